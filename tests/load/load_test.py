#!/usr/bin/env python3
"""Load and fault test of hgraph-server, on loopback only, bounded in time.

Starts a real hgraph-server and runs, for --duration seconds, concurrent clients against it:
- "client" workers (the Python hgraph_client, with its retries): merge, requery, check;
- "raw" workers (grpc stubs generated from proto/): streamed merges, a third of them cancelled
  after their first progress event, requeries of the H-Graphs they made;
- a disconnect worker: merges dropped mid-stream by closing the channel, and by killing
  (SIGKILL) a client process of its own;
- a deadline storm: bursts of calls with deadlines of 1-20 ms;
- a health prober;
and, halfway, restarts the server (SIGTERM, exit status 0 expected, same port): every client
then finds its session gone and uploads its scene again by digest (only the blobs the new server
lacks) before it goes on.

Every response is checked against its request: a merge's path must run from the request's start
to its goal, its input reports must carry the request's path names and waypoint counts and their
lengths; a requery must echo its H-Graph and run between that merge's endpoints; a check must
report each path's length. It prints requests, errors by code, lost and mixed responses, p50/p99
latency per method and the server's peak RSS (VmHWM from /proc). Exit status 1 when a response
was lost or mixed, a call failed with a code the scenario cannot explain, or the server did not
stay healthy (health check, a final merge, exit status 0 on SIGTERM); 0 otherwise. Nothing here
asserts a duration.

Usage: /usr/bin/python3 tests/load/load_test.py --server-binary build/hgraph-server --duration 60
"""
import argparse
import collections
import hashlib
import json
import math
import pathlib
import random
import re
import secrets
import subprocess
import sys
import tempfile
import threading
import time

ROOT = pathlib.Path(__file__).resolve().parents[2]

# grpc.health.v1.HealthCheckResponse{status: SERVING}.
HEALTH_SERVING = b"\x08\x01"


def parse_args(argv):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--server-binary", required=True, help="the hgraph-server executable")
    p.add_argument("--python-path", help="generated hgraph.v1 stubs (default: <server dir>/python)")
    p.add_argument("--duration", type=float, default=60, help="seconds of load (default 60)")
    p.add_argument("--clients", type=int, default=3, help="hgraph_client workers (default 3)")
    p.add_argument("--raw", type=int, default=3, help="raw-stub workers (default 3)")
    p.add_argument("--threads", type=int, default=2, help="server worker threads (default 2)")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--no-restart", action="store_true", help="skip the server restart")
    p.add_argument("--call-timeout", type=float, default=120,
                   help="deadline of every ordinary call, s (default 120: sanitizer builds are "
                   "slow)")
    p.add_argument("--json", help="also write the figures here")
    p.add_argument("--child-merge", nargs=2, metavar=("TARGET", "SESSION"), help=argparse.SUPPRESS)
    return p.parse_args(argv)


args = parse_args(sys.argv[1:])
STUBS = args.python_path or str(pathlib.Path(args.server_binary).resolve().parent / "python")
sys.path.insert(0, str(ROOT / "client" / "python"))
sys.path.insert(0, STUBS)
sys.path.insert(0, str(ROOT / "tests" / "integration"))  # server_process

import grpc  # noqa: E402

import hgraph_client  # noqa: E402
from hgraph.v1 import merge_pb2, path_pb2, scene_pb2, service_pb2, service_pb2_grpc  # noqa: E402
from google.protobuf import json_format  # noqa: E402
from server_process import IgnoredSigterm, ServerProcess, free_port  # noqa: E402

C = grpc.StatusCode

# ---------------------------------------------------------------------------------------------
# The scene: streets between 16 blocks. R^2 in [0, 90]^2, a point robot; blocks of 10 x 10 at
# [10 + 20 i, 20 + 20 i] x [10 + 20 j, 20 + 20 j]; one block is a mesh (an uploaded blob), the
# others are boxes. Street centre lines run at 5 + 20 k, so every route along them is free.

