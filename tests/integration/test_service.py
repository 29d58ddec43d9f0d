"""Integration tests of hgraph-server: a real server on a loopback port, driven from the Python
client (and, in test_cli_remote, from the C++ CLI). Every test that starts a server stops it.

Run through CTest (which sets the environment), or by hand:
    HGRAPH_SERVER=build/hgraph-server HGRAPH_CLI=build/hgraph \
    PYTHONPATH=client/python:build/python /usr/bin/python3 -m pytest tests/integration
"""
import concurrent.futures
import json
import os
import pathlib
import re
import signal
import socket
import subprocess
import threading
import time
import urllib.request

import grpc
import pytest

import hgraph_client
from google.protobuf import json_format
from hgraph.v1 import merge_pb2, scene_pb2, service_pb2
from server_process import ServerProcess

ROOT = pathlib.Path(__file__).resolve().parents[2]
DATA = ROOT / "tests" / "data" / "circles"
SERVER = os.environ.get("HGRAPH_SERVER", str(ROOT / "build" / "hgraph-server"))
CLI = os.environ.get("HGRAPH_CLI", str(ROOT / "build" / "hgraph"))


class Server(ServerProcess):
    """One hgraph-server process on 127.0.0.1 with free ports picked by the server itself."""

    def __init__(self, *flags):
        threads = [] if "--threads" in flags else ["--threads", "2"]
        # No drain on SIGTERM unless a test asks for one: stopping servers stays quick.
        drain = [] if "--drain-s" in flags else ["--drain-s", "0"]
        super().__init__(SERVER, "--listen", "127.0.0.1:0", "--metrics-listen", "127.0.0.1:0",
                         *threads, *drain, *flags)

    def client(self) -> hgraph_client.Client:
        return hgraph_client.connect(self.target)

    def metrics(self) -> str:
        url = f"http://127.0.0.1:{self.metrics_port}/metrics"
        return urllib.request.urlopen(url, timeout=5).read().decode()

    def metric(self, name: str, **labels) -> float:
        total = 0.0
        for line in self.metrics().splitlines():
            if line.startswith("#") or not line.startswith(name):
                continue
            series, value = line.rsplit(" ", 1)
            if series.split("{")[0] != name:
                continue
            if all(f'{k}="{v}"' in series for k, v in labels.items()):
                total += float(value)
        return total

    def stop(self, timeout=20) -> int:
        return super().stop(timeout)


@pytest.fixture(scope="module")
def server():
    s = Server("--max-paths", "8")
    yield s
    assert s.stop() == 0, "".join(s.log)


@pytest.fixture
def client(server):
    with server.client() as c:
        c.create_session(c.upload_scene(DATA / "scene.json"))
        yield c


def input_paths():
    return hgraph_client.load_paths_text((DATA / "paths.txt").read_text())


def densified(n):
    """The two inputs with every edge cut into n pieces: still valid, and an all-pairs merge of
    them takes seconds (long enough to cancel)."""
    out = []
    for path in input_paths().paths:
        w = [list(q.values) for q in path.waypoints]
        dense = []
        for a, b in zip(w, w[1:]):
            for i in range(n):
                dense.append([a[j] + (b[j] - a[j]) * i / n for j in range(len(a))])
        dense.append(w[-1])
        out.append(dense)
    return out


def test_health_and_reflection(server):
    channel = grpc.insecure_channel(server.target)
    check = channel.unary_unary("/grpc.health.v1.Health/Check")
    # HealthCheckResponse{status: SERVING} is field 1 = 1.
    assert check(b"", timeout=5) == b"\x08\x01"
    # HealthCheckRequest{service: "hgraph.v1.PathMerger"}.
    name = b"hgraph.v1.PathMerger"
    assert check(b"\x0a" + bytes([len(name)]) + name, timeout=5) == b"\x08\x01"
    # ServerReflectionRequest{list_services: ""} (field 7).
    reflect = channel.stream_stream("/grpc.reflection.v1alpha.ServerReflection/ServerReflectionInfo")
    responses = list(reflect(iter([b"\x3a\x00"]), timeout=5))
    assert b"hgraph.v1.PathMerger" in responses[0]
    assert b"grpc.health.v1.Health" in responses[0]
    channel.close()


def test_merge_streams_progress_then_requery_reuses_checks(client):
    events = []
    # Eager: every edge checked with its profile up front, so later measures need no new work.
    merged = client.merge(input_paths(), measure="inverse-clearance", variant="all-pairs",
                          evaluation="eager", optimize_ms=0, on_progress=events.append,
                          progress_interval_ms=1)
    assert merged.progress_events >= 1 and events
    assert {e.phase for e in events} <= {"validate", "inputs", "align", "candidates", "check",
                                         "clearance", "search", "evaluate", "optimize"}
    result = merged.result
    assert merged.hgraph.startswith(client.session + "/hgraphs/")
    assert result.quality.length <= min(i.quality.length for i in result.inputs if i.valid)
    assert result.stats.collision_checks > 0

    # Clearance profiles were computed for the first measure: other measures need no new work.
    for measure in ("bottleneck-clearance", "length", "safe-length"):
        again = client.requery(merged.hgraph, measure, safety=0.5)
        assert again.stats.collision_checks == 0, measure
        assert again.stats.distance_queries == 0, measure
        assert again.stats.edges_checked == 0, measure
        assert again.stats.edges_reused > 0, measure
    assert client.get_session().hgraphs == [merged.hgraph]


def test_partial_shortcuts_leave_a_space_of_one_part_alone(client):
    """The circles' point robot moves in R^2 alone: no part to move on its own, so the option
    reaches the server and changes nothing (the CLI's mesh case shows what it changes)."""
    plain = client.merge(input_paths()).result
    partial = client.merge(input_paths(), partial_shortcuts=True).result
    assert partial.path == plain.path
    assert partial.stats.edges_checked == plain.stats.edges_checked


def test_progress_paths_stream_the_best_path_so_far(client):
    """The post-optimization streams the best path's objective, and with progress_paths the
    path itself: each one certified by the service's own check, from start to goal, of the
    length its event names; the objectives only fall, and the result is no worse than the last.
    Without progress_paths the events carry the objective alone."""
    inputs = [[list(q.values) for q in p.waypoints] for p in input_paths().paths]
    for with_paths in (True, False):
        events = []
        merged = client.merge(input_paths(), progress_paths=with_paths, on_progress=events.append)
        optimize = [e for e in events if e.phase == "optimize"]
        # (One may replace another that waited behind a write; the last always comes.)
        assert optimize, events
        assert all(e.objective is not None for e in optimize)
        assert all(e.objective is None and e.path is None for e in events
                   if e.phase != "optimize")
        assert optimize[0].objective <= merged.result.hgraph_objective + 1e-9
        assert all(b.objective < a.objective for a, b in zip(optimize, optimize[1:]))
        assert merged.result.objective <= optimize[-1].objective + 1e-9
        if not with_paths:
            assert all(e.path is None for e in optimize)
            continue
        checked = client.check([e.path for e in optimize])
        for event, report in zip(optimize, checked.paths):
            assert report.valid and report.certified, report
            assert report.quality.length == pytest.approx(event.objective, rel=1e-7)
            assert list(event.path.waypoints[0].values) == pytest.approx(inputs[0][0])
            assert list(event.path.waypoints[-1].values) == pytest.approx(inputs[0][-1])


