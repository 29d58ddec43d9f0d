"""Replicas sharing a store (hgraph-server --store redis://...): a real redis-server on a free
loopback port, started by each test, and real hgraph-server processes driven from the Python
client. What one replica built, another answers for, as the builder would; another tenant's
token cannot load it; a store that is corrupt, down or restarted never breaks a call.

Run through CTest (which sets the environment), or by hand:
    HGRAPH_SERVER=build/hgraph-server PYTHONPATH=client/python:build/python \
    /usr/bin/python3 -m pytest tests/integration/store_test.py
"""
import os
import pathlib
import signal
import socket
import subprocess
import time
import urllib.request

import grpc
import pytest

import hgraph_client
from redis_process import REDIS, Redis
from server_process import ServerProcess, free_port

ROOT = pathlib.Path(__file__).resolve().parents[2]
DATA = ROOT / "tests" / "data" / "circles"
SERVER = os.environ.get("HGRAPH_SERVER", str(ROOT / "build" / "hgraph-server"))

pytestmark = pytest.mark.skipif(not pathlib.Path(REDIS).exists(),
                                reason="redis-server is not installed (scripts/install-deps.sh)")


class Replica(ServerProcess):
    def __init__(self, *flags):
        super().__init__(SERVER, "--listen", "127.0.0.1:0", "--metrics-listen", "127.0.0.1:0",
                         "--threads", "2", "--drain-s", "0", "--grace-s", "2",
                         "--store-timeout-ms", "300", *flags)

    def client(self, **kwargs):
        return hgraph_client.connect(self.target, **kwargs)

    def metric(self, name, **labels):
        url = f"http://127.0.0.1:{self.metrics_port}/metrics"
        total = 0.0
        for line in urllib.request.urlopen(url, timeout=5).read().decode().splitlines():
            if line.startswith("#") or not line.startswith(name):
                continue
            series, value = line.rsplit(" ", 1)
            if series.split("{")[0] == name and all(f'{k}="{v}"' in series
                                                    for k, v in labels.items()):
                total += float(value)
        return total

    def kill(self):
        self.proc.kill()
        self.proc.wait()

    def stop(self, timeout=20):
        return super().stop(timeout)


@pytest.fixture
def redis(tmp_path):
    r = Redis(tmp_path)
    yield r
    r.stop()


@pytest.fixture
def replicas(redis):
    started = []

    def start(*flags):
        r = Replica("--store", redis.url, *flags)
        started.append(r)
        return r

    yield start
    for r in started:
        if r.proc.poll() is None:
            r.stop()


def paths():
    return hgraph_client.load_paths_text((DATA / "paths.txt").read_text())


def merge_on(client):
    client.create_session(client.upload_scene(DATA / "scene.json"))
    return client.merge(paths(), measure="length", variant="all-pairs", optimize_ms=0)


def test_another_replica_answers_after_the_builder_is_killed(replicas):
    a, b = replicas(), replicas()
    with a.client() as ca:
        merged = merge_on(ca)
        session = ca.session
    assert merged.kept and merged.shared
    a.kill()  # SIGKILL: nothing written after the answer
    with b.client() as cb:
        again = cb.requery(merged.hgraph, "length")
        assert again.path == merged.result.path
        assert again.stats.collision_checks == 0 and again.stats.distance_queries == 0
        assert again.stats.edges_reused > 0
        assert cb.get_session(session).scene.sha256
        # Under another measure it checks what it needs, and keeps answering.
        other = cb.requery(merged.hgraph, "inverse-clearance", k=2)
        assert len(other.path.waypoints) >= 2
    assert b.metric("hgraph_store_loads_total", kind="hgraph") == 1
    assert b.metric("hgraph_store_loads_total", kind="session") == 1


