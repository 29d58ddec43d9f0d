"""The contract a client relies on (issue "A contract clients can rely on"), through a real
hgraph-server on a loopback port, with the Python client and with the raw stubs: safe retries
(hgraph_id, request_id), names never reused, presence instead of sentinels, error details,
generations and the HGraph resource, a merge that outlives its client, pagination, and every
range the proto comments state checked against the server.

Run through CTest (service.contract), or by hand as test_service.py says.
"""
import os
import pathlib
import re
import threading
import time

import grpc
import pytest

import hgraph_client
from hgraph.v1 import merge_pb2, scene_pb2, service_pb2, service_pb2_grpc, space_pb2
from test_service import DATA, Server, densified, input_paths

ROOT = pathlib.Path(__file__).resolve().parents[2]
PROTO = ROOT / "proto" / "hgraph" / "v1"


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


def raw(server):
    channel = grpc.insecure_channel(server.target)
    return channel, service_pb2_grpc.PathMergerStub(channel)


def details_of(error: grpc.RpcError) -> hgraph_client.ErrorDetails:
    details = hgraph_client.decode_error_details(error.trailing_metadata())
    assert details is not None, f"no error details with {error.code()}: {error.details()}"
    assert details.domain == "hgraph.v1"
    return details


def merge_request(client, **kwargs):
    return service_pb2.MergePathsRequest(session=client.session,
                                         paths=hgraph_client.make_paths(input_paths()), **kwargs)


# Retries ----------------------------------------------------------------------------------------

def test_merge_repeated_with_its_hgraph_id_returns_the_first_answer(client):
    first = client.merge(input_paths(), hgraph_id="retry-me", progress_interval_ms=1)
    assert first.hgraph == client.session + "/hgraphs/retry-me"
    assert first.progress_events > 0 and first.generation == 1
    again = client.merge(input_paths(), hgraph_id="retry-me", progress_interval_ms=1)
    # The first answer, not a second merge: no progress, the same result, one H-Graph.
    assert again.progress_events == 0
    assert again.hgraph == first.hgraph
    assert again.result == first.result
    assert list(client.get_session().hgraphs) == [first.hgraph]
    # The same id with another request is refused.
    with pytest.raises(hgraph_client.HgraphError) as e:
        client.merge(input_paths(), measure="bottleneck-clearance", hgraph_id="retry-me")
    assert e.value.code == grpc.StatusCode.ALREADY_EXISTS
    assert e.value.field == "hgraph_id"


def test_merge_without_hgraph_id_gets_a_fresh_random_name_each_time(client):
    a = client.merge(input_paths())
    b = client.merge(input_paths())
    assert a.hgraph != b.hgraph
    assert re.fullmatch(re.escape(client.session) + r"/hgraphs/[0-9a-f]{32}", a.hgraph)


def test_add_paths_repeated_with_its_request_id_returns_the_first_answer(client):
    merged = client.merge(input_paths())
    extra = [[list(q.values) for q in p.waypoints] for p in input_paths().paths]
    first = client.add_paths(merged.hgraph, extra, request_id="add-1")
    assert len(first.result.inputs) == 4 and first.generation == 2
    again = client.add_paths(merged.hgraph, extra, request_id="add-1")
    assert again == first
    graph = client.get_hgraph(merged.hgraph)
    assert graph.generation == 2 and len(graph.inputs) == 4
    # The same id with other paths is refused; without an id the paths are added again.
    with pytest.raises(hgraph_client.HgraphError) as e:
        client.add_paths(merged.hgraph, extra[:1], request_id="add-1")
    assert e.value.code == grpc.StatusCode.ALREADY_EXISTS
    assert len(client.add_paths(merged.hgraph, extra).result.inputs) == 6


def test_add_paths_with_a_stale_expected_generation_is_aborted_and_adds_nothing(client):
    merged = client.merge(input_paths())
    extra = [[list(q.values) for q in p.waypoints] for p in input_paths().paths]
    grown = client.add_paths(merged.hgraph, extra, expected_generation=1)
    assert grown.generation == 2
    with pytest.raises(hgraph_client.HgraphError) as e:
        client.add_paths(merged.hgraph, extra, expected_generation=1)
    assert e.value.code == grpc.StatusCode.ABORTED
    assert e.value.reason == "GENERATION_MISMATCH"
    assert e.value.field == "expected_generation"
    assert client.get_hgraph(merged.hgraph).generation == 2
    assert len(client.get_hgraph(merged.hgraph).inputs) == 4
    # A requery answers from the same generation and does not change it.
    channel, stub = raw(client)
    requery = stub.Requery(service_pb2.RequeryRequest(hgraph=merged.hgraph), timeout=30)
    assert requery.generation == 2
    channel.close()