CENTRES = [5.0 + 20.0 * k for k in range(5)]

CUBE_OBJ = "".join(f"v {x} {y} {z}\n" for x in (-5, 5) for y in (-5, 5) for z in (-1, 1)) + "".join(
    f"f {a} {b} {c}\n" for a, b, c in [
        (1, 3, 4), (1, 4, 2), (5, 6, 8), (5, 8, 7), (1, 2, 6), (1, 6, 5),
        (3, 7, 8), (3, 8, 4), (1, 5, 7), (1, 7, 3), (2, 4, 8), (2, 8, 6)])


def write_scene(folder: pathlib.Path) -> pathlib.Path:
    obstacles = []
    for i in range(4):
        for j in range(4):
            centre = [15.0 + 20 * i, 15.0 + 20 * j, 0.0]
            if (i, j) == (1, 2):
                shape = {"mesh": {"path": "block.obj"}}
            else:
                shape = {"box": {"size": [10, 10, 2]}}
            obstacles.append({"name": f"block{i}{j}", "shape": shape, "pose": {"position": centre}})
    scene = {
        "name": "load-streets",
        "space": {"components": [{"type": "TYPE_RN", "dimension": 2, "lower": [0, 0],
                                  "upper": [90, 90], "name": "xy"}]},
        "obstacles": obstacles,
        "robot": [{"name": "point", "shape": {"sphere": {"radius": 0}}, "component": 0}],
        "resolution": 0.002,
    }
    (folder / "block.obj").write_text(CUBE_OBJ)
    path = folder / "scene.json"
    path.write_text(json.dumps(scene, indent=1))
    return path


def route(rng, a, b, c, d):
    """Waypoints along street centre lines from intersection (a, b) to (c, d), in a random order
    of unit moves, each move cut in two."""
    moves = [(1 if c > a else -1, 0)] * abs(c - a) + [(0, 1 if d > b else -1)] * abs(d - b)
    rng.shuffle(moves)
    x, y = a, b
    points = [(CENTRES[x], CENTRES[y])]
    for dx, dy in moves:
        nx, ny = x + dx, y + dy
        points.append(((CENTRES[x] + CENTRES[nx]) / 2, (CENTRES[y] + CENTRES[ny]) / 2))
        points.append((CENTRES[nx], CENTRES[ny]))
        x, y = nx, ny
    return points


class Job:
    """One merge request with what its answer must show."""

    def __init__(self, rng, tag):
        while True:
            a, b, c, d = (rng.randrange(5) for _ in range(4))
            if abs(c - a) + abs(d - b) >= 2:
                break
        self.start = (CENTRES[a] + rng.uniform(-3, 3), CENTRES[b] + rng.uniform(-3, 3))
        self.goal = (CENTRES[c] + rng.uniform(-3, 3), CENTRES[d] + rng.uniform(-3, 3))
        self.paths = path_pb2.PathSet()
        self.lengths = []
        self.counts = []
        self.names = []
        for i in range(rng.randint(2, 4)):
            points = [self.start] + route(rng, a, b, c, d) + [self.goal]
            name = f"{tag}-{i}"
            p = self.paths.paths.add(name=name)
            for q in points:
                p.waypoints.add(values=list(q))
            self.names.append(name)
            self.counts.append(len(points))
            self.lengths.append(sum(math.dist(u, v) for u, v in zip(points, points[1:])))
        self.variant = rng.choice([merge_pb2.VARIANT_EDIT_DISTANCE, merge_pb2.VARIANT_ALL_PAIRS,
                                   merge_pb2.VARIANT_NEIGHBORHOOD])
        self.eager = rng.random() < 0.3
        self.optimize_ms = rng.choice([0.0, 20.0, 100.0])

    def request(self, session):
        opts = merge_pb2.MergeOptions(variant=self.variant, optimize_ms=self.optimize_ms,
                                      evaluation=merge_pb2.EVALUATION_EAGER if self.eager
                                      else merge_pb2.EVALUATION_LAZY)
        return service_pb2.MergePathsRequest(session=session, paths=self.paths, options=opts,
                                             progress_interval_ms=1)