def test_add_paths_request_id_is_recognised_on_another_replica(replicas):
    """An AddPaths repeated with its request id on another replica (a retry that nginx sent
    elsewhere, its first replica lost or not) answers as the first and adds nothing; the same
    id with other paths is refused there too."""
    a, b = replicas(), replicas()
    extra = [[list(q.values) for q in p.waypoints] for p in paths().paths]
    with a.client() as ca:
        merged = merge_on(ca)
        first = ca.add_paths(merged.hgraph, extra, request_id="retry-7")
        assert first.shared and first.generation == 2 and len(first.result.inputs) == 4
    a.kill()
    with b.client() as cb:
        again = cb.add_paths(merged.hgraph, extra, request_id="retry-7")
        assert again.generation == 2 and again.hgraph == first.hgraph
        assert again.result == first.result and again.candidates_added == first.candidates_added
        graph = cb.get_hgraph(merged.hgraph)
        assert graph.generation == 2 and len(graph.inputs) == 4
        with pytest.raises(hgraph_client.HgraphError) as e:
            cb.add_paths(merged.hgraph, extra[:1], request_id="retry-7")
        assert e.value.code == grpc.StatusCode.ALREADY_EXISTS, e.value.message
        # A new id adds, and is remembered across replicas in turn.
        grown = cb.add_paths(merged.hgraph, extra[:1], request_id="retry-8")
        assert grown.generation == 3 and len(grown.result.inputs) == 5
    c = replicas()
    with c.client() as cc:
        assert cc.add_paths(merged.hgraph, extra[:1], request_id="retry-8").generation == 3
        assert cc.add_paths(merged.hgraph, extra, request_id="retry-7").generation == 2
        assert cc.get_hgraph(merged.hgraph).generation == 3
    assert b.metric("hgraph_store_loads_total", kind="hgraph") == 1


def test_another_tenant_cannot_load_a_stored_session(replicas, tmp_path):
    tokens = tmp_path / "tokens.txt"
    tokens.write_text("token-of-tenant-a-0001 team-a\ntoken-of-tenant-b-0002 team-b\n")
    tokens.chmod(0o600)
    a = replicas("--auth-tokens", str(tokens))
    b = replicas("--auth-tokens", str(tokens))
    with a.client(token="token-of-tenant-a-0001") as ca:
        merged = merge_on(ca)
        session = ca.session
    for replica in (a, b):
        with replica.client(token="token-of-tenant-b-0002") as other:
            for call in (lambda: other.requery(merged.hgraph, "length"),
                         lambda: other.get_session(session)):
                with pytest.raises(hgraph_client.HgraphError) as e:
                    call()
                assert e.value.code == grpc.StatusCode.PERMISSION_DENIED, e.value.message
    # The owner's token still reaches it on B.
    with b.client(token="token-of-tenant-a-0001") as cb:
        assert cb.requery(merged.hgraph, "length").path == merged.result.path