def test_restarts_reach_the_post_optimization(client):
    """optimize_restarts through the service: more rounds, a path no longer than without them
    and certified; a negative count is refused naming the field."""
    plain = client.merge(input_paths()).result
    restarted = client.merge(input_paths(), restarts=2).result
    assert restarted.stats.optimize_rounds > plain.stats.optimize_rounds
    assert restarted.objective <= plain.objective + 1e-9
    report = client.check([restarted.path]).paths[0]
    assert report.valid and report.certified
    with pytest.raises(hgraph_client.HgraphError) as error:
        client.merge(input_paths(), restarts=-1)
    assert error.value.code == grpc.StatusCode.INVALID_ARGUMENT
    assert "options.optimize_restarts" in error.value.message


def test_sampled_merge_is_marked_uncertified(client):
    """check_mode sampled: every motion checked at its samples only (no distance query under
    length), and the result says so (check_mode echoed, certified False with presence), also on
    a requery of its H-Graph; its path passes the sampled check from start to goal. The default
    says certified. An unknown mode is refused naming the field."""
    plain = client.merge(input_paths()).result
    assert plain.HasField("certified") and plain.certified
    assert plain.check_mode == merge_pb2.CHECK_MODE_CERTIFIED
    assert plain.stats.distance_queries > 0

    merged = client.merge(input_paths(), check="sampled")
    sampled = merged.result
    assert sampled.HasField("certified") and not sampled.certified
    assert sampled.check_mode == merge_pb2.CHECK_MODE_SAMPLED
    assert sampled.stats.distance_queries == 0 and sampled.stats.collision_checks > 0
    assert not sampled.quality.has_clearance
    report = client.check([sampled.path], sampled=True).paths[0]
    assert report.valid and not report.certified, report
    assert report.quality.length == pytest.approx(sampled.quality.length, rel=1e-9)
    inputs = [[list(q.values) for q in p.waypoints] for p in input_paths().paths]
    assert list(sampled.path.waypoints[0].values) == pytest.approx(inputs[0][0])
    assert list(sampled.path.waypoints[-1].values) == pytest.approx(inputs[0][-1])

    again = client.requery(merged.hgraph, "bottleneck-clearance")
    assert again.HasField("certified") and not again.certified
    assert again.check_mode == merge_pb2.CHECK_MODE_SAMPLED

    with pytest.raises(hgraph_client.HgraphError) as e:
        client.merge(input_paths(), options=merge_pb2.MergeOptions(check_mode=7))
    assert e.value.code == grpc.StatusCode.INVALID_ARGUMENT
    assert "options.check_mode" in e.value.message and e.value.field == "options.check_mode"
    with pytest.raises(ValueError, match="check"):
        client.merge(input_paths(), check="approximately")


def test_requery_counts_what_it_added_against_the_cache(server, client):
    """A requery grows its stored H-Graph (here the post-optimization's points under length,
    after a merge under inverse clearance that has none): the cache counts the H-Graph at its new
    size, so that --cache-bytes bounds what stored H-Graphs hold."""
    merged = client.merge(input_paths(), measure="inverse-clearance")
    assert merged.result.stats.optimize_rounds == 0
    before = server.metric("hgraph_cache_bytes", kind="hgraph")
    again = client.requery(merged.hgraph, "length")
    assert again.stats.optimize_rounds > 0
    assert server.metric("hgraph_cache_bytes", kind="hgraph") > before


def test_stop_merge_keeps_the_best_path_so_far(client):
    """A client that stops a merge on its first streamed path keeps that path (certified, of
    its objective) as an incomplete outcome; stopped before any path came, it gets CANCELLED.
    The server's worker is freed either way: the next merge completes."""
    def stop_at_first_path(progress):
        if progress.path is not None:
            raise hgraph_client.StopMerge()

    stopped = client.merge(input_paths(), progress_paths=True, on_progress=stop_at_first_path)
    assert not stopped.complete and stopped.hgraph == ""
    assert stopped.result.path.name == "merged" and len(stopped.result.path.waypoints) >= 2
    report = client.check([stopped.result.path]).paths[0]
    assert report.valid and report.certified
    assert report.quality.length == pytest.approx(stopped.result.objective, rel=1e-7)
    full = client.merge(input_paths())
    assert full.complete
    # The first path is the H-Graph's optimum or a later improvement; never better than the end.
    assert full.result.objective <= stopped.result.objective + 1e-9

    def stop_at_once(progress):
        raise hgraph_client.StopMerge()

    with pytest.raises(hgraph_client.HgraphError) as error:
        client.merge(input_paths(), progress_paths=True, on_progress=stop_at_once)
    assert error.value.code == grpc.StatusCode.CANCELLED
    assert client.merge(input_paths()).complete


def test_requery_computes_missing_profiles_once(client):
    merged = client.merge(input_paths(), measure="length", variant="all-pairs",
                          evaluation="eager", optimize_ms=0)
    first = client.requery(merged.hgraph, "inverse-clearance")
    assert first.stats.distance_queries > 0  # length needed no profiles; they are made now
    second = client.requery(merged.hgraph, "bottleneck-clearance")
    assert second.stats.collision_checks == 0 and second.stats.distance_queries == 0


def test_lazy_requery_profiles_only_what_its_search_wants(client):
    # A bottleneck re-query after a length merge: eager profiles every valid edge, lazy the
    # nodes and the edges its search settles through. Same widest path either way.
    results = {}
    for evaluation in ("eager", "lazy"):
        merged = client.merge(input_paths(), measure="length", variant="all-pairs",
                              evaluation=evaluation, optimize_ms=0)
        results[evaluation] = client.requery(merged.hgraph, "bottleneck-clearance")
    eager, lazy = results["eager"], results["lazy"]
    assert lazy.objective == pytest.approx(eager.objective, rel=1e-9)
    assert lazy.quality.length == pytest.approx(eager.quality.length, rel=1e-9)
    assert 0 < lazy.stats.distance_queries < eager.stats.distance_queries
    assert lazy.stats.node_clearances > 0