def mismatch_of_path(path, start, goal):
    """Why `path` does not run from start to goal, or ''."""
    if len(path.waypoints) < 2:
        return f"path has {len(path.waypoints)} waypoints"
    first, last = tuple(path.waypoints[0].values), tuple(path.waypoints[-1].values)
    if math.dist(first, start) > 1e-9 or math.dist(last, goal) > 1e-9:
        return f"path runs {first} -> {last}, the request {start} -> {goal}"
    return ""


def mismatch_of_merge(job, result):
    why = mismatch_of_path(result.path, job.start, job.goal)
    if why:
        return why
    if [r.name for r in result.inputs] != job.names:
        return f"input reports {[r.name for r in result.inputs]}, the request {job.names}"
    if [r.waypoints for r in result.inputs] != job.counts:
        return f"input waypoints {[r.waypoints for r in result.inputs]}, the request {job.counts}"
    for r, length in zip(result.inputs, job.lengths):
        if abs(r.quality.length - length) > 1e-6 * max(1.0, length):
            return f"input {r.name} has length {r.quality.length}, the request's is {length}"
    return ""


# ---------------------------------------------------------------------------------------------
# The server under test.


class Server(ServerProcess):
    def __init__(self, binary, port, threads):
        super().__init__(binary, "--listen", f"127.0.0.1:{port}", "--metrics-listen", "127.0.0.1:0",
                         "--threads", str(threads), "--drain-s", "0", "--grace-s", "2",
                         "--log-level", "warn")

    def peak_rss_kib(self):
        try:
            status = pathlib.Path(f"/proc/{self.proc.pid}/status").read_text()
        except OSError:
            return 0
        match = re.search(r"VmHWM:\s+(\d+) kB", status)
        return int(match.group(1)) if match else 0

    def stop(self, timeout=60):
        try:
            return super().stop(timeout)
        except IgnoredSigterm:
            return "ignored SIGTERM"


# ---------------------------------------------------------------------------------------------
# Bookkeeping shared by the workers.


class Stats:
    def __init__(self):
        self.lock = threading.Lock()
        self.requests = collections.Counter()
        self.ok = collections.Counter()
        self.errors = collections.Counter()       # code name -> count
        self.unexpected = []                      # (method, code, message)
        self.mixed = []                           # (method, why)
        self.lost = []                            # (method, why)
        self.latency = collections.defaultdict(list)  # method -> ms of successful calls
        self.cancelled_by_client = 0
        self.disconnects = 0
        self.killed_clients = 0
        self.storm_calls = 0
        self.reuploads = 0
        self.blobs_reuploaded = 0
        self.recoveries = 0
        self.unhealthy = []
        self.restart_window = (math.inf, -math.inf)
        self.inflight = {}

    def begin(self, method):
        with self.lock:
            self.requests[method] += 1
            token = object()
            self.inflight[token] = (method, time.monotonic())
            return token

    def end(self, token, method, started, error=None, expected=()):
        elapsed_ms = (time.monotonic() - started) * 1e3
        with self.lock:
            self.inflight.pop(token, None)
            if error is None:
                self.ok[method] += 1
                self.latency[method].append(elapsed_ms)
                return
            code = error.code() if isinstance(error, grpc.RpcError) else error.code
            message = error.details() if isinstance(error, grpc.RpcError) else error.message
            self.errors[code.name] += 1
            if callable(expected):
                expected = expected()
            if code not in expected and not self.explained(code):
                self.unexpected.append((method, code.name, (message or "")[:300]))

    def explained(self, code):
        """Codes any call may get from the scenario itself: the admission queue, and the
        restart (in flight calls cancelled or refused, sessions gone)."""
        if code == C.RESOURCE_EXHAUSTED:
            return True
        lo, hi = self.restart_window
        now = time.monotonic()
        if code in (C.UNAVAILABLE, C.CANCELLED) and lo <= now <= hi + 10:
            return True
        return False

    def overlaps_restart(self, asked):
        """Whether a call asked at `asked` (monotonic time) and answered now overlapped the
        restart: the old server answers health NOT_SERVING while it drains (SIGTERM), as it
        should."""
        lo, hi = self.restart_window
        return asked <= hi and time.monotonic() >= lo

    def lost_by_restart(self, origin):
        """Whether something made at `origin` (monotonic time: a session, an H-Graph) may be on a
        server that has since been restarted."""
        lo, hi = self.restart_window
        return time.monotonic() >= lo and origin <= hi

    def add(self, field, value=1):
        with self.lock:
            setattr(self, field, getattr(self, field) + value)

    def note(self, kind, method, why):
        with self.lock:
            getattr(self, kind).append((method, why))


