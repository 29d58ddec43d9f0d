"""Transport security and tenants of hgraph-server (--tls-cert, --tls-key, --tls-client-ca,
--auth-tokens): real servers on loopback, certificates made by `openssl` for this run, the Python
client and the C++ CLI. Every test that starts a server stops it.

Run through CTest (which sets the environment), or by hand:
    HGRAPH_SERVER=build/hgraph-server HGRAPH_CLI=build/hgraph \
    PYTHONPATH=client/python:build/python /usr/bin/python3 -m pytest tests/integration/test_security.py
"""
import os
import pathlib
import secrets
import shutil
import subprocess

import grpc
import pytest

import hgraph_client
from hgraph.v1 import service_pb2, service_pb2_grpc
from test_service import CLI, DATA, SERVER, Server, input_paths

HEALTH = "/grpc.health.v1.Health/Check"
SERVING = b"\x08\x01"  # HealthCheckResponse{status: SERVING}


def openssl(*args, cwd):
    subprocess.run(["openssl", *args], cwd=cwd, check=True, capture_output=True)


def make_ca(folder, name):
    openssl("req", "-x509", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1",
            "-nodes", "-keyout", f"{name}.key", "-out", f"{name}.pem", "-days", "2",
            "-subj", f"/CN=hgraph test {name}", cwd=folder)


def make_cert(folder, name, ca, usage):
    """A certificate for 127.0.0.1 and localhost, signed by `ca`."""
    (folder / f"{name}.ext").write_text(
        f"subjectAltName=DNS:localhost,IP:127.0.0.1\nextendedKeyUsage={usage}\n")
    openssl("req", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1", "-nodes",
            "-keyout", f"{name}.key", "-out", f"{name}.csr", "-subj", f"/CN={name}", cwd=folder)
    openssl("x509", "-req", "-in", f"{name}.csr", "-CA", f"{ca}.pem", "-CAkey", f"{ca}.key",
            "-CAcreateserial", "-out", f"{name}.pem", "-days", "2", "-extfile", f"{name}.ext",
            cwd=folder)


@pytest.fixture(scope="module")
def pki(tmp_path_factory):
    """A CA with a server and a client certificate, and a second CA the server does not trust
    with a client certificate of its own."""
    if shutil.which("openssl") is None:
        pytest.skip("openssl is not installed (scripts/install-deps.sh installs it)")
    folder = tmp_path_factory.mktemp("pki")
    make_ca(folder, "ca")
    make_cert(folder, "server", "ca", "serverAuth")
    make_cert(folder, "client", "ca", "clientAuth")
    make_ca(folder, "rogue-ca")
    make_cert(folder, "rogue-client", "rogue-ca", "clientAuth")
    return folder


TOKEN_A = "a-" + secrets.token_urlsafe(24)
TOKEN_B = "b-" + secrets.token_urlsafe(24)
WRONG = "w-" + secrets.token_urlsafe(24)


@pytest.fixture(scope="module")
def tokens(tmp_path_factory):
    path = tmp_path_factory.mktemp("auth") / "tokens.txt"
    path.write_text(f"# tenants of the security test\n\n{TOKEN_A} team-a\n"
                    f"{TOKEN_B}\tteam-b  # second tenant\n")
    path.chmod(0o600)
    return path


def call_health(channel, timeout=10):
    return channel.unary_unary(HEALTH)(b"", timeout=timeout)


def expect_code(code, call):
    with pytest.raises(hgraph_client.HgraphError) as info:
        call()
    assert info.value.code == code, info.value
    return info.value


def merge_once(client):
    client.create_session(client.upload_scene(DATA / "scene.json", timeout=20), timeout=20)
    return client.merge(input_paths(), timeout=60)


def stopped(server):
    """Stops the server and returns its whole log (the reader ends at the log's end)."""
    code = server.stop()
    log = server.whole_log()
    assert code == 0, log
    return log


# TLS ----------------------------------------------------------------------------------------