def test_add_paths_grows_the_stored_hgraph(client):
    paths = [[list(q.values) for q in p.waypoints] for p in input_paths().paths]
    first = client.merge([paths[0]], variant="all-pairs", optimize_ms=0)
    added = client.add_paths(first.hgraph, [paths[1]])
    assert added.hgraph == first.hgraph
    assert added.candidates_added > 0
    grown = added.result
    assert len(grown.inputs) == 2
    assert grown.objective <= first.result.objective + 1e-9
    assert grown.stats.edges_reused > 0  # what the first merge checked is not checked again
    # All-pairs either way: the same candidates as merging both at once, so the same optimum.
    together = client.merge(paths, variant="all-pairs", optimize_ms=0)
    assert grown.objective == pytest.approx(together.result.objective, rel=1e-9)
    # The paths stay in the H-Graph: a requery sees both inputs.
    assert len(client.requery(first.hgraph, "bottleneck-clearance").inputs) == 2
    # A path that misses the start is refused, named as the request holds it, and the H-Graph
    # is unchanged; so is a batch past --max-paths in all.
    stray = [list(q) for q in paths[1]]
    stray[0][0] += 1.0
    with pytest.raises(hgraph_client.HgraphError) as e:
        client.add_paths(first.hgraph, [paths[1], stray])
    assert e.value.code == grpc.StatusCode.INVALID_ARGUMENT
    assert e.value.message.startswith("paths.paths[1].waypoints[0]: "), e.value.message
    with pytest.raises(hgraph_client.HgraphError) as e:
        client.add_paths(first.hgraph, [paths[1]] * 7)
    assert e.value.code == grpc.StatusCode.RESOURCE_EXHAUSTED
    assert "--max-paths" in e.value.message
    assert len(client.requery(first.hgraph, "length").inputs) == 2
    with pytest.raises(hgraph_client.HgraphError) as e:
        client.add_paths(client.session + "/hgraphs/999", [paths[1]])
    assert e.value.code == grpc.StatusCode.NOT_FOUND and "hgraph" in e.value.message


def test_upload_chunked_blob_and_mesh_scene(server):
    with server.client() as c:
        # 5 MiB is more than gRPC's default 4 MiB message: the client sends 1 MiB chunks.
        blob = bytes((i * 7919) % 251 for i in range(5 << 20))
        digest = c.upload_blob(blob)
        missing = c.stub.FindMissingBlobs(service_pb2.FindMissingBlobsRequest(digests=[digest]))
        assert list(missing.missing) == []
        wrench = ROOT / "scenes" / "wrench" / "scene.json"
        if wrench.exists():
            scene_digest = c.upload_scene(wrench)
            assert c.upload_scene(wrench) == scene_digest  # content-addressed


def test_upload_with_wrong_digest_is_rejected(server):
    with server.client() as c:
        bad = scene_pb2.Digest(sha256="0" * 64, size_bytes=3)
        with pytest.raises(grpc.RpcError) as e:
            c.stub.UploadBlob(iter([service_pb2.UploadBlobRequest(digest=bad, data=b"abc")]))
        assert e.value.code() == grpc.StatusCode.INVALID_ARGUMENT
        assert "digest.sha256" in e.value.details()


def test_put_scene_names_field_of_file_path_mesh(server):
    channel = grpc.insecure_channel(server.target)
    from hgraph.v1 import service_pb2_grpc
    stub = service_pb2_grpc.PathMergerStub(channel)
    scene = scene_pb2.Scene()
    scene.space.components.add(type=1, dimension=2, lower=[0, 0], upper=[1, 1])
    scene.robot.add(name="r").shape.mesh.path = "/etc/passwd"
    with pytest.raises(grpc.RpcError) as e:
        stub.PutScene(service_pb2.PutSceneRequest(scene=scene), timeout=5)
    assert e.value.code() == grpc.StatusCode.INVALID_ARGUMENT
    assert "scene.robot[0].shape.mesh.path" in e.value.details()
    channel.close()


def test_plan_then_merge_planned_paths(client):
    planned = client.plan(count=3, planner="rrtconnect", time_per_path_s=2.0, seed=7,
                          start=[30, 62], goal=[67, 35])
    assert len(planned) == 3 and planned.failures == []
    merged = client.merge(planned, measure="length")
    assert merged.result.quality.length <= min(i.quality.length for i in merged.result.inputs)


def test_solve_streams_improvements_and_keeps_its_hgraph(client):
    events = []
    solved = client.solve(1.0, portfolio={"prm": 2, "rrtconnect": 2}, seed=5,
                          start=[30, 62], goal=[67, 35], on_progress=events.append, timeout=30)
    assert solved.found, solved.result.message
    assert [e for e in events] == solved.progress
    runs = [e.run for e in events if e.HasField("run")]
    assert sorted(r.index for r in runs) == [0, 1, 2, 3]
    assert {r.planner for r in runs} == {"prm", "rrtconnect"}
    assert len(solved.result.runs) == 4
    # Two workers: at most one run beside the call's own worker, which plans too.
    assert 1 <= solved.result.most_runs_at_once <= 2
    found = [r for r in solved.result.runs if r.found]
    # Every path found went into the H-Graph; the result is no longer than any certified input.
    assert 1 <= len(solved.result.merge.inputs) <= len(found)
    for r in found:
        if r.certified:
            assert solved.result.merge.objective <= r.length + 1e-9
    improvements = [e.objective for e in events if e.HasField("objective")]
    assert improvements and improvements == sorted(improvements, reverse=True)
    assert abs(improvements[-1] - solved.result.merge.objective) < 1e-9
    # The path is certified by the same check a merge makes.
    assert client.check([solved.path]).valid
    assert list(solved.path.waypoints[0].values) == [30, 62]
    assert list(solved.path.waypoints[-1].values) == [67, 35]
    # Kept as a merge's H-Graph: requery, add_paths and get_hgraph take its name.
    assert solved.kept and solved.generation == 1
    again = client.requery(solved.hgraph, measure="length")
    assert again.quality.length <= max(r.length for r in found) + 1e-9
    planned = client.plan(count=1, planner="rrtconnect", seed=11, start=[30, 62], goal=[67, 35])
    grown = client.add_paths(solved.hgraph, planned)
    assert grown.generation == 2 and len(grown.result.inputs) == len(found) + 1
    assert len(client.get_hgraph(solved.hgraph).inputs) == len(found) + 1
    assert list(client.get_hgraph(solved.hgraph).inputs)[:len(found)] == [
        r.path_name for r in runs if r.found]


def test_solve_plans_on_the_worker_pool_as_many_at_once_as_it_has_free_workers():
    # A pool of one worker: the Solve's own job is the only worker, so every run is planned
    # there, one at a time between merges, however many runs `parallel` allows.
    s = Server("--threads", "1")
    try:
        with s.client() as c:
            c.create_session(c.upload_scene(DATA / "scene.json"))
            solved = c.solve(1.0, portfolio={"prm": 3, "rrtconnect": 1}, parallel=4, seed=5,
                             start=[30, 62], goal=[67, 35], timeout=30)
            assert solved.found, solved.result.message
            started = [r for r in solved.result.runs if not r.message.startswith("not started")]
            assert started
            assert solved.result.most_runs_at_once == 1
            assert solved.result.runs_on_call_worker == len(started)
    finally:
        assert s.stop() == 0, "".join(s.log)


def test_solve_without_a_path_in_its_budget_says_no_path_was_found(client):
    # The circles scene with a wall across the whole space between start and goal.
    scene = json_format.Parse((DATA / "scene.json").read_text(), scene_pb2.Scene())
    wall = scene.obstacles.add(name="wall")
    wall.shape.box.size.extend([400, 2, 2])
    wall.pose.position.extend([40, 48.5, 0])
    client.create_session(client.upload_scene(scene))
    solved = client.solve(0.3, portfolio={"rrtconnect": 2}, start=[30, 62], goal=[67, 35],
                          timeout=30)
    assert not solved.found and solved.hgraph == "" and solved.path is None
    assert "no path found in 0.3 s" in solved.result.message
    assert len(solved.result.runs) == 2
    assert not any(r.found for r in solved.result.runs)