def timed(stats, method, call, expected=()):
    """Runs call() as one request; returns its value, or None after an error (recorded)."""
    token = stats.begin(method)
    started = time.monotonic()
    try:
        value = call()
    except (grpc.RpcError, hgraph_client.HgraphError) as e:
        stats.end(token, method, started, e, expected)
        return None
    stats.end(token, method, started)
    return value


def percentile(values, q):
    if not values:
        return float("nan")
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, max(0, math.ceil(q * len(ordered)) - 1))]


# ---------------------------------------------------------------------------------------------
# Workers.


class RawSession:
    """A session opened with the raw stubs; re-opened (scene re-uploaded by digest) when the
    server has forgotten it."""

    def __init__(self, stats, stub, scene_path, timeout):
        self.stats, self.stub, self.timeout = stats, stub, timeout
        base = scene_path.parent
        self.scene = json_format.Parse(scene_path.read_text(), scene_pb2.Scene())
        self.blobs = {}
        for o in self.scene.obstacles:
            if o.shape.HasField("mesh"):
                data = (base / o.shape.mesh.path).read_bytes()
                digest = scene_pb2.Digest(sha256=hashlib.sha256(data).hexdigest(),
                                          size_bytes=len(data))
                self.blobs[digest.sha256] = (digest, data)
                o.shape.mesh.format = "obj"
                o.shape.mesh.digest.CopyFrom(digest)
        self.name = None
        self.opened_at = None  # monotonic time the session was created, None until it is

    def metadata(self):
        return (("x-hgraph-session", self.name or ""),)

    def open(self, reupload):
        """Stores the scene (only missing blobs) and creates a session; False if the server
        did not answer."""
        stats, stub, t = self.stats, self.stub, self.timeout
        self.name = "sessions/" + secrets.token_hex(16)
        opened_at = time.monotonic()
        missing = timed(stats, "FindMissingBlobs", lambda: stub.FindMissingBlobs(
            service_pb2.FindMissingBlobsRequest(digests=[d for d, _ in self.blobs.values()]),
            timeout=t, metadata=self.metadata()).missing)
        if missing is None:
            return False
        for digest in missing:
            _, data = self.blobs[digest.sha256]
            if timed(stats, "UploadBlob", lambda: stub.UploadBlob(
                    iter([service_pb2.UploadBlobRequest(digest=digest, data=data)]), timeout=t,
                    metadata=self.metadata())) is None:
                return False
            if opened_at >= stats.restart_window[0]:
                stats.add("blobs_reuploaded")  # by any worker: the new server lacked it
        put = timed(stats, "PutScene", lambda: stub.PutScene(
            service_pb2.PutSceneRequest(scene=self.scene), timeout=t, metadata=self.metadata()))
        if put is None:
            return False
        session = timed(stats, "CreateSession", lambda: stub.CreateSession(
            service_pb2.CreateSessionRequest(scene=put.digest, session_id=self.name.split("/")[1]),
            timeout=t, metadata=self.metadata()))
        if session is None:
            return False
        if session.name != self.name:
            stats.note("mixed", "CreateSession", f"asked for {self.name}, got {session.name}")
        self.opened_at = opened_at
        if reupload:
            stats.add("reuploads")
        return True

    def stale(self):
        """Whether a NOT_FOUND for this session is explained by the restart."""
        return self.opened_at is not None and self.stats.lost_by_restart(self.opened_at)