def test_tls_needs_a_tls_client_that_trusts_the_ca(pki):
    server = Server("--tls-cert", str(pki / "server.pem"), "--tls-key", str(pki / "server.key"))
    try:
        # A plaintext client cannot talk to a TLS port.
        with hgraph_client.Client(server.target, retries=0) as plain:
            expect_code(grpc.StatusCode.UNAVAILABLE, lambda: plain.list_sessions())
        # TLS that does not trust the server's CA fails the handshake.
        with hgraph_client.Client(server.target, retries=0,
                                  tls_ca=pki / "rogue-ca.pem") as untrusting:
            expect_code(grpc.StatusCode.UNAVAILABLE, lambda: untrusting.list_sessions())
        # TLS with the right CA (as a path, or the PEM bytes) works end to end.
        with hgraph_client.Client(server.target, tls_ca=pki / "ca.pem") as client:
            merged = merge_once(client)
            assert merged.result.quality.length > 0
        with hgraph_client.Client(server.target,
                                  tls_ca=(pki / "ca.pem").read_bytes()) as client:
            assert client.list_sessions() != []
        channel = grpc.secure_channel(
            server.target, grpc.ssl_channel_credentials((pki / "ca.pem").read_bytes()))
        assert call_health(channel) == SERVING
        channel.close()
    finally:
        log = stopped(server)
    assert "(TLS, no authentication)" in log


def test_mutual_tls_requires_a_client_certificate_of_the_ca(pki):
    server = Server("--tls-cert", str(pki / "server.pem"), "--tls-key", str(pki / "server.key"),
                    "--tls-client-ca", str(pki / "ca.pem"))
    try:
        with hgraph_client.Client(server.target, retries=0, tls_ca=pki / "ca.pem") as no_cert:
            expect_code(grpc.StatusCode.UNAVAILABLE, lambda: no_cert.list_sessions())
        with hgraph_client.Client(server.target, retries=0, tls_ca=pki / "ca.pem",
                                  tls_cert=pki / "rogue-client.pem",
                                  tls_key=pki / "rogue-client.key") as rogue:
            expect_code(grpc.StatusCode.UNAVAILABLE, lambda: rogue.list_sessions())
        with hgraph_client.Client(server.target, tls_ca=pki / "ca.pem",
                                  tls_cert=pki / "client.pem",
                                  tls_key=pki / "client.key") as client:
            assert merge_once(client).hgraph
    finally:
        log = stopped(server)
    assert "(mutual TLS, no authentication)" in log


def run_server(*flags):
    return subprocess.run([SERVER, "--listen", "127.0.0.1:0", "--metrics-listen", "", *flags],
                          capture_output=True, text=True, timeout=60)


@pytest.mark.parametrize("flags, fragment", [
    (["--tls-cert", "{pki}/server.pem"], "--tls-key: --tls-cert and --tls-key go together"),
    (["--tls-key", "{pki}/server.key"], "--tls-cert: --tls-cert and --tls-key go together"),
    (["--tls-client-ca", "{pki}/ca.pem"], "--tls-client-ca: mutual TLS needs the server's own"),
    (["--tls-cert", "{pki}/server.pem", "--tls-key", "{pki}/client.key"],
     "--tls-key: {pki}/client.key is not the private key of the certificate in"),
    (["--tls-cert", "{pki}/server.key", "--tls-key", "{pki}/server.key"],
     "--tls-cert: {pki}/server.key holds no PEM certificate"),
    (["--tls-cert", "{pki}/server.pem", "--tls-key", "{pki}/server.pem"],
     "--tls-key: {pki}/server.pem holds no unencrypted PEM private key"),
    (["--tls-cert", "{pki}/server.pem", "--tls-key", "{pki}/server.key",
      "--tls-client-ca", "{pki}/server.ext"], "--tls-client-ca: {pki}/server.ext holds no PEM"),
    (["--tls-cert", "{pki}/missing.pem", "--tls-key", "{pki}/server.key"], "--tls-cert"),
])
def test_tls_flag_errors_name_the_flag(pki, flags, fragment):
    done = run_server(*[f.format(pki=pki) for f in flags])
    assert done.returncode != 0
    assert fragment.format(pki=pki) in done.stderr, done.stderr
    assert "ready" not in done.stdout
    # A key file's bytes never reach the log.
    assert (pki / "server.key").read_text().splitlines()[1] not in done.stderr