def test_solve_bad_input_names_the_field(client):
    cases = [(dict(budget_s=-1), "budget_s"),
             (dict(portfolio={"no-such-planner": 1}), "portfolio[0].planner"),
             (dict(portfolio=[("prm", 1), ("rrt", -1)]), "portfolio[1].runs"),
             (dict(start=[27, 15], goal=[67, 35]), "start"),
             (dict(start=[30, 62], goal=[27, 15]), "goal"),
             (dict(plan_fraction=1.5, start=[30, 62], goal=[67, 35]), "plan_fraction")]
    for kwargs, field in cases:
        kwargs.setdefault("start", [30, 62])
        kwargs.setdefault("goal", [67, 35])
        with pytest.raises(hgraph_client.HgraphError) as e:
            client.solve(**{"budget_s": 0.5, "timeout": 30, **kwargs})
        assert e.value.code == grpc.StatusCode.INVALID_ARGUMENT, (kwargs, e.value)
        assert e.value.field == field, (kwargs, e.value.field, str(e.value))
        assert field in str(e.value)


def test_cancelling_a_solve_stops_its_planners(server, client):
    before = server.metric("grpc_server_handled_total", grpc_method="Solve",
                           grpc_code="CANCELLED")
    request = service_pb2.SolveRequest(
        session=client.session, budget_s=60,
        portfolio=[service_pb2.PortfolioEntry(planner="bitstar", runs=2)])
    request.start.values.extend([30, 62])
    request.goal.values.extend([67, 35])
    call = client.stub.Solve(request, timeout=120, metadata=client._metadata(client.session))
    time.sleep(0.5)
    call.cancel()
    with pytest.raises(grpc.RpcError) as e:
        for _ in call:
            pass
    assert e.value.code() == grpc.StatusCode.CANCELLED
    # The planners stopped and the worker is free: the call is recorded as CANCELLED long before
    # its 60 s budget, and a merge completes.
    for _ in range(400):
        if server.metric("grpc_server_handled_total", grpc_method="Solve",
                         grpc_code="CANCELLED") > before:
            break
        time.sleep(0.05)
    else:
        raise AssertionError("the cancelled Solve was never finished")
    merged = client.merge(input_paths(), measure="length", timeout=10)
    assert merged.result.stats.collision_checks > 0


def test_cancel_mid_merge_frees_the_workers(server, client):
    before = server.metric("grpc_server_handled_total", grpc_method="MergePaths",
                           grpc_code="CANCELLED")
    request = service_pb2.MergePathsRequest(
        session=client.session, paths=hgraph_client.make_paths(densified(40)),
        options=merge_pb2.MergeOptions(variant=merge_pb2.VARIANT_ALL_PAIRS),
        progress_interval_ms=10)
    call = client.merge_stream(request, timeout=60)
    for event in call:
        if event.HasField("progress") and event.progress.phase == "check":
            call.cancel()
            break
    with pytest.raises(grpc.RpcError) as e:
        for _ in call:
            pass
    assert e.value.code() == grpc.StatusCode.CANCELLED
    # The workers are free again: a small merge completes promptly.
    merged = client.merge(input_paths(), measure="length", timeout=10)
    assert merged.result.stats.collision_checks > 0
    # The cancelled call is recorded as CANCELLED once its worker has stopped (polled).
    for _ in range(400):
        if server.metric("grpc_server_handled_total", grpc_method="MergePaths",
                         grpc_code="CANCELLED") > before:
            break
        time.sleep(0.05)
    else:
        raise AssertionError("the cancelled merge was never finished")


def test_deadline_exceeded(client):
    with pytest.raises(hgraph_client.HgraphError) as e:
        # Eager all-pairs on densified inputs: seconds of checks, far past the deadline.
        client.merge(densified(40), variant="all-pairs", evaluation="eager", timeout=0.5)
    assert e.value.code == grpc.StatusCode.DEADLINE_EXCEEDED
    assert client.merge(input_paths(), timeout=10).result.quality.length > 0


def test_unknown_session_and_hgraph(client):
    unknown = "sessions/" + "0" * 32
    with pytest.raises(hgraph_client.HgraphError) as e:
        client.merge(input_paths(), session=unknown)
    assert e.value.code == grpc.StatusCode.NOT_FOUND and "session" in e.value.message
    with pytest.raises(hgraph_client.HgraphError) as e:
        client.merge(input_paths(), session="sessions/not-hex")
    assert e.value.code == grpc.StatusCode.INVALID_ARGUMENT and "session" in e.value.message
    with pytest.raises(hgraph_client.HgraphError) as e:
        client.requery(client.session + "/hgraphs/999", "length")
    assert e.value.code == grpc.StatusCode.NOT_FOUND and "hgraph" in e.value.message
    with pytest.raises(hgraph_client.HgraphError) as e:
        client.get_session(unknown)
    assert e.value.code == grpc.StatusCode.NOT_FOUND