def raw_worker(index, stats, target, scene_path, stop, timeout):
    rng = random.Random(args.seed * 1000 + index)
    channel = grpc.insecure_channel(target)
    stub = service_pb2_grpc.PathMergerStub(channel)
    session = RawSession(stats, stub, scene_path, timeout)
    count = 0
    while not stop.is_set():
        if session.opened_at is None:
            if not session.open(reupload=count > 0):
                time.sleep(0.2)
                continue
        count += 1
        job = Job(rng, f"raw{index}-{count}")
        cancel = rng.random() < 0.33
        request = job.request(session.name)
        token = stats.begin("MergePaths")
        started = time.monotonic()
        result, hgraph, error, events = None, "", None, 0
        call = stub.MergePaths(request, timeout=timeout, metadata=session.metadata())
        try:
            for event in call:
                if event.HasField("progress"):
                    events += 1
                    p = event.progress
                    if not p.phase or (p.total > 0 and p.done > p.total):
                        stats.note("mixed", "MergePaths", f"progress {p.phase} {p.done}/{p.total}")
                    if cancel:
                        call.cancel()
                elif event.HasField("result"):
                    result, hgraph = event.result, event.hgraph
        except grpc.RpcError as e:
            error = e
        if cancel and error is not None and error.code() == C.CANCELLED:
            # Our own cancel (or the result came first): not a server error.
            with stats.lock:
                stats.inflight.pop(token, None)
                stats.cancelled_by_client += 1
            continue
        if error is not None:
            stats.end(token, "MergePaths", started, error,
                      expected=lambda: (C.NOT_FOUND,) if session.stale() else ())
            if error.code() in (C.NOT_FOUND, C.UNAVAILABLE):
                session.opened_at = None
                time.sleep(0.1)
            continue
        if result is None:
            with stats.lock:
                stats.inflight.pop(token, None)
            stats.note("lost", "MergePaths", f"stream of {job.names[0]} ended without a result")
            continue
        stats.end(token, "MergePaths", started)
        why = mismatch_of_merge(job, result)
        if why:
            stats.note("mixed", "MergePaths", why)
        if not hgraph.startswith(session.name + "/hgraphs/"):
            stats.note("mixed", "MergePaths", f"H-Graph {hgraph!r} not in {session.name}")
            continue
        measure = rng.choice([merge_pb2.Measure.TYPE_BOTTLENECK_CLEARANCE,
                              merge_pb2.Measure.TYPE_INVERSE_CLEARANCE,
                              merge_pb2.Measure.TYPE_LENGTH])
        response = timed(stats, "Requery", lambda: stub.Requery(
            service_pb2.RequeryRequest(hgraph=hgraph, measure=merge_pb2.Measure(type=measure)),
            timeout=timeout, metadata=session.metadata()),
            expected=lambda: (C.NOT_FOUND,) if session.stale() else ())
        if response is not None:
            if response.hgraph != hgraph:
                stats.note("mixed", "Requery", f"asked {hgraph}, answered {response.hgraph}")
            why = mismatch_of_path(response.result.path, job.start, job.goal)
            if why or response.result.measure.type != measure:
                stats.note("mixed", "Requery", why or f"measure {response.result.measure.type}")
    channel.close()