def test_list_and_delete_sessions_across_replicas(replicas, redis, tmp_path):
    """ListSessions on any replica lists the tenant's sessions from the store, with every
    H-Graph any replica wrote; DeleteSession on a replica that holds none of them deletes the
    session's stored H-Graphs; another tenant can neither list nor delete them."""
    tokens = tmp_path / "tokens.txt"
    tokens.write_text("token-of-tenant-a-0001 team-a\ntoken-of-tenant-b-0002 team-b\n")
    tokens.chmod(0o600)
    a, b, c = (replicas("--auth-tokens", str(tokens)) for _ in range(3))
    with a.client(token="token-of-tenant-a-0001") as ca:
        first = merge_on(ca)
        second = ca.merge(paths(), measure="length", variant="edit-distance", optimize_ms=0)
        kept = ca.session
        assert first.shared and second.shared
    with a.client(token="token-of-tenant-a-0001") as ca:
        merged_kept_apart = merge_on(ca)
        doomed = ca.session
    with a.client(token="token-of-tenant-b-0002") as cb:
        cb.create_session(cb.upload_scene(DATA / "scene.json"))
        other_tenant = cb.session
    session_id = doomed.split("/")[1]
    assert redis.keys(f"hgraph:1:hgraph:{session_id}:*")

    # B holds none of them: it lists tenant A's two sessions from the store, and not B's.
    with b.client(token="token-of-tenant-a-0001") as lb:
        listed = {s.name: s for s in lb.list_sessions(page_size=1)}  # one per page
    assert set(listed) == {kept, doomed}
    assert set(listed[kept].hgraphs) == {first.hgraph, second.hgraph}
    assert listed[kept].create_time.seconds > 0 and listed[kept].expire_time.seconds > 0
    with b.client(token="token-of-tenant-b-0002") as lb:
        assert [s.name for s in lb.list_sessions()] == [other_tenant]
        with pytest.raises(hgraph_client.HgraphError) as e:
            lb.delete_session(doomed)
        assert e.value.code == grpc.StatusCode.PERMISSION_DENIED, e.value.message
    assert redis.keys(f"hgraph:1:hgraph:{session_id}:*")

    # Deleted on B: its record and its H-Graph (built on A) leave the store.
    with b.client(token="token-of-tenant-a-0001") as db:
        db.delete_session(doomed)
    assert redis.keys(f"hgraph:1:hgraph:{session_id}:*") == []
    assert redis.keys(f"hgraph:1:session:{session_id}") == []
    with c.client(token="token-of-tenant-a-0001") as cc:
        assert [s.name for s in cc.list_sessions()] == [kept]
        with pytest.raises(hgraph_client.HgraphError) as e:
            cc.requery(merged_kept_apart.hgraph, "length")
        assert e.value.code == grpc.StatusCode.NOT_FOUND
        # The other session still answers there.
        assert cc.requery(first.hgraph, "length").path == first.result.path