# Names ------------------------------------------------------------------------------------------

def test_an_old_hgraph_name_is_not_found_after_its_session_is_re_created(client):
    digest = client.upload_scene(DATA / "scene.json")
    session_id = client.session.split("/", 1)[1]
    old = client.merge(input_paths()).hgraph
    client.delete_session()
    client.create_session(digest, session_id=session_id)
    new = client.merge(input_paths()).hgraph
    assert new != old
    with pytest.raises(hgraph_client.HgraphError) as e:
        client.requery(old)
    assert e.value.code == grpc.StatusCode.NOT_FOUND
    assert e.value.reason == "HGRAPH_NOT_FOUND"
    assert client.requery(new).path.waypoints


def test_a_deleted_hgraph_is_gone_and_its_id_is_not_given_out_again(client):
    merged = client.merge(input_paths(), hgraph_id="short-lived")
    client.delete_hgraph(merged.hgraph)
    assert list(client.get_session().hgraphs) == []
    for call in (lambda: client.get_hgraph(merged.hgraph), lambda: client.requery(merged.hgraph),
                 lambda: client.delete_hgraph(merged.hgraph),
                 lambda: client.merge(input_paths(), hgraph_id="short-lived")):
        with pytest.raises(hgraph_client.HgraphError) as e:
            call()
        assert e.value.code == grpc.StatusCode.NOT_FOUND
        assert e.value.reason == "HGRAPH_NOT_FOUND"


def test_get_hgraph_describes_the_kept_graph(client):
    merged = client.merge(input_paths(), measure="inverse-clearance", variant="all-pairs")
    graph = client.get_hgraph(merged.hgraph)
    assert graph.name == merged.hgraph
    assert graph.state == service_pb2.HGraph.STATE_READY
    assert graph.generation == 1
    assert list(graph.inputs) == [p.name for p in input_paths().paths]
    assert graph.measure.type == merge_pb2.Measure.TYPE_INVERSE_CLEARANCE
    assert graph.options.variant == merge_pb2.VARIANT_ALL_PAIRS
    assert graph.nodes > 0 and graph.edges > 0 and graph.memory_bytes > 0
    assert graph.result == merged.result


# Presence instead of sentinels ------------------------------------------------------------------

def test_a_lazy_result_says_unknown_where_nothing_was_checked(client):
    # The defaults: lazy, no report_inputs, length. An input the search did not take whole is
    # UNKNOWN, not valid; the best input and clearances are absent rather than -1 and 0.
    lazy = client.merge(input_paths(), variant="all-pairs").result
    assert lazy.evaluation == merge_pb2.EVALUATION_LAZY
    unknown = [r for r in lazy.inputs if not r.checked]
    assert unknown, "the lazy merge checked every input whole; the test needs one it did not"
    for report in unknown:
        assert report.valid  # the old field says valid...
        assert report.validity == merge_pb2.VALIDITY_UNKNOWN  # ...the new one says unknown
        assert not report.HasField("failure")
        assert not report.quality.HasField("min_clearance")
    known = [i for i, r in enumerate(lazy.inputs) if r.validity == merge_pb2.VALIDITY_VALID]
    assert lazy.HasField("best") == (lazy.best_input in known)
    if not lazy.HasField("best"):
        assert lazy.best_input == -1 and lazy.best_input_objective == 0  # the old sentinels
    assert not lazy.quality.has_clearance
    for field in ("min_clearance", "avg_clearance", "inverse_clearance"):
        assert not lazy.quality.HasField(field)
    # Eager: every input checked, VALID, the best one present with its objective.
    eager = client.merge(input_paths(), variant="all-pairs", evaluation="eager").result
    assert eager.evaluation == merge_pb2.EVALUATION_EAGER
    assert [r.validity for r in eager.inputs] == [merge_pb2.VALIDITY_VALID] * 2
    assert eager.HasField("best")
    assert eager.best.index == eager.best_input >= 0
    assert eager.best.objective == eager.best_input_objective > 0
    assert all(r.quality.HasField("min_clearance") for r in eager.inputs)