# Tokens -------------------------------------------------------------------------------------


@pytest.mark.parametrize("text, fragment", [
    ("# only a comment\n", "holds no \"TOKEN TENANT\" line"),
    (f"{TOKEN_A} team-a\n{TOKEN_A}x\n", "line 2: expected \"TOKEN TENANT\""),
    (f"{TOKEN_A} team-a\n\n{TOKEN_A} team-b\n", "line 3: repeats the token of line 1"),
    (f"short team-a\n", "line 1: the token has 5 characters"),
    (f"{TOKEN_A} team/a\n", "line 1: the tenant must be"),
])
def test_bad_token_files_are_refused_at_start_without_quoting_them(tmp_path, text, fragment):
    path = tmp_path / "tokens.txt"
    path.write_text(text)
    done = run_server("--auth-tokens", str(path))
    assert done.returncode == 2, done.stderr
    assert f"--auth-tokens: {path}" in done.stderr and fragment in done.stderr, done.stderr
    assert TOKEN_A not in done.stderr


def test_a_token_file_others_can_read_is_warned_about(tmp_path):
    path = tmp_path / "tokens.txt"
    path.write_text(f"{TOKEN_A} team-a\n")
    path.chmod(0o644)
    server = Server("--auth-tokens", str(path))
    log = stopped(server)
    assert f"--auth-tokens: {path} is readable by other users" in log
    assert TOKEN_A not in log


@pytest.fixture(scope="module")
def token_server(pki, tokens):
    """TLS plus bearer tokens for two tenants."""
    server = Server("--tls-cert", str(pki / "server.pem"), "--tls-key", str(pki / "server.key"),
                    "--auth-tokens", str(tokens), "--max-paths", "8")
    yield server
    log = stopped(server)
    # The log counts tokens and tenants; it never holds a token, right or wrong.
    assert "--auth-tokens: 2 tokens for 2 tenants" in log
    assert "readable by other users" not in log  # the fixture's file is 0600
    for secret in (TOKEN_A, TOKEN_B, WRONG):
        assert secret not in log


def tenant(server, pki, token, **kwargs):
    return hgraph_client.Client(server.target, tls_ca=pki / "ca.pem", token=token, **kwargs)


def test_python_client_takes_the_token_from_the_environment(token_server, pki, monkeypatch):
    monkeypatch.setenv("HGRAPH_TOKEN", TOKEN_B)
    with tenant(token_server, pki, None) as from_env, tenant(token_server, pki, TOKEN_A) as a:
        name = a.create_session(a.upload_scene(DATA / "scene.json")).name
        expect_code(grpc.StatusCode.PERMISSION_DENIED, lambda: from_env.get_session(name))
        assert a.get_session(name).name == name  # the argument wins over the variable
        a.delete_session(name)
    with pytest.raises(ValueError, match="token: must be visible ASCII"):
        hgraph_client.Client("127.0.0.1:1", token="two words")
    with pytest.raises(ValueError, match="tls_cert and tls_key go together"):
        hgraph_client.Client("127.0.0.1:1", tls_cert=pki / "client.pem")