def client_worker(index, stats, target, scene_path, stop, timeout):
    rng = random.Random(args.seed * 2000 + index)
    client = None
    count = 0
    while not stop.is_set():
        if client is None:
            try:
                client = hgraph_client.connect(target, wait_s=5)
            except hgraph_client.HgraphError:
                time.sleep(0.2)
                continue
            digest = timed(stats, "client.upload_scene",
                           lambda: client.upload_scene(scene_path, timeout=timeout))
            created = digest is not None and timed(
                stats, "client.create_session",
                lambda: client.create_session(digest, timeout=timeout)) is not None
            if not created:
                client.close()
                client = None
                time.sleep(0.2)
                continue
        count += 1
        job = Job(rng, f"client{index}-{count}")
        recoveries = client.recoveries
        merged_at = time.monotonic()
        outcome = timed(stats, "client.merge", lambda: client.merge(
            job.paths, variant=rng.choice(["edit-distance", "all-pairs"]),
            optimize_ms=job.optimize_ms, timeout=timeout))
        stats.add("recoveries", client.recoveries - recoveries)
        if outcome is None:
            continue
        why = mismatch_of_merge(job, outcome.result)
        if why:
            stats.note("mixed", "client.merge", why)
        if not outcome.hgraph.startswith(client.session + "/hgraphs/"):
            stats.note("mixed", "client.merge",
                       f"H-Graph {outcome.hgraph!r} not in {client.session}")
        result = timed(stats, "client.requery", lambda: client.requery(
            outcome.hgraph, "inverse-clearance", k=2, timeout=timeout),
            expected=lambda: (C.NOT_FOUND,) if stats.lost_by_restart(merged_at) else ())
        if result is not None:
            why = mismatch_of_path(result.path, job.start, job.goal)
            if why:
                stats.note("mixed", "client.requery", why)
        if rng.random() < 0.3:
            checked = timed(stats, "client.check", lambda: client.check(job.paths, timeout=timeout))
            if checked is not None:
                lengths = [p.quality.length for p in checked.paths]
                if len(lengths) != len(job.lengths) or any(
                        abs(a - b) > 1e-6 * max(1.0, b) for a, b in zip(lengths, job.lengths)):
                    stats.note("mixed", "client.check",
                               f"lengths {lengths}, the request's {job.lengths}")
                if not checked.valid:
                    stats.note("mixed", "client.check", "a valid street route reported invalid")
    if client is not None:
        client.close()


def child_merge(target, session):
    """--child-merge: starts a long merge, says so after its first event, and waits to be killed."""
    stub = service_pb2_grpc.PathMergerStub(grpc.insecure_channel(target))
    job = Job(random.Random(7), "child")
    request = job.request(session)
    request.options.variant = merge_pb2.VARIANT_ALL_PAIRS
    request.options.evaluation = merge_pb2.EVALUATION_EAGER
    for event in stub.MergePaths(request, timeout=120, metadata=(("x-hgraph-session", session),)):
        print("started", flush=True)
        time.sleep(60)
        break