def test_an_invalid_input_reports_its_failure(client):
    paths = [[list(q.values) for q in p.waypoints] for p in input_paths().paths]
    # Straight from start to goal through the obstacles of the circles scene.
    blocked = [paths[0][0], paths[0][-1]]
    report = client.check([blocked]).paths[0]
    assert report.validity == merge_pb2.VALIDITY_INVALID
    assert report.HasField("failure")
    assert report.failure.edge == report.invalid_edge == 0
    assert report.failure.at == report.invalid_at
    assert report.failure.cause == report.invalid_cause != merge_pb2.InputReport.CAUSE_UNSPECIFIED
    valid = client.check(paths[:1]).paths[0]
    assert valid.validity == merge_pb2.VALIDITY_VALID and not valid.HasField("failure")


def test_waypoint_sources_say_with_presence_what_the_parallel_arrays_say(client):
    result = client.merge(input_paths(), variant="all-pairs", optimize_ms=0).result
    assert len(result.sources) == len(result.path.waypoints) == len(result.source_path)
    for source, path, index, fraction in zip(result.sources, result.source_path,
                                             result.source_index, result.source_fraction):
        assert source.HasField("input") == (path >= 0)
        if path >= 0:
            assert (source.input, source.edge, source.fraction) == (path, index, fraction)


def test_a_result_says_whether_its_hgraph_was_kept(client):
    merged = client.merge(input_paths())
    assert merged.retention == service_pb2.RETENTION_KEPT and merged.kept
    assert merged.hgraph and merged.generation == 1
    channel, stub = raw(client)
    metadata = [("x-hgraph-session", client.session)]
    requery = stub.Requery(service_pb2.RequeryRequest(hgraph=merged.hgraph), timeout=30,
                           metadata=metadata)
    assert requery.retention == service_pb2.RETENTION_KEPT
    assert requery.hgraph == merged.hgraph
    extra = [[list(q.values) for q in p.waypoints] for p in input_paths().paths]
    added = client.add_paths(merged.hgraph, extra)
    assert added.retention == service_pb2.RETENTION_KEPT and added.hgraph == merged.hgraph
    channel.close()


def test_an_hgraph_larger_than_the_cache_is_not_kept_and_the_result_says_so():
    s = Server("--cache-bytes", str(300_000))
    try:
        with s.client() as c:
            c.create_session(c.upload_scene(DATA / "scene.json"))
            big = c.merge(densified(30), variant="all-pairs", hgraph_id="too-big")
            # The result stands; the H-Graph is not held, and the response says why instead of
            # leaving only an empty name.
            assert big.result.path.waypoints and big.result.quality.length > 0
            assert big.retention == service_pb2.RETENTION_TOO_LARGE and not big.kept
            assert big.hgraph == "" and big.generation == 0
            assert list(c.get_session().hgraphs) == []
            with pytest.raises(hgraph_client.HgraphError) as e:
                c.get_hgraph(c.session + "/hgraphs/too-big")
            assert e.value.reason == "HGRAPH_NOT_FOUND"
            # A small merge on the same server is kept.
            small = c.merge(input_paths(), optimize_ms=0)
            assert small.kept and small.hgraph
    finally:
        assert s.stop() == 0, "".join(s.log)


def test_an_hgraph_whose_session_ended_during_the_merge_is_not_kept(client):
    request = service_pb2.MergePathsRequest(
        session=client.session, paths=hgraph_client.make_paths(densified(40)),
        options=merge_pb2.MergeOptions(variant=merge_pb2.VARIANT_ALL_PAIRS),
        progress_interval_ms=10)
    call = client.merge_stream(request, timeout=120)
    events = iter(call)
    for event in events:
        if event.HasField("progress") and event.progress.phase == "check":
            break
    # Deleted while the merge checks its bridge candidates (seconds of work left).
    client.delete_session()
    last = list(events)[-1]
    assert last.HasField("result") and last.result.path.waypoints
    assert last.retention == service_pb2.RETENTION_SESSION_ENDED
    assert last.hgraph == "" and last.generation == 0


def test_the_example_runs_and_prints_no_input_it_does_not_know(server):
    import subprocess
    import sys
    example = ROOT / "client" / "python" / "examples" / "merge_circles.py"
    proc = subprocess.run([sys.executable, str(example), "--server", server.target],
                          capture_output=True, text=True, timeout=120, env=os.environ)
    assert proc.returncode == 0, proc.stderr
    assert "merged: length" in proc.stdout
    assert "no input known valid" in proc.stdout or "best input" in proc.stdout