def test_client_repeats_calls_only_after_transient_errors(client):
    """Requery, the reads and add_paths with a request_id are repeated as they are after
    UNAVAILABLE (nothing listens: a replica restarting), `retries` times; NOT_FOUND is raised at
    once, and add_paths without a request_id is never repeated (it could add twice)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        closed = f"127.0.0.1:{s.getsockname()[1]}"
    hgraph = "sessions/" + "0" * 32 + "/hgraphs/x"
    with hgraph_client.Client(closed, retries=2, backoff_s=0.01) as down:
        for call in (lambda: down.requery(hgraph, "length"), lambda: down.get_hgraph(hgraph),
                     lambda: down.get_session("sessions/" + "0" * 32),
                     lambda: down.list_sessions(),
                     lambda: down.add_paths(hgraph, input_paths(), request_id="r1")):
            before = down.repeats
            with pytest.raises(hgraph_client.HgraphError) as e:
                call()
            assert e.value.code == grpc.StatusCode.UNAVAILABLE and e.value.transient
            assert down.repeats == before + 2
        with pytest.raises(hgraph_client.HgraphError):
            down.add_paths(hgraph, input_paths())
        assert down.repeats == 10
    with pytest.raises(hgraph_client.HgraphError) as e:
        client.requery(client.session + "/hgraphs/999", "length")
    assert e.value.code == grpc.StatusCode.NOT_FOUND and not e.value.transient
    assert client.repeats == 0


def test_over_limit_batch_and_bad_values(client):
    with pytest.raises(hgraph_client.HgraphError) as e:
        client.merge([input_paths().paths[0]] * 9)
    assert e.value.code == grpc.StatusCode.RESOURCE_EXHAUSTED
    assert "paths.paths" in e.value.message and "--max-paths" in e.value.message
    with pytest.raises(hgraph_client.HgraphError) as e:
        client.merge(input_paths(), measure="inverse-clearance", k=-1)
    assert e.value.code == grpc.StatusCode.INVALID_ARGUMENT and "measure.k" in e.value.message
    with pytest.raises(hgraph_client.HgraphError) as e:
        client.merge(input_paths(), measure="safe-length", safety=1000)
    assert e.value.code == grpc.StatusCode.FAILED_PRECONDITION
    assert "measure.safety" in e.value.message
    # A bad waypoint is named as the request holds it, as CheckPaths names it.
    paths = [[list(q.values) for q in p.waypoints] for p in input_paths().paths]
    paths[1][2] = [float("inf"), 1.0]
    with pytest.raises(hgraph_client.HgraphError) as e:
        client.merge(paths)
    assert e.value.code == grpc.StatusCode.INVALID_ARGUMENT
    assert e.value.message.startswith("paths.paths[1].waypoints[2][0]: "), e.value.message
    with pytest.raises(hgraph_client.HgraphError) as e:
        client.merge(input_paths(), max_node_spacing=-1)
    assert e.value.code == grpc.StatusCode.INVALID_ARGUMENT
    assert "options.max_node_spacing" in e.value.message


def test_check_paths_reports_what_merge_reports(client):
    merged = client.merge(input_paths(), measure="inverse-clearance", k=2,
                          report_inputs=True).result
    checked = client.check(input_paths(), k=2)
    assert checked.valid and len(checked.paths) == 2
    assert checked.collision_checks > 0 and checked.distance_queries > 0
    assert checked.resolution == pytest.approx(0.001)  # the scene's
    for mine, theirs in zip(checked.paths, merged.inputs):
        assert theirs.checked
        assert mine.name == theirs.name
        assert mine.certified == theirs.certified
        assert mine.quality == theirs.quality  # bit for bit: the same check

    # Straight through disc6 (centre 39, 44.5, radius 6), and a path leaving the bounds; the
    # paths need not share endpoints, and one waypoint is enough.
    bad = client.check([[[30.0, 44.5], [31.0, 44.5], [48.0, 44.5]],
                        [[70.0, 10.0], [79.0, 10.0], [90.0, 10.0]],
                        [[1.0, 1.0]]])
    assert not bad.valid
    through, out, point = bad.paths
    assert not through.valid and through.invalid_edge == 1
    assert through.invalid_cause == merge_pb2.InputReport.CAUSE_COLLISION
    assert 0 <= through.invalid_at <= 1
    assert through.invalid_reason.startswith("edge 1 -> 2 is in collision at t=")
    assert through.quality.length == pytest.approx(18.0)
    assert not out.valid and out.invalid_edge == 1
    assert out.invalid_cause == merge_pb2.InputReport.CAUSE_OUT_OF_BOUNDS
    assert "leaves the space's bounds" in out.invalid_reason
    assert point.valid and point.waypoints == 1 and point.quality.min_clearance > 0

    sampled = client.check(input_paths(), sampled=True)
    assert sampled.valid and sampled.distance_queries == 0
    assert not any(p.certified for p in sampled.paths)


def test_length_merge_reports_its_clearance_on_request(client):
    plain = client.merge(input_paths()).result
    profiled = client.merge(input_paths(), report_clearance=True).result
    assert ([list(w.values) for w in plain.path.waypoints]
            == [list(w.values) for w in profiled.path.waypoints])
    assert not plain.quality.has_clearance
    assert plain.quality.min_clearance == 0 and plain.quality.avg_clearance == 0
    assert profiled.quality.has_clearance and profiled.quality.min_clearance > 0
    assert plain.stats.distance_queries < profiled.stats.distance_queries
    check = client.check([[list(w.values) for w in plain.path.waypoints]]).paths[0]
    assert check.valid and check.certified and check.quality.has_clearance
    assert check.quality.min_clearance == pytest.approx(profiled.quality.min_clearance, rel=0.01)


def test_requery_reports_its_clearance_on_request(client):
    """A requery (or AddPaths) under length profiles its path when it asks; the profiles stay."""
    paths = [[list(q.values) for q in p.waypoints] for p in input_paths().paths]
    merged = client.merge([paths[0]], optimize_ms=0)
    assert not merged.result.quality.has_clearance
    plain = client.requery(merged.hgraph, "length")
    assert not plain.quality.has_clearance and plain.quality.min_clearance == 0
    profiled = client.requery(merged.hgraph, "length", report_clearance=True)
    assert profiled.quality.has_clearance and profiled.quality.min_clearance > 0
    assert profiled.stats.distance_queries > 0
    assert ([list(w.values) for w in plain.path.waypoints]
            == [list(w.values) for w in profiled.path.waypoints])
    check = client.check([[list(w.values) for w in profiled.path.waypoints]]).paths[0]
    assert check.quality.min_clearance == pytest.approx(profiled.quality.min_clearance, rel=0.01)
    # The H-Graph keeps them: the next query reports them without a distance query.
    again = client.requery(merged.hgraph, "length")
    assert again.quality.has_clearance and again.stats.distance_queries == 0
    assert again.quality.min_clearance == profiled.quality.min_clearance
    added = client.add_paths(merged.hgraph, [paths[1]], report_clearance=True).result
    assert added.quality.has_clearance and added.quality.min_clearance > 0


def test_check_paths_errors_name_the_field(client):
    paths = [[list(q.values) for q in p.waypoints] for p in input_paths().paths]
    paths[1][3] = [float("nan"), 1.0]
    with pytest.raises(hgraph_client.HgraphError) as e:
        client.check(paths)
    assert e.value.code == grpc.StatusCode.INVALID_ARGUMENT
    assert "paths.paths[1].waypoints[3]" in e.value.message
    paths[1][3] = [1.0, 2.0, 3.0]
    with pytest.raises(hgraph_client.HgraphError) as e:
        client.check(paths)
    assert e.value.code == grpc.StatusCode.INVALID_ARGUMENT
    assert "paths.paths[1].waypoints[3]" in e.value.message and "coordinates" in e.value.message
    with pytest.raises(hgraph_client.HgraphError) as e:
        client.check([])
    assert e.value.code == grpc.StatusCode.INVALID_ARGUMENT and "paths.paths" in e.value.message
    with pytest.raises(hgraph_client.HgraphError) as e:
        client.check(input_paths(), resolution=-0.5)
    assert e.value.code == grpc.StatusCode.INVALID_ARGUMENT and "resolution" in e.value.message
    with pytest.raises(hgraph_client.HgraphError) as e:
        client.check(input_paths(), k=-1)
    assert e.value.code == grpc.StatusCode.INVALID_ARGUMENT and "k:" in e.value.message
    with pytest.raises(hgraph_client.HgraphError) as e:
        client.check(input_paths(), session="sessions/" + "0" * 32)
    assert e.value.code == grpc.StatusCode.NOT_FOUND and "session" in e.value.message
    # The server's limits, as for MergePaths (the module's server has --max-paths 8).
    with pytest.raises(hgraph_client.HgraphError) as e:
        client.check([input_paths().paths[0]] * 9)
    assert e.value.code == grpc.StatusCode.RESOURCE_EXHAUSTED
    assert "paths.paths" in e.value.message and "--max-paths" in e.value.message


def test_sessions_list_get_delete(server):
    with server.client() as c:
        scene = c.upload_scene(DATA / "scene.json")
        a = c.create_session(scene)
        b = c.create_session(scene)
        assert a.name != b.name and re.fullmatch(r"sessions/[0-9a-f]{32}", a.name)
        names = {s.name for s in c.list_sessions()}
        assert {a.name, b.name} <= names
        c.delete_session(a.name)
        with pytest.raises(hgraph_client.HgraphError) as e:
            c.get_session(a.name)
        assert e.value.code == grpc.StatusCode.NOT_FOUND
        assert c.get_session(b.name).scene == scene


def test_two_sessions_on_one_scene_load_it_once(server):
    with server.client() as c:
        # A scene no other test uses, so that its first load is this test's.
        scene = scene_pb2.Scene()
        from google.protobuf import json_format
        json_format.Parse((DATA / "scene.json").read_text(), scene)
        scene.description = "test_two_sessions_on_one_scene_load_it_once"
        loads = server.metric("hgraph_scene_loads_total")
        hits = server.metric("hgraph_scene_cache_hits_total")
        digest = c.upload_scene(scene)
        first = c.create_session(digest)
        second = c.create_session(digest)
        assert first.scene == second.scene
        assert server.metric("hgraph_scene_loads_total") == loads + 1
        assert server.metric("hgraph_scene_cache_hits_total") >= hits + 2


def test_admission_queue_full_is_resource_exhausted():
    s = Server("--threads", "1", "--max-pending", "1")
    try:
        with s.client() as c:
            c.create_session(c.upload_scene(DATA / "scene.json"))
            request = service_pb2.MergePathsRequest(
                session=c.session, paths=hgraph_client.make_paths(densified(40)),
                options=merge_pb2.MergeOptions(variant=merge_pb2.VARIANT_ALL_PAIRS))
            call = c.merge_stream(request, timeout=60)
            next(call)  # the slow merge is running and holds the only admission slot
            with pytest.raises(hgraph_client.HgraphError) as e:
                c.merge(input_paths(), timeout=10)
            assert e.value.code == grpc.StatusCode.RESOURCE_EXHAUSTED
            assert "--max-pending" in e.value.message
            call.cancel()
    finally:
        assert s.stop() == 0, "".join(s.log)


def test_sequential_calls_with_one_admission_slot_are_never_busy():
    # A call's slot is free by the time its answer arrives: a client that waits for each answer
    # before its next call never meets RESOURCE_EXHAUSTED, however small --max-pending is.
    s = Server("--threads", "1", "--max-pending", "1")
    try:
        with s.client() as c:
            digest = c.upload_scene(DATA / "scene.json")
            for _ in range(25):
                c.create_session(digest)
                result = c.merge(input_paths(), variant="edit-distance", optimize_ms=0)
                assert c.requery(result.hgraph, "length").stats.edges_reused > 0
    finally:
        assert s.stop() == 0, "".join(s.log)


def test_eviction_under_a_small_budget_gives_not_found(server):
    budget = 300_000
    s = Server("--cache-bytes", str(budget))
    try:
        with s.client() as c:
            c.create_session(c.upload_scene(DATA / "scene.json"))
            first_session = c.session
            first = c.merge(input_paths(), variant="all-pairs", measure="inverse-clearance",
                            evaluation="eager")
            assert first.hgraph
            # A second scene and its H-Graph push the first scene's entries out.
            scene = scene_pb2.Scene()
            from google.protobuf import json_format
            json_format.Parse((DATA / "scene.json").read_text(), scene)
            scene.description = "another scene"
            c.create_session(c.upload_scene(scene))
            second = c.merge(input_paths(), variant="all-pairs", measure="inverse-clearance",
                             evaluation="eager", optimize_ms=0)
            assert second.hgraph
            assert s.metric("hgraph_cache_bytes") <= budget
            assert s.metric("hgraph_cache_evictions_total") > 0
            with pytest.raises(hgraph_client.HgraphError) as e:
                c.requery(first.hgraph, "length")
            assert e.value.code == grpc.StatusCode.NOT_FOUND
            with pytest.raises(hgraph_client.HgraphError) as e:
                c.merge(input_paths(), session=first_session)
            assert e.value.code == grpc.StatusCode.NOT_FOUND and "PutScene" in e.value.message
            assert c.requery(second.hgraph, "length").stats.collision_checks == 0
            # A merge whose H-Graph alone exceeds the budget still returns its result.
            big = c.merge(densified(30), variant="all-pairs")
            assert big.hgraph == "" and big.result.quality.length > 0
            assert s.metric("hgraph_cache_bytes") <= budget
    finally:
        assert s.stop() == 0, "".join(s.log)


HEALTH_SERVING, HEALTH_NOT_SERVING = b"\x08\x01", b"\x08\x02"


def test_sigterm_drains_then_cancels_in_flight_merge_after_grace_and_exits_0():
    drain_s, grace_s = 1.0, 0.5
    s = Server("--grace-s", str(grace_s), "--drain-s", str(drain_s))
    with s.client() as c:
        health = c.channel.unary_unary("/grpc.health.v1.Health/Check")
        assert health(b"", timeout=5) == HEALTH_SERVING
        c.create_session(c.upload_scene(DATA / "scene.json"))
        request = service_pb2.MergePathsRequest(
            session=c.session, paths=hgraph_client.make_paths(densified(40)),
            # A merge that is still in flight when the grace period ends: a post-optimization
            # budget given is spent (restarts until it runs out), far past drain + grace. (The
            # automatic budget stops by rounds, which a fast machine finishes within them.)
            options=merge_pb2.MergeOptions(variant=merge_pb2.VARIANT_ALL_PAIRS,
                                           evaluation=merge_pb2.EVALUATION_EAGER,
                                           optimize_ms=40000))
        call = c.merge_stream(request, timeout=60)
        next(call)
        s.proc.send_signal(signal.SIGTERM)
        # The drain: health answers NOT_SERVING, and calls are still served meanwhile.
        for _ in range(200):
            if health(b"", timeout=5) == HEALTH_NOT_SERVING:
                break
            time.sleep(0.02)
        else:
            raise AssertionError("health still SERVING after SIGTERM")
        assert c.get_session().name == c.session
        assert [x.name for x in c.list_sessions()] == [c.session]
        # The in-flight merge outlives the drain and is cancelled after the grace period.
        with pytest.raises(grpc.RpcError) as e:
            for _ in call:
                pass
        assert e.value.code() in (grpc.StatusCode.CANCELLED, grpc.StatusCode.UNAVAILABLE)
        assert s.proc.wait(timeout=15) == 0
    assert any("shut down cleanly" in line for line in s.log)


def run_cli(*args, timeout=120):
    return subprocess.run([CLI, *args], capture_output=True, text=True, timeout=timeout)


def test_cli_remote_merge_requery_plan(server, tmp_path):
    merged = run_cli("merge", "--server", server.target, "--scene", str(DATA / "scene.json"),
                     "--paths", str(DATA / "paths.txt"), "--measure", "inverse-clearance",
                     "--variant", "all-pairs", "--evaluation", "eager",
                     "--out", str(tmp_path / "result.json"))
    assert merged.returncode == 0, merged.stderr
    assert "session sessions/" in merged.stderr
    # Not a terminal: plain progress lines, no carriage-return redraws.
    assert "\r" not in merged.stderr
    hgraph = re.search(r"^hgraph (\S+)$", merged.stdout, re.M).group(1)
    assert (tmp_path / "result.json").exists()

    again = run_cli("requery", "--server", server.target, "--hgraph", hgraph,
                    "--measure", "bottleneck-clearance")
    assert again.returncode == 0, again.stderr
    assert "0 edges checked" in again.stdout
    assert "0 collision checks, 0 distance queries" in again.stdout

    missing = run_cli("requery", "--server", server.target, "--hgraph",
                      "sessions/" + "0" * 32 + "/hgraphs/1")
    assert missing.returncode == 2 and "NOT_FOUND" in missing.stderr

    one = tmp_path / "one.txt"
    chunks = (DATA / "paths.txt").read_text().split("\n\n")
    one.write_text([c for c in chunks if c.strip() and not c.lstrip().startswith("#")][0] + "\n")
    first = run_cli("merge", "--server", server.target, "--scene", str(DATA / "scene.json"),
                    "--paths", str(one))
    assert first.returncode == 0, first.stderr
    grown_name = re.search(r"^hgraph (\S+)$", first.stdout, re.M).group(1)
    grown = run_cli("add-paths", "--server", server.target, "--hgraph", grown_name,
                    "--scene", str(DATA / "scene.json"), "--paths", str(DATA / "paths.txt"),
                    "--out", str(tmp_path / "grown.json"))
    assert grown.returncode == 0, grown.stderr
    assert len(json.loads((tmp_path / "grown.json").read_text())["inputs"]) == 3
    assert ("hgraph " + grown_name) in grown.stdout

    planned = run_cli("plan", "--server", server.target, "--scene",
                      str(ROOT / "scenes" / "circles" / "scene.json"), "--count", "2",
                      "--out", str(tmp_path / "planned.txt"))
    assert planned.returncode == 0, planned.stderr
    assert "found 2 of 2 paths with prm" in planned.stdout


def test_cli_remote_deadline(server, tmp_path):
    paths = tmp_path / "dense.txt"
    paths.write_text("\n\n".join("\n".join(" ".join(map(str, q)) for q in p)
                                 for p in densified(40)) + "\n")
    late = run_cli("merge", "--server", server.target, "--scene", str(DATA / "scene.json"),
                   "--paths", str(paths), "--variant", "all-pairs", "--evaluation", "eager",
                   "--timeout", "0.5", "-q")
    # The server did not answer in time: exit 3 (server failed), not 2 (bad input).
    assert late.returncode == 3 and "DEADLINE_EXCEEDED" in late.stderr, late.stderr


def test_started_total_counts_a_call_in_flight():
    """grpc_server_started_total goes up when a call starts, handled_total when it ends: while a
    merge runs, started exceeds handled by one for MergePaths (on a server of its own, so that no
    other test's call is in flight)."""
    server = Server()
    try:
        with server.client() as client:
            client.create_session(client.upload_scene(DATA / "scene.json"))
            started_total_in_flight(server, client)
    finally:
        assert server.stop() == 0, "".join(server.log)


def started_total_in_flight(server, client):
    def counts():
        return (server.metric("grpc_server_started_total", grpc_method="MergePaths"),
                server.metric("grpc_server_handled_total", grpc_method="MergePaths"))

    request = service_pb2.MergePathsRequest(
        session=client.session, paths=hgraph_client.make_paths(densified(40)),
        options=merge_pb2.MergeOptions(variant=merge_pb2.VARIANT_ALL_PAIRS,
                                       evaluation=merge_pb2.EVALUATION_EAGER),
        progress_interval_ms=10)
    call = client.merge_stream(request, timeout=60)
    during = None
    for event in call:
        if event.HasField("progress"):
            during = counts()
            call.cancel()
            break
    with pytest.raises(grpc.RpcError):
        for _ in call:
            pass
    assert during is not None
    started, handled = during
    assert started == handled + 1, during
    # Once the cancelled call is finished, the two agree again.
    for _ in range(400):
        started, handled = counts()
        if started == handled:
            break
        time.sleep(0.05)
    assert started == handled


def run_server_expecting_refusal(*flags):
    """Runs hgraph-server with `flags` and returns (exit code, stderr) of a refused start."""
    proc = subprocess.run([SERVER, "--listen", "127.0.0.1:0", "--metrics-listen", "", *flags],
                          capture_output=True, text=True, timeout=30)
    assert "ready" not in proc.stdout, proc.stdout
    return proc.returncode, proc.stderr


def test_max_message_bytes_out_of_int_range_is_refused():
    # gRPC takes an int: 3 GB would wrap to a negative size if narrowed unchecked.
    code, err = run_server_expecting_refusal("--max-message-bytes", "3000000000")
    assert code != 0
    assert "--max-message-bytes" in err and "2147483647" in err, err


def test_mistyped_log_level_is_refused_naming_the_allowed_values():
    code, err = run_server_expecting_refusal("--log-level", "verbose")
    assert code != 0
    assert "--log-level" in err and "verbose" in err, err
    for level in ("trace", "debug", "info", "warn", "error"):
        assert level in err, err


def test_metrics_listener_error_names_the_flag():
    import socket
    taken = socket.socket()
    taken.bind(("127.0.0.1", 0))
    taken.listen(1)
    try:
        port = taken.getsockname()[1]
        proc = subprocess.run([SERVER, "--listen", "127.0.0.1:0", "--metrics-listen",
                               f"127.0.0.1:{port}"], capture_output=True, text=True, timeout=30)
    finally:
        taken.close()
    assert proc.returncode != 0
    assert "--metrics-listen" in proc.stderr, proc.stderr
    assert "--metrics-address" not in proc.stderr, proc.stderr


def test_merge_whose_session_is_deleted_meanwhile_still_answers(server):
    """Deleting the session while its merge runs: the merge still answers with its result; the
    H-Graph is not stored (no name to re-query), and the session stays deleted."""
    with server.client() as c:
        c.create_session(c.upload_scene(DATA / "scene.json"))
        session = c.session
        deleted = []

        def on_progress(_):
            if not deleted:
                with server.client() as other:
                    other.delete_session(session)
                deleted.append(True)

        merged = c.merge(densified(30), variant="all-pairs", evaluation="eager",
                         optimize_ms=0, on_progress=on_progress, progress_interval_ms=10,
                         timeout=300)
        assert deleted
        assert merged.result.quality.length > 0
        assert len(merged.result.path.waypoints) >= 2
        assert merged.hgraph == ""
        with pytest.raises(hgraph_client.HgraphError) as e:
            server.client().get_session(session)
        assert e.value.code == grpc.StatusCode.NOT_FOUND


class StalledUpload:
    """An UploadBlob stream that sends its first chunk of `size` declared bytes, then nothing
    until release() (which sends the rest) or forever."""

    def __init__(self, client, size, seed=b"x"):
        import hashlib
        self.data = (seed * size)[:size]
        digest = scene_pb2.Digest(sha256=hashlib.sha256(self.data).hexdigest(), size_bytes=size)
        self.sent_first = threading.Event()
        self.go_on = threading.Event()

        def chunks():
            yield service_pb2.UploadBlobRequest(digest=digest, data=self.data[:1024])
            self.sent_first.set()
            self.go_on.wait()
            yield service_pb2.UploadBlobRequest(data=self.data[1024:])

        self.future = client.stub.UploadBlob.future(chunks(), timeout=120)
        # The generator goes past its first yield when gRPC asks for the second chunk; a
        # stream the server refused at its first chunk never asks.
        for _ in range(600):
            if self.sent_first.wait(0.05) or self.future.done():
                break
        else:
            raise AssertionError("the first chunk was never sent")

    def release(self):
        self.go_on.set()
        return self.future.result(timeout=60)

    def error(self):
        """The status the server ended the stream with."""
        try:
            self.future.result(timeout=60)
        except grpc.RpcError as e:
            return e
        raise AssertionError("the stalled upload succeeded")


def wait_for_metric(server, name, value, **labels):
    for _ in range(400):
        if server.metric(name, **labels) == value:
            return
        time.sleep(0.05)
    raise AssertionError(f"{name}{labels} never became {value}: {server.metric(name, **labels)}")


def test_unfinished_uploads_count_against_the_cache_budget():
    server = Server("--cache-bytes", str(1 << 20))
    try:
        with server.client() as c:
            stalled = StalledUpload(c, 700 << 10)
            wait_for_metric(server, "hgraph_cache_bytes", 700 << 10, kind="upload")
            # Two unfinished 700 kB uploads would hold 1.4 MB against a 1 MiB budget.
            second = StalledUpload(c, 700 << 10, seed=b"y")
            e = second.error()
            assert e.code() == grpc.StatusCode.RESOURCE_EXHAUSTED, e
            assert "digest.size_bytes" in e.details() and "--cache-bytes" in e.details()
            second.go_on.set()
            # The first one completes, and its bytes now count as a blob, not a reservation.
            assert stalled.release().stored
            wait_for_metric(server, "hgraph_cache_bytes", 0, kind="upload")
            assert server.metric("hgraph_cache_bytes", kind="blob") == 700 << 10
    finally:
        assert server.stop() == 0, "".join(server.log)


def test_an_unfinished_upload_takes_an_admission_slot():
    server = Server("--max-pending", "1")
    try:
        with server.client() as c:
            stalled = StalledUpload(c, 64 << 10)
            with pytest.raises(hgraph_client.HgraphError) as e:
                c.create_session(c.upload_scene(DATA / "scene.json"))
            assert e.value.code == grpc.StatusCode.RESOURCE_EXHAUSTED
            assert "--max-pending" in str(e.value)
            assert stalled.release().stored
            # The slot is free again.
            c.create_session(c.upload_scene(DATA / "scene.json"))
            assert c.merge(input_paths(), timeout=30).result.quality.length > 0
    finally:
        assert server.stop() == 0, "".join(server.log)


def test_an_idle_upload_is_aborted_and_its_bytes_released():
    server = Server("--cache-bytes", str(1 << 20), "--upload-idle-timeout-s", "1",
                    "--max-pending", "1")
    try:
        with server.client() as c:
            stalled = StalledUpload(c, 900 << 10)
            e = stalled.error()
            stalled.go_on.set()
            assert e.code() == grpc.StatusCode.ABORTED, e
            assert "--upload-idle-timeout-s" in e.details(), e.details()
            wait_for_metric(server, "hgraph_cache_bytes", 0, kind="upload")
            # Its 900 kB and its admission slot are free: another upload of that size goes in.
            blob = (b"z" * (900 << 10))
            assert c.upload_blob(blob, timeout=30).size_bytes == len(blob)
    finally:
        assert server.stop() == 0, "".join(server.log)


def test_a_name_with_a_newline_cannot_forge_a_log_line(server):
    forged = "\n2026-01-01 info FORGED"
    name = "sessions/" + (forged + "x" * 32)[:32]
    with server.client() as c:
        # The raw stub: the client library would also put the name in call metadata, which
        # refuses a newline on the client side.
        with pytest.raises(grpc.RpcError) as e:
            c.stub.GetSession(service_pb2.GetSessionRequest(name=name), timeout=10)
    assert e.value.code() == grpc.StatusCode.INVALID_ARGUMENT
    assert "\n" not in e.value.details()
    assert "\\n2026-01-01 info FORGED" in e.value.details(), e.value.details()
    for _ in range(100):
        if any("\\n2026-01-01 info FORGED" in line for line in server.log):
            break
        time.sleep(0.05)
    else:
        raise AssertionError("the call was not logged:\n" + "".join(server.log[-5:]))
    assert not any(line.startswith("2026-01-01 info FORGED") for line in server.log)


def test_a_100_kb_name_gets_the_real_error(client):
    with pytest.raises(hgraph_client.HgraphError) as e:
        client.plan(count=1, planner="p" * 100000, time_per_path_s=0.1)
    assert e.value.code == grpc.StatusCode.INVALID_ARGUMENT, e.value
    message = str(e.value)
    assert "planner" in message and "unknown planner" in message and "bytes, cut" in message
    assert len(message) < 4000


def test_a_scene_digest_with_a_wrong_size_is_refused_naming_the_field(server):
    with server.client() as c:
        digest = c.upload_scene(DATA / "scene.json")
        wrong = scene_pb2.Digest(sha256=digest.sha256, size_bytes=digest.size_bytes + 1)
        with pytest.raises(grpc.RpcError) as e:
            c.stub.CreateSession(service_pb2.CreateSessionRequest(scene=wrong), timeout=30)
        assert e.value.code() == grpc.StatusCode.INVALID_ARGUMENT
        assert "scene.size_bytes" in e.value.details(), e.value.details()
        assert c.create_session(digest).name.startswith("sessions/")


def test_requery_answers_do_not_depend_on_earlier_or_concurrent_ones(client):
    """A stored H-Graph answers each measure the same, whatever was asked before or at the same
    time (the length requeries' post-optimization used to leave its shortcuts in the graph), and
    as the merge that built it answers that measure."""
    paths = [[list(q.values) for q in p.waypoints] for p in input_paths().paths]
    merged = client.merge(paths, measure="inverse-clearance", k=3, variant="all-pairs")
    measures = [("bottleneck-clearance", {}), ("length", {}), ("inverse-clearance", {"k": 3})]

    def answer(result):
        return ([list(w.values) for w in result.path.waypoints], result.objective,
                list(result.source_path), list(result.source_index),
                list(result.source_fraction))

    first = {}
    for name, extra in measures + measures[::-1]:
        got = answer(client.requery(merged.hgraph, name, **extra))
        assert first.setdefault(name, got) == got, name
    assert answer(merged.result) == first["inverse-clearance"]
    # A merge under length equals a requery under length.
    assert answer(client.merge(paths, variant="all-pairs").result) == first["length"]

    def run(i):
        name, extra = measures[i % len(measures)]
        return name, answer(client.requery(merged.hgraph, name, **extra))

    with concurrent.futures.ThreadPoolExecutor(max_workers=8) as pool:
        for name, got in pool.map(run, range(48)):
            assert got == first[name], name