def disconnect_worker(stats, target, scene_path, stop, timeout):
    rng = random.Random(args.seed * 3000)
    count = 0
    while not stop.is_set():
        count += 1
        channel = grpc.insecure_channel(target)
        stub = service_pb2_grpc.PathMergerStub(channel)
        session = RawSession(stats, stub, scene_path, timeout)
        if not session.open(reupload=False):
            channel.close()
            time.sleep(0.2)
            continue
        if count % 4 == 0:
            # A client process killed mid-stream: its TCP connection just goes away.
            child = subprocess.Popen([sys.executable, __file__, "--server-binary",
                                      args.server_binary, "--python-path", STUBS,
                                      "--child-merge", target, session.name],
                                     stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
            line = child.stdout.readline()
            child.kill()
            child.wait()
            if line.strip() == "started":
                stats.add("killed_clients")
        else:
            job = Job(rng, f"drop{count}")
            request = job.request(session.name)
            call = stub.MergePaths(request, timeout=timeout, metadata=session.metadata())
            try:
                next(call)
                channel.close()  # drops the stream under the server's feet
                stats.add("disconnects")
            except (grpc.RpcError, StopIteration, ValueError):
                pass
        channel.close()
        stop.wait(0.3)


def deadline_storm(stats, target, scene_path, stop, timeout):
    rng = random.Random(args.seed * 4000)
    channel = grpc.insecure_channel(target)
    stub = service_pb2_grpc.PathMergerStub(channel)
    health = channel.unary_unary("/grpc.health.v1.Health/Check")
    session = RawSession(stats, stub, scene_path, timeout)
    while not stop.is_set():
        if session.opened_at is None or session.stale():
            if not session.open(reupload=False):
                stop.wait(0.3)
                continue
        futures = []
        for i in range(24):
            deadline = rng.choice([0.001, 0.002, 0.005, 0.01, 0.02])
            job = Job(rng, f"storm{i}")
            if i % 3 == 0:
                futures.append(("CheckPaths", time.monotonic(), stub.CheckPaths.future(
                    service_pb2.CheckPathsRequest(session=session.name, paths=job.paths),
                    timeout=deadline, metadata=session.metadata())))
            else:
                # A merge stream with a tiny deadline, read to its end on this thread below.
                futures.append(("MergePaths", time.monotonic(), stub.MergePaths(
                    job.request(session.name), timeout=deadline, metadata=session.metadata())))
        for method, started, f in futures:
            token = stats.begin("storm." + method)
            try:
                if method == "CheckPaths":
                    f.result()
                else:
                    for _ in f:
                        pass
                stats.end(token, "storm." + method, started)
            except grpc.RpcError as e:
                stats.end(token, "storm." + method, started, e,
                          expected=lambda: (C.DEADLINE_EXCEEDED,) +
                          ((C.NOT_FOUND,) if session.stale() else ()))
            stats.add("storm_calls")
        # The server must answer at once after a storm.
        asked = time.monotonic()
        try:
            if health(b"", timeout=10) != HEALTH_SERVING and not stats.overlaps_restart(asked):
                stats.note("unhealthy", "Health", "not SERVING after a deadline storm")
        except grpc.RpcError as e:
            if not stats.explained(e.code()):
                stats.note("unhealthy", "Health", f"{e.code().name} after a deadline storm")
        stop.wait(1.0)
    channel.close()


def health_prober(stats, target, stop):
    channel = grpc.insecure_channel(target)
    health = channel.unary_unary("/grpc.health.v1.Health/Check")
    while not stop.wait(0.5):
        asked = time.monotonic()
        try:
            answer = health(b"", timeout=10)
            if answer != HEALTH_SERVING and not stats.overlaps_restart(asked):
                stats.note("unhealthy", "Health", f"answered {answer!r}")
        except grpc.RpcError as e:
            if not stats.explained(e.code()):
                stats.note("unhealthy", "Health", e.code().name)
    channel.close()


# ---------------------------------------------------------------------------------------------


def final_merge(target, scene_path, timeout):
    """A fresh client's merge after the load: the server must still do its job."""
    with hgraph_client.connect(target, wait_s=10) as client:
        client.create_session(client.upload_scene(scene_path, timeout=timeout), timeout=timeout)
        job = Job(random.Random(99), "final")
        outcome = client.merge(job.paths, timeout=timeout)
        return mismatch_of_merge(job, outcome.result)


def main():
    if args.child_merge:
        child_merge(*args.child_merge)
        return 0
    work = pathlib.Path(tempfile.mkdtemp(prefix="hgraph-load-"))
    scene_path = write_scene(work)
    port = free_port()
    target = f"127.0.0.1:{port}"
    stats = Stats()
    server = Server(args.server_binary, port, args.threads)
    servers = [server]
    stop = threading.Event()
    timeout = args.call_timeout
    common = (stats, target, scene_path, stop, timeout)
    workers = [threading.Thread(target=raw_worker, args=(i, *common)) for i in range(args.raw)]
    workers += [threading.Thread(target=client_worker, args=(i, *common))
                for i in range(args.clients)]
    workers += [threading.Thread(target=disconnect_worker, args=common),
                threading.Thread(target=deadline_storm, args=common),
                threading.Thread(target=health_prober, args=(stats, target, stop))]
    began = time.monotonic()
    for w in workers:
        w.daemon = True
        w.start()
    failures = []
    peaks = []
    if not args.no_restart:
        stop.wait(args.duration / 2)
        with stats.lock:
            stats.restart_window = (time.monotonic(), math.inf)
        peaks.append(server.peak_rss_kib())
        status = server.stop()
        if status != 0:
            failures.append(f"first server: exit status {status} on SIGTERM")
        server = Server(args.server_binary, port, args.threads)
        servers.append(server)
        with stats.lock:
            stats.restart_window = (stats.restart_window[0], time.monotonic())
    stop.wait(max(0.0, began + args.duration - time.monotonic()))
    stop.set()
    # Every call has a deadline, so every worker returns; one that does not has lost a call.
    for w in workers:
        w.join(timeout + 30)
    with stats.lock:
        for method, started in stats.inflight.values():
            stats.lost.append((method, f"no answer after {time.monotonic() - started:.0f} s"))
    elapsed = time.monotonic() - began

    if server.proc.poll() is not None:
        failures.append(f"server exited during the run (status {server.proc.returncode})")
    else:
        try:
            why = final_merge(target, scene_path, timeout)
            if why:
                stats.note("mixed", "final merge", why)
        except hgraph_client.HgraphError as e:
            failures.append(f"final merge failed: {e}")
    peaks.append(server.peak_rss_kib())
    status = server.stop()
    if status != 0:
        failures.append(f"server: exit status {status} on SIGTERM")

    # ---- report
    total = sum(stats.requests.values())
    ok = sum(stats.ok.values())
    print(f"hgraph load test: {elapsed:.0f} s, {args.raw} raw + {args.clients} client workers, "
          f"disconnects, deadline storms, {len(servers) - 1} restart(s); "
          f"server --threads {args.threads}")
    print(f"requests: {total} (ok {ok}, cancelled by the client {stats.cancelled_by_client}, "
          f"errors {sum(stats.errors.values())}); storm calls {stats.storm_calls}, "
          f"dropped streams {stats.disconnects}, killed client processes {stats.killed_clients}")
    codes = ", ".join(f"{k} {v}" for k, v in sorted(stats.errors.items()))
    print(f"errors by code: {codes or 'none'}")
    print(f"after the restart: {stats.reuploads} raw sessions re-opened, "
          f"{stats.blobs_reuploaded} blobs uploaded again (the new server lacked them), "
          f"{stats.recoveries} hgraph_client recoveries")
    print(f"lost: {len(stats.lost)}   mixed: {len(stats.mixed)}   unexplained errors: "
          f"{len(stats.unexpected)}   health failures: {len(stats.unhealthy)}")
    print(f"{'method':<22}{'ok':>7}{'p50 ms':>10}{'p99 ms':>10}")
    for method in sorted(stats.latency):
        v = stats.latency[method]
        print(f"{method:<22}{len(v):>7}{percentile(v, 0.5):>10.1f}{percentile(v, 0.99):>10.1f}")
    print("server peak RSS (VmHWM): " + ", ".join(f"{p / 1024:.1f} MiB" for p in peaks))
    for kind in ("lost", "mixed", "unexpected", "unhealthy"):
        for item in getattr(stats, kind)[:10]:
            print(f"  {kind}: {item}")
    for f in failures:
        print(f"  failure: {f}")
    if args.json:
        pathlib.Path(args.json).write_text(json.dumps({
            "seconds": elapsed, "requests": total, "ok": ok, "errors": dict(stats.errors),
            "lost": len(stats.lost), "mixed": len(stats.mixed),
            "unexpected": len(stats.unexpected), "peak_rss_kib": peaks,
            "latency_ms": {m: {"n": len(v), "p50": percentile(v, 0.5), "p99": percentile(v, 0.99)}
                           for m, v in stats.latency.items()}}, indent=1))
    bad = stats.lost or stats.mixed or stats.unexpected or stats.unhealthy or failures
    if bad:
        print("FAILED")
        for s in servers:
            sys.stdout.write("".join(s.log[-40:]))
        return 1
    print("PASSED")
    return 0


if __name__ == "__main__":
    sys.exit(main())