# Error details ----------------------------------------------------------------------------------

def test_error_details_decode_from_the_raw_stubs(client, server):
    channel, stub = raw(server)
    metadata = (("x-hgraph-session", client.session),)
    # A missing session: NOT_FOUND, SESSION_NOT_FOUND, the field named.
    with pytest.raises(grpc.RpcError) as e:
        stub.GetSession(service_pb2.GetSessionRequest(name="sessions/" + "0" * 32), timeout=10)
    assert e.value.code() == grpc.StatusCode.NOT_FOUND
    d = details_of(e.value)
    assert d.reason == "SESSION_NOT_FOUND" and d.metadata == {"field": "name"}
    assert [f for f, _ in d.field_violations] == ["name"]
    assert d.retry_delay_s is None
    # A missing H-Graph of an existing session: HGRAPH_NOT_FOUND.
    with pytest.raises(grpc.RpcError) as e:
        stub.Requery(service_pb2.RequeryRequest(hgraph=client.session + "/hgraphs/nope"),
                     timeout=10, metadata=metadata)
    assert details_of(e.value).reason == "HGRAPH_NOT_FOUND"
    # A bad value: INVALID_ARGUMENT with a BadRequest field violation.
    with pytest.raises(grpc.RpcError) as e:
        list(stub.MergePaths(merge_request(client, measure=merge_pb2.Measure(k=100)),
                             timeout=10, metadata=metadata))
    assert e.value.code() == grpc.StatusCode.INVALID_ARGUMENT
    d = details_of(e.value)
    assert d.reason == "INVALID_ARGUMENT"
    assert d.field_violations and d.field_violations[0][0] == "measure.k"
    assert "[0, 8]" in d.field_violations[0][1]
    # A permanent limit: RESOURCE_EXHAUSTED, LIMIT_EXCEEDED, no RetryInfo.
    many = hgraph_client.make_paths(list(densified(1)) * 5)  # 10 paths, --max-paths 8
    with pytest.raises(grpc.RpcError) as e:
        list(stub.MergePaths(service_pb2.MergePathsRequest(session=client.session, paths=many),
                             timeout=10, metadata=metadata))
    assert e.value.code() == grpc.StatusCode.RESOURCE_EXHAUSTED
    d = details_of(e.value)
    assert d.reason == "LIMIT_EXCEEDED" and d.retry_delay_s is None
    assert d.metadata == {"field": "paths.paths"}
    channel.close()


def test_busy_says_retry_later_with_retry_info():
    s = Server("--max-pending", "1")
    try:
        channel, stub = raw(s)
        # An upload holds its admission slot from its first message on: the only one.
        release = threading.Event()

        def chunks():
            # A valid digest, then nothing until the test is done.
            digest = hgraph_client.client._digest(b"two bytes held back")
            yield service_pb2.UploadBlobRequest(digest=digest)
            release.wait(30)

        upload = stub.UploadBlob.future(chunks(), timeout=60)
        # Wait (polled) until the upload holds the slot.
        for _ in range(400):
            if s.metric("hgraph_admitted_calls") >= 1:
                break
            time.sleep(0.05)
        with pytest.raises(hgraph_client.HgraphError) as e:
            with s.client() as c:
                c.upload_scene(DATA / "scene.json")
        assert e.value.code == grpc.StatusCode.RESOURCE_EXHAUSTED
        assert e.value.reason == "SERVER_BUSY"
        assert e.value.retry_delay_s and e.value.retry_delay_s > 0
        release.set()
        with pytest.raises(grpc.RpcError):
            upload.result()
        channel.close()
    finally:
        assert s.stop() == 0, "".join(s.log)


# A merge that outlives its client ---------------------------------------------------------------