def test_calls_without_a_valid_token_are_unauthenticated(token_server, pki, monkeypatch):
    monkeypatch.delenv("HGRAPH_TOKEN", raising=False)
    with tenant(token_server, pki, "", retries=0) as anonymous:
        missing = expect_code(grpc.StatusCode.UNAUTHENTICATED, anonymous.list_sessions)
        assert "no authorization metadata" in missing.message
        assert "Bearer" in missing.message
        # Every kind of call is refused before any work: uploads, scenes, merges.
        expect_code(grpc.StatusCode.UNAUTHENTICATED, lambda: anonymous.upload_blob(b"x" * 100))
        expect_code(grpc.StatusCode.UNAUTHENTICATED,
                    lambda: anonymous.upload_scene(DATA / "scene.json"))
        expect_code(grpc.StatusCode.UNAUTHENTICATED,
                    lambda: anonymous.merge(input_paths(), session="sessions/" + "0" * 32))
        expect_code(grpc.StatusCode.UNAUTHENTICATED,
                    lambda: anonymous.plan(session="sessions/" + "0" * 32))
    with tenant(token_server, pki, WRONG, retries=0) as wrong:
        unknown = expect_code(grpc.StatusCode.UNAUTHENTICATED, wrong.list_sessions)
    # A malformed header gets the same answer as an unknown token.
    channel = grpc.secure_channel(token_server.target,
                                  grpc.ssl_channel_credentials((pki / "ca.pem").read_bytes()))
    stub = service_pb2_grpc.PathMergerStub(channel)
    for value in ("Basic " + TOKEN_A, TOKEN_A, "Bearer", "Bearer " + TOKEN_A + "x"):
        with pytest.raises(grpc.RpcError) as info:
            stub.ListSessions(service_pb2.ListSessionsRequest(),
                              metadata=(("authorization", value),), timeout=10)
        assert info.value.code() == grpc.StatusCode.UNAUTHENTICATED
        assert info.value.details() == unknown.message
    # The scheme's case does not matter (RFC 7235).
    stub.ListSessions(service_pb2.ListSessionsRequest(),
                      metadata=(("authorization", "bearer " + TOKEN_A),), timeout=10)
    # Health stays open without a token.
    assert call_health(channel) == SERVING
    channel.close()
    assert token_server.metric("grpc_server_handled_total", grpc_method="ListSessions",
                               grpc_code="UNAUTHENTICATED") >= 6


def test_sessions_and_hgraphs_belong_to_their_tenant(token_server, pki):
    with tenant(token_server, pki, TOKEN_A) as a, tenant(token_server, pki, TOKEN_B,
                                                         retries=0) as b:
        scene = a.upload_scene(DATA / "scene.json")
        session_a = a.create_session(scene).name
        merged = a.merge(input_paths(), measure="inverse-clearance", variant="all-pairs",
                         evaluation="eager", optimize_ms=0)
        assert merged.hgraph.startswith(session_a + "/hgraphs/")

        # B cannot see, use, re-query, take over or delete A's session.
        denied = [
            lambda: b.get_session(session_a),
            lambda: b.delete_session(session_a),
            lambda: b.requery(merged.hgraph, "bottleneck-clearance"),
            lambda: b.merge(input_paths(), session=session_a),
            lambda: b.check(input_paths(), session=session_a),
            lambda: b.plan(session=session_a),
            lambda: b.create_session(scene, session_id=session_a.split("/", 1)[1]),
        ]
        for call in denied:
            error = expect_code(grpc.StatusCode.PERMISSION_DENIED, call)
            assert "belongs to another tenant" in error.message
            assert "team-a" not in error.message
        assert session_a not in [s.name for s in b.list_sessions()]

        # The scene is shared by digest: B opens its own session on it without uploading.
        session_b = b.create_session(scene).name
        assert b.merge(input_paths()).hgraph.startswith(session_b + "/hgraphs/")
        assert [s.name for s in b.list_sessions()] == [session_b]
        assert [s.name for s in a.list_sessions()] == [session_a]
        # So are blobs: what A uploaded, B's FindMissingBlobs does not ask for.
        blob = a.upload_blob(b"shared mesh bytes " * 10)
        missing = b.stub.FindMissingBlobs(service_pb2.FindMissingBlobsRequest(digests=[blob]),
                                          metadata=b._metadata(), timeout=10).missing
        assert list(missing) == []

        # B's attempts changed nothing for A, who can still re-query and delete.
        again = a.requery(merged.hgraph, "bottleneck-clearance")
        assert again.stats.edges_checked == 0
        a.delete_session(session_a)
        expect_code(grpc.StatusCode.NOT_FOUND, lambda: a.get_session(session_a))
        b.delete_session(session_b)