def test_corrupt_entries_are_refused_with_clear_errors(replicas, redis):
    a = replicas()
    with a.client() as ca:
        merged = merge_on(ca)
        wrench = ROOT / "scenes" / "wrench" / "scene.json"
        mesh_scene = ca.upload_scene(wrench)
    [hgraph_key] = redis.keys("hgraph:1:hgraph:*")
    [blob_key] = redis.keys("hgraph:1:blob:*")
    value = redis.command("GET", hgraph_key)
    redis.command("SET", hgraph_key, value[:len(value) // 2])  # truncated
    redis.command("SET", blob_key, b"not the mesh")
    b = replicas()
    with b.client() as cb:
        with pytest.raises(hgraph_client.HgraphError) as e:
            cb.requery(merged.hgraph, "length")
        assert e.value.code == grpc.StatusCode.NOT_FOUND and e.value.reason == "HGRAPH_NOT_FOUND"
        with pytest.raises(hgraph_client.HgraphError) as e:
            cb.create_session(mesh_scene)
        assert e.value.code == grpc.StatusCode.NOT_FOUND and e.value.reason == "BLOB_NOT_FOUND"
        # Still serving.
        assert merge_on(cb).kept
    log = "".join(b.log)
    assert "refused the hgraph" in log and "refused the blob" in log, log
    assert b.metric("hgraph_store_refused_total") == 2


def test_store_down_then_back(replicas, redis):
    a = replicas()
    with a.client() as ca:
        ca.create_session(ca.upload_scene(DATA / "scene.json"))
        redis.stop(signal.SIGKILL)
        down = ca.merge(paths(), measure="length", optimize_ms=0)
        assert down.kept and not down.shared
        assert ca.requery(down.hgraph, "length").path == down.result.path
        assert a.metric("hgraph_store_errors_total") >= 1
        health = subprocess.run(
            [os.environ.get("HGRAPH_CLI", str(ROOT / "build" / "hgraph")), "health",
             "--server", a.target], capture_output=True, text=True)
        assert health.returncode == 0 and "SERVING" in health.stdout, health.stdout
        redis.start()
        time.sleep(1.2)  # the store is retried a second after its last failure
        back = ca.merge(paths(), measure="length", optimize_ms=0)
        assert back.kept and back.shared
    assert "serving from memory" in "".join(a.log)


def test_redis_restart_loses_nothing(replicas, redis):
    a = replicas()
    with a.client() as ca:
        merged = merge_on(ca)
    redis.stop()  # SIGTERM: the append-only file is complete
    redis.start()
    b = replicas()
    with b.client() as cb:
        again = cb.requery(merged.hgraph, "length")
        assert again.path == merged.result.path and again.stats.collision_checks == 0


def test_bad_store_flags_fail_at_startup(tmp_path):
    for flags, fragment in [
        (["--store", "redis://h:99999"], "--store: must be"),
        (["--store", "mysql://h"], "unknown scheme"),
        (["--store", "redis://u:secret@h"], "--store-password-file"),
        (["--store-ca-file", str(DATA / "scene.json")], "--store-ca-file: needs --store rediss"),
    ]:
        done = subprocess.run([SERVER, "--listen", "127.0.0.1:0", "--metrics-listen", "",
                               *flags], capture_output=True, text=True, timeout=30)
        assert done.returncode != 0, flags
        assert fragment in done.stderr, (flags, done.stderr)
        assert "secret" not in done.stderr


def test_tls_store_with_a_password(tmp_path):
    """rediss:// with a password file: a real redis-server with TLS and requirepass, its
    certificate from a CA made by openssl now. A replica that trusts another CA, or sends a
    wrong password, keeps serving from memory and says why in its log."""
    def openssl(*args):
        subprocess.run(["openssl", *args], cwd=tmp_path, check=True, capture_output=True)

    openssl("req", "-x509", "-newkey", "rsa:2048", "-nodes", "-keyout", "ca.key", "-out",
            "ca.pem", "-days", "2", "-subj", "/CN=store test CA")
    openssl("req", "-x509", "-newkey", "rsa:2048", "-nodes", "-keyout", "rogue.key", "-out",
            "rogue.pem", "-days", "2", "-subj", "/CN=rogue CA")
    openssl("req", "-newkey", "rsa:2048", "-nodes", "-keyout", "redis.key", "-out", "redis.csr",
            "-subj", "/CN=127.0.0.1")
    (tmp_path / "ext").write_text("subjectAltName=IP:127.0.0.1\n")
    openssl("x509", "-req", "-in", "redis.csr", "-CA", "ca.pem", "-CAkey", "ca.key",
            "-CAcreateserial", "-out", "redis.pem", "-days", "2", "-extfile", "ext")
    (tmp_path / "password").write_text("store-password-0123\n")
    (tmp_path / "wrong").write_text("not-the-password\n")
    port = free_port()
    redis = subprocess.Popen(
        [REDIS, "--port", "0", "--tls-port", str(port), "--bind", "127.0.0.1",
         "--tls-cert-file", "redis.pem", "--tls-key-file", "redis.key", "--tls-ca-cert-file",
         "ca.pem", "--tls-auth-clients", "no", "--requirepass", "store-password-0123",
         "--save", "", "--daemonize", "no"],
        cwd=tmp_path, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    started = []

    def replica(ca, password):
        r = Replica("--store", f"rediss://127.0.0.1:{port}", "--store-ca-file", str(tmp_path / ca),
                    "--store-password-file", str(tmp_path / password))
        started.append(r)
        return r

    try:
        for _ in range(200):
            try:
                socket.create_connection(("127.0.0.1", port), timeout=1).close()
                break
            except OSError:
                time.sleep(0.02)
        a, b = replica("ca.pem", "password"), replica("ca.pem", "password")
        with a.client() as ca:
            merged = merge_on(ca)
        assert merged.shared
        with b.client() as cb:
            again = cb.requery(merged.hgraph, "length")
            assert again.path == merged.result.path and again.stats.collision_checks == 0
        for bad, why in ((("rogue.pem", "password"), "TLS handshake failed"),
                         (("ca.pem", "wrong"), "AUTH refused")):
            r = replica(*bad)
            with r.client() as c:
                assert not merge_on(c).shared
            r.stop()
            log = r.whole_log()
            assert why in log, log
            assert "store-password-0123" not in log and "not-the-password" not in log
    finally:
        for r in started:
            if r.proc.poll() is None:
                r.stop()
        redis.terminate()
        redis.wait(timeout=20)