def test_a_merge_with_an_hgraph_id_survives_its_client_going_away(client):
    request = service_pb2.MergePathsRequest(
        session=client.session, paths=hgraph_client.make_paths(densified(40)),
        options=merge_pb2.MergeOptions(variant=merge_pb2.VARIANT_ALL_PAIRS),
        progress_interval_ms=10, hgraph_id="outlives")
    name = client.session + "/hgraphs/outlives"
    call = client.merge_stream(request, timeout=60)
    for event in call:
        if event.HasField("progress") and event.progress.phase == "check":
            break
    # Still running: the H-Graph says so, and a repeat is told to retry later.
    assert client.get_hgraph(name).state == service_pb2.HGraph.STATE_RUNNING
    call.cancel()
    with pytest.raises(grpc.RpcError) as e:
        list(client.merge_stream(request, timeout=30))
    assert e.value.code() == grpc.StatusCode.ABORTED
    assert details_of(e.value).reason == "MERGE_RUNNING"
    assert details_of(e.value).retry_delay_s > 0
    # The merge finishes without its client (polled until it is kept).
    for _ in range(1200):
        graph = client.get_hgraph(name)
        if graph.state == service_pb2.HGraph.STATE_READY:
            break
        time.sleep(0.1)
    else:
        raise AssertionError("the merge whose client went away was never kept")
    assert graph.result.path.waypoints
    assert name in client.get_session().hgraphs
    # A repeat returns that result; the kept H-Graph answers requeries.
    again = list(client.merge_stream(request, timeout=30))
    assert len(again) == 1 and again[0].result == graph.result and again[0].hgraph == name
    assert client.requery(name).path.waypoints


def test_a_merge_that_outlived_its_client_stops_at_shutdown():
    # Nobody waits for it any more: SIGTERM cancels it rather than waiting for it to finish.
    s = Server("--grace-s", "0.5")
    with s.client() as c:
        c.create_session(c.upload_scene(DATA / "scene.json"))
        request = service_pb2.MergePathsRequest(
            # Dense enough that its eager checks (half a million all-pairs bridges, most of them
            # long) outlast the stop's 20 s by far.
            session=c.session, paths=hgraph_client.make_paths(densified(40)),
            options=merge_pb2.MergeOptions(variant=merge_pb2.VARIANT_ALL_PAIRS,
                                           evaluation=merge_pb2.EVALUATION_EAGER,
                                           optimize_ms=60000),
            hgraph_id="orphan")
        call = c.merge_stream(request, timeout=120)
        # Into its checks before the stop, which then has their bulk to cancel.
        for event in call:
            if event.HasField("progress") and event.progress.phase == "check":
                break
        call.cancel()
        assert c.get_hgraph(c.session + "/hgraphs/orphan").state == \
            service_pb2.HGraph.STATE_RUNNING
    assert s.stop(timeout=20) == 0, "".join(s.log)


def test_a_merge_without_an_hgraph_id_stops_with_its_client(client):
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
    # Nothing was kept (a small merge afterwards is the only H-Graph).
    merged = client.merge(input_paths())
    assert list(client.get_session().hgraphs) == [merged.hgraph]


# Metadata and sizes -----------------------------------------------------------------------------