def test_without_auth_tokens_a_sent_token_is_ignored():
    server = Server()
    try:
        with hgraph_client.Client(server.target, token=TOKEN_A) as with_token, \
                hgraph_client.Client(server.target) as without:
            name = with_token.create_session(with_token.upload_scene(DATA / "scene.json")).name
            # One anonymous tenant: the session is everyone's, as before tenants existed.
            assert without.get_session(name).name == name
            assert name in [s.name for s in without.list_sessions()]
    finally:
        stopped(server)


# The CLI ------------------------------------------------------------------------------------


def run_cli(*args, env=None, timeout=120):
    return subprocess.run([CLI, *args], capture_output=True, text=True, timeout=timeout,
                          env={**os.environ, **(env or {})})


def test_cli_health_and_merge_over_tls_with_a_token(token_server, pki):
    ca = str(pki / "ca.pem")
    health = run_cli("health", "--server", token_server.target, "--tls-ca", ca)
    assert health.returncode == 0 and "SERVING" in health.stdout, health.stdout + health.stderr
    plain = run_cli("health", "--server", token_server.target, "--timeout", "3")
    assert plain.returncode == 1, plain.stdout

    merge = ["merge", "--server", token_server.target, "--scene", str(DATA / "scene.json"),
             "--paths", str(DATA / "paths.txt"), "--tls-ca", ca]
    done = run_cli(*merge, "--token", TOKEN_A, env={"HGRAPH_TOKEN": ""})
    assert done.returncode == 0, done.stderr
    assert "hgraph sessions/" in done.stdout
    # The token from the environment; the flag wins over it.
    assert run_cli(*merge, env={"HGRAPH_TOKEN": TOKEN_B}).returncode == 0
    assert run_cli(*merge, "--token", TOKEN_A, env={"HGRAPH_TOKEN": WRONG}).returncode == 0
    refused = run_cli(*merge, env={"HGRAPH_TOKEN": ""})
    # Rejected, not failed: exit 2 with the code and the server's message.
    assert refused.returncode == 2, refused.stderr
    assert "UNAUTHENTICATED" in refused.stderr and "no authorization metadata" in refused.stderr
    wrong = run_cli(*merge, "--token", WRONG)
    assert wrong.returncode == 2 and "UNAUTHENTICATED" in wrong.stderr, wrong.stderr
    # Another tenant's H-Graph cannot be re-queried from the CLI either.
    hgraph = done.stdout.split("hgraph ", 1)[1].split()[0]
    other = run_cli("requery", "--server", token_server.target, "--hgraph", hgraph,
                    "--tls-ca", ca, "--token", TOKEN_B)
    assert other.returncode == 2 and "PERMISSION_DENIED" in other.stderr, other.stderr
    own = run_cli("requery", "--server", token_server.target, "--hgraph", hgraph,
                  "--tls-ca", ca, "--token", TOKEN_A)
    assert own.returncode == 0, own.stderr


def test_cli_mutual_tls(pki):
    server = Server("--tls-cert", str(pki / "server.pem"), "--tls-key", str(pki / "server.key"),
                    "--tls-client-ca", str(pki / "ca.pem"))
    try:
        ca = ["--tls-ca", str(pki / "ca.pem")]
        cert = ["--tls-cert", str(pki / "client.pem"), "--tls-key", str(pki / "client.key")]
        assert run_cli("health", "--server", server.target, *ca, *cert).returncode == 0
        assert run_cli("health", "--server", server.target, *ca, "--timeout", "3").returncode == 1
        done = run_cli("merge", "--server", server.target, "--scene", str(DATA / "scene.json"),
                       "--paths", str(DATA / "paths.txt"), *ca, *cert)
        assert done.returncode == 0, done.stderr
        lone = run_cli("health", "--server", server.target, *ca, "--tls-cert",
                       str(pki / "client.pem"))
        assert lone.returncode == 2 and "--tls-key" in lone.stderr, lone.stderr
    finally:
        stopped(server)