def dense_path(waypoints):
    """Input 0 of the circles problem with its edges cut into equal pieces: the same motion in
    about `waypoints` waypoints."""
    w = [list(q.values) for q in input_paths().paths[0].waypoints]
    n = max(1, waypoints // (len(w) - 1))
    out = [[a[j] + (b[j] - a[j]) * i / n for j in range(len(a))]
           for a, b in zip(w, w[1:]) for i in range(n)]
    return out + [w[-1]]


def test_every_rpc_states_its_metadata_and_response_size():
    text = (PROTO / "service.proto").read_text()
    service = text[text.index("service PathMerger {"):text.index("message FindMissingBlobsRequest")]
    comment = []
    rpcs = {}
    for line in service.splitlines()[1:]:
        line = line.strip()
        if line.startswith("//"):
            comment.append(line[2:].strip())
        elif line.startswith("rpc "):
            rpcs[line.split()[1].split("(")[0]] = " ".join(comment)
            comment = []
        elif not line:
            comment = []
    # Every method of the service, each with its own comment.
    assert sorted(rpcs) == sorted(service_pb2.DESCRIPTOR.services_by_name["PathMerger"]
                                  .methods_by_name)
    for rpc, text in rpcs.items():
        metadata = text[text.index("Metadata:"):] if "Metadata:" in text else ""
        assert "authorization" in metadata, f"{rpc}: no 'Metadata:' naming authorization"
        assert "Response:" in text, f"{rpc}: no 'Response:' stating its size"


def test_a_response_over_4_mib_needs_the_64_mib_receive_limit():
    # One input of 150,000 waypoints: nothing to bridge, so the merged path is the input itself
    # and its result (waypoints and their sources) is larger than gRPC's default 4 MiB.
    s = Server("--max-waypoints", "200000")
    try:
        with s.client() as c:
            c.create_session(c.upload_scene(DATA / "scene.json"))
            merged = c.merge([dense_path(150_000)], optimize_ms=0)
            size = merged.result.ByteSize()
            assert size > 4 << 20, size
            assert len(merged.result.path.waypoints) > 130_000
            metadata = [("x-hgraph-session", c.session)]
            request = service_pb2.GetHGraphRequest(name=merged.hgraph)
            # A raw stub with gRPC's default receive limit: the server answers, the client
            # refuses the message.
            channel = grpc.insecure_channel(s.target)
            with pytest.raises(grpc.RpcError) as e:
                service_pb2_grpc.PathMergerStub(channel).GetHGraph(request, timeout=60,
                                                                   metadata=metadata)
            assert e.value.code() == grpc.StatusCode.RESOURCE_EXHAUSTED, e.value
            channel.close()
            # The same call with the documented 64 MiB receives it whole.
            channel = grpc.insecure_channel(
                s.target, options=[("grpc.max_receive_message_length", 64 << 20)])
            graph = service_pb2_grpc.PathMergerStub(channel).GetHGraph(request, timeout=60,
                                                                       metadata=metadata)
            assert graph.result == merged.result
            channel.close()
    finally:
        assert s.stop() == 0, "".join(s.log)


# Planning ---------------------------------------------------------------------------------------

def two_rooms_scene():
    """A point robot in a box split by a wall: start and goal in different rooms, so that every
    planning attempt fails, whatever its seed or time."""
    scene = scene_pb2.Scene(name="two-rooms")
    scene.space.components.add(type=space_pb2.Component.TYPE_RN, dimension=2, lower=[0, 0],
                               upper=[10, 10])
    wall = scene.obstacles.add(name="wall")
    wall.shape.box.size.extend([0.5, 20, 1])
    wall.pose.position.extend([5, 5, 0])
    scene.robot.add(name="point").shape.sphere.radius = 0.1
    scene.start.values.extend([2, 5])
    scene.goal.values.extend([8, 5])
    return scene


def test_plan_paths_reports_each_failed_attempt(server):
    with server.client() as c:
        c.create_session(c.upload_scene(two_rooms_scene()))
        planned = c.plan(count=3, planner="rrt-connect", time_per_path_s=0.05, seed=9)
        assert list(planned) == []
        assert [f.index for f in planned.failures] == [0, 1, 2]
        for f in planned.failures:
            assert f.failure.reason == service_pb2.PlanAttemptFailure.REASON_NO_SOLUTION
            assert f.failure.planner == "rrtconnect"
            assert f.failure.message.startswith("no path in 0.05 s (OMPL: "), f.failure.message
            assert not f.failure.HasField("invalid_edge")
        seeds = [f.failure.seed for f in planned.failures]
        assert len(set(seeds)) == 3
        # The same request draws the same seeds; another seed others.
        again = c.plan(count=3, planner="rrtconnect", time_per_path_s=0.05, seed=9)
        assert [f.failure.seed for f in again.failures] == seeds
        other = c.plan(count=1, planner="rrtconnect", time_per_path_s=0.05, seed=10)
        assert other.failures[0].failure.seed not in seeds
        # Without report_failures the stream stays as older readers know it: paths only.
        channel, stub = raw(server)
        request = service_pb2.PlanPathsRequest(session=c.session, planner="rrtconnect", count=2,
                                               time_per_path_s=0.05)
        assert list(stub.PlanPaths(request, timeout=60,
                                   metadata=[("x-hgraph-session", c.session)])) == []
        request.report_failures = True
        events = list(stub.PlanPaths(request, timeout=60,
                                     metadata=[("x-hgraph-session", c.session)]))
        assert [e.index for e in events] == [0, 1]
        assert all(e.HasField("failure") and not e.HasField("path") for e in events)
        channel.close()


def test_plan_paths_that_find_every_path_report_no_failure(client):
    request = service_pb2.PlanPathsRequest(session=client.session, planner="rrtconnect", count=2,
                                           time_per_path_s=2.0, seed=7, report_failures=True)
    request.start.values.extend([30, 62])
    request.goal.values.extend([67, 35])
    channel, stub = raw(client)
    events = list(stub.PlanPaths(request, timeout=60,
                                 metadata=[("x-hgraph-session", client.session)]))
    assert sorted(e.index for e in events) == [0, 1]
    assert all(e.HasField("path") and not e.HasField("failure") for e in events)
    channel.close()


# A merge that spends its deadline ---------------------------------------------------------------

def test_a_merge_spends_what_is_left_of_its_deadline_and_still_answers(client):
    # A small radius keeps the bridges from the post-optimization's new points few, so that its
    # overlay grows slowly and the deadline ends it, not the growth limit (on the development
    # machine that limit comes after about 1.5 s of rounds; this budget is about 0.5 s).
    # Deadlines from short to long: one too short for the H-Graph itself (a slow or sanitized
    # build) fails or answers without rounds, and the next is tried; the first that leaves time
    # for rounds must end them at the deadline and still answer whole.
    for timeout in (0.6, 1.5, 4.0, 10.0):
        try:
            merged = client.merge(input_paths(), options=merge_pb2.MergeOptions(radius=1e-3),
                                  optimize_to_deadline=True, timeout=timeout)
        except hgraph_client.HgraphError as e:
            assert e.code == grpc.StatusCode.DEADLINE_EXCEEDED, e
            continue
        if merged.complete and merged.result.stats.optimize_rounds > 0:
            break
    else:
        raise AssertionError("no deadline up to 10 s left the post-optimization a round")
    result = merged.result
    # A whole answer (not the best-so-far of a stream cut by the deadline), which says that the
    # deadline stopped the post-optimization.
    assert merged.complete and merged.kept
    assert result.stats.optimize_stop == merge_pb2.OPTIMIZE_STOP_DEADLINE
    assert result.stats.optimize_rounds > 0
    assert result.objective <= result.hgraph_objective
    assert len(result.inputs) == 2 and result.HasField("timing")
    report = client.check([result.path]).paths[0]
    assert report.valid and report.certified
    # A margin larger than the time left leaves no post-optimization: the H-Graph's optimum
    # answers, and the result says why nothing more was tried.
    quick = client.merge(input_paths(), optimize_to_deadline=True, deadline_margin_ms=600000,
                         timeout=30).result
    assert quick.stats.optimize_stop == merge_pb2.OPTIMIZE_STOP_DEADLINE
    assert quick.stats.optimize_rounds == 0
    assert quick.objective == quick.hgraph_objective


def test_a_merge_to_its_deadline_needs_a_deadline_and_no_optimize_ms(client):
    with pytest.raises(hgraph_client.HgraphError) as e:
        client.merge(input_paths(), optimize_to_deadline=True)
    assert e.value.code == grpc.StatusCode.INVALID_ARGUMENT
    assert e.value.field == "options.optimize_to_deadline"
    assert "deadline" in e.value.message
    with pytest.raises(hgraph_client.HgraphError) as e:
        client.merge(input_paths(), optimize_to_deadline=True, optimize_ms=100, timeout=30)
    assert e.value.code == grpc.StatusCode.INVALID_ARGUMENT
    assert e.value.field == "options.optimize_ms"
    # Without the option a margin changes nothing (the stated range still holds).
    plain = client.merge(input_paths(), deadline_margin_ms=10, timeout=30).result
    assert plain.stats.optimize_stop != merge_pb2.OPTIMIZE_STOP_DEADLINE


# Listing ----------------------------------------------------------------------------------------

def test_list_sessions_pages(server):
    with server.client() as c:
        digest = c.upload_scene(DATA / "scene.json")
        names = sorted(c.create_session(digest).name for _ in range(3))
        channel, stub = raw(server)
        seen, token, pages = [], "", 0
        while True:
            page = stub.ListSessions(service_pb2.ListSessionsRequest(page_size=2,
                                                                     page_token=token), timeout=10)
            assert len(page.sessions) <= 2
            seen += [s.name for s in page.sessions]
            pages += 1
            token = page.next_page_token
            if not token:
                break
        assert seen == sorted(seen) and set(names) <= set(seen)
        assert pages >= 2
        assert [s.name for s in c.list_sessions(page_size=1)] == seen
        with pytest.raises(grpc.RpcError) as e:
            stub.ListSessions(service_pb2.ListSessionsRequest(page_size=1001), timeout=10)
        assert details_of(e.value).field_violations[0][0] == "page_size"
        for name in names:
            c.delete_session(name)
        channel.close()


# Ranges -----------------------------------------------------------------------------------------

RANGE = re.compile(r"\b[Ii]n ([\[(])(-?[0-9.e+-]+), (-?[0-9.e+-]+)\]")
FIELD = re.compile(r"^\s*(?:optional\s+)?(double|int32|int64)\s+(\w+)\s*=")


def stated_ranges():
    """(message, field, type, lo, lo_open, hi) for every field whose comment states its range
    as "in [lo, hi]" (or "(lo, hi]"), read from the proto files."""
    out = []
    for proto in ("merge.proto", "service.proto"):
        message, comment = None, []
        for line in (PROTO / proto).read_text().splitlines():
            m = re.match(r"^message (\w+)", line)
            if m:
                message, comment = m.group(1), []
                continue
            if line.strip().startswith("//"):
                comment.append(line.strip()[2:])
                continue
            field = FIELD.match(line)
            text = " ".join(comment)
            comment = []
            # What a client sends: requests and the messages they hold (results are outputs).
            if field and (message in ("Measure", "MergeOptions") or
                          (message or "").endswith("Request")):
                r = RANGE.search(text)
                if r:
                    out.append((message, field.group(2), field.group(1), float(r.group(2)),
                                r.group(1) == "(", float(r.group(3))))
    return out


def call_with(client, stub, message, field, value, kind):
    """Sends `value` in `field` of `message` by the RPC that takes it; returns the error field
    named by an INVALID_ARGUMENT, or None when the value was not refused."""
    value = int(value) if kind != "double" else value
    md = (("x-hgraph-session", client.session),)
    paths = hgraph_client.make_paths(input_paths())
    if message in ("Measure", "MergeOptions", "MergePathsRequest"):
        request = merge_request(client)
        # A measure without post-optimization keeps accepted calls short.
        request.measure.type = merge_pb2.Measure.TYPE_BOTTLENECK_CLEARANCE
        target = {"Measure": request.measure, "MergeOptions": request.options,
                  "MergePathsRequest": request}[message]
        if field == "phi":
            request.options.variant = merge_pb2.VARIANT_K_NEAREST
        setattr(target, field, value)
        prefix = {"Measure": "measure.", "MergeOptions": "options.", "MergePathsRequest": ""}
        expected = prefix[message] + field
        run = lambda: list(stub.MergePaths(request, timeout=3, metadata=md))  # noqa: E731
    elif message == "CheckPathsRequest":
        request = service_pb2.CheckPathsRequest(session=client.session, paths=paths)
        setattr(request, field, value)
        expected, run = field, lambda: stub.CheckPaths(request, timeout=3, metadata=md)
    elif message == "PlanPathsRequest":
        request = service_pb2.PlanPathsRequest(session=client.session)
        setattr(request, field, value)
        expected, run = field, lambda: list(stub.PlanPaths(request, timeout=3, metadata=md))
    elif message == "SolveRequest":
        # A short budget and one quick planner keep accepted calls short (budget_s 3600 is
        # accepted and then cut by the call's deadline: not INVALID_ARGUMENT).
        ends = input_paths().paths[0].waypoints
        request = service_pb2.SolveRequest(
            session=client.session, budget_s=0.05,
            portfolio=[service_pb2.PortfolioEntry(planner="rrtconnect")])
        request.start.values.extend(ends[0].values)
        request.goal.values.extend(ends[-1].values)
        setattr(request, field, value)
        expected, run = field, lambda: list(stub.Solve(request, timeout=3, metadata=md))
    elif message == "ListSessionsRequest":
        request = service_pb2.ListSessionsRequest()
        setattr(request, field, value)
        expected, run = field, lambda: stub.ListSessions(request, timeout=3)
    else:
        raise AssertionError(f"no RPC known for {message}.{field}: add it here")
    try:
        run()
    except grpc.RpcError as e:
        if e.code() == grpc.StatusCode.INVALID_ARGUMENT:
            named = details_of(e).metadata.get("field")
            if named == expected:
                return named
    return None


def test_every_stated_range_is_the_servers(client):
    ranges = stated_ranges()
    assert len(ranges) >= 15, ranges
    channel, stub = raw(client)
    for message, field, kind, lo, lo_open, hi in ranges:
        step = 1 if kind != "double" else max(abs(lo), 1e-9) * 0.5
        inside = [hi] + ([] if lo_open else [lo])
        outside = [hi + max(abs(hi), 1), lo - step if not lo_open else lo]
        for value in inside:
            assert call_with(client, stub, message, field, value, kind) is None, \
                f"{message}.{field} = {value} is in its stated range but the server refused it"
        for value in outside:
            assert call_with(client, stub, message, field, value, kind) is not None, \
                f"{message}.{field} = {value} is outside its stated range but was not refused"
    channel.close()