# Probes, reflection and quotas -----------------------------------------------------------------


def reflect(channel):
    """ServerReflectionRequest{list_services: ""}: the services listed, or the error code."""
    call = channel.stream_stream("/grpc.reflection.v1alpha.ServerReflection/ServerReflectionInfo")
    try:
        return list(call(iter([b"\x3a\x00"]), timeout=5))[0]
    except grpc.RpcError as e:
        return e.code()


def test_health_listener_answers_plaintext_probes_of_a_tls_server(pki, tokens):
    server = Server("--tls-cert", str(pki / "server.pem"), "--tls-key", str(pki / "server.key"),
                    "--auth-tokens", str(tokens), "--health-listen", "127.0.0.1:0")
    try:
        assert server.health_port > 0
        probe = f"127.0.0.1:{server.health_port}"
        health = run_cli("health", "--server", probe)
        assert health.returncode == 0 and "SERVING" in health.stdout, health.stdout
        # Health only: the service itself is not there, and neither is reflection.
        channel = grpc.insecure_channel(probe)
        stub = service_pb2_grpc.PathMergerStub(channel)
        with pytest.raises(grpc.RpcError) as e:
            stub.ListSessions(service_pb2.ListSessionsRequest(), timeout=5)
        assert e.value.code() == grpc.StatusCode.UNIMPLEMENTED
        assert reflect(channel) == grpc.StatusCode.UNIMPLEMENTED
        channel.close()
        # With --auth-tokens reflection is off on the gRPC port too.
        with grpc.secure_channel(server.target, grpc.ssl_channel_credentials(
                (pki / "ca.pem").read_bytes())) as tls:
            assert reflect(tls) == grpc.StatusCode.UNIMPLEMENTED
    finally:
        stopped(server)


def test_reflection_with_tokens_when_asked_for(tokens):
    server = Server("--auth-tokens", str(tokens), "--reflection")
    try:
        with grpc.insecure_channel(server.target) as channel:
            assert b"hgraph.v1.PathMerger" in reflect(channel)
    finally:
        stopped(server)


def test_tenant_quotas_refuse_naming_the_quota(tokens):
    server = Server("--auth-tokens", str(tokens), "--tenant-max-sessions", "1",
                    "--tenant-cache-bytes", "1")
    try:
        with hgraph_client.Client(server.target, token=TOKEN_A, retries=0) as a, \
                hgraph_client.Client(server.target, token=TOKEN_B, retries=0) as b:
            digest = a.upload_scene(DATA / "scene.json")
            a.create_session(digest)
            first = a.merge(input_paths(), optimize_ms=0)
            assert first.kept
            # The tenant's H-Graphs hold more than its 1-byte quota now.
            error = expect_code(grpc.StatusCode.RESOURCE_EXHAUSTED,
                                lambda: a.merge(input_paths(), optimize_ms=0))
            assert error.reason == "TENANT_QUOTA" and "--tenant-cache-bytes" in error.message
            with hgraph_client.Client(server.target, token=TOKEN_A, retries=0) as again:
                error = expect_code(grpc.StatusCode.RESOURCE_EXHAUSTED,
                                    lambda: again.create_session(digest))
                assert error.reason == "TENANT_QUOTA" and "--tenant-max-sessions" in error.message
            # Another tenant is not held to the first one's use.
            b.create_session(b.upload_scene(DATA / "scene.json"))
            assert b.merge(input_paths(), optimize_ms=0).kept
            a.delete_hgraph(first.hgraph)
            assert a.merge(input_paths(), optimize_ms=0).kept
    finally:
        stopped(server)
