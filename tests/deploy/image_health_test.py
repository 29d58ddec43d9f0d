#!/usr/bin/env python3
"""The image's HEALTHCHECK works when the server speaks TLS, and probes what deploy/ probes.

Reads the runtime stage of the Dockerfile (ENV, EXPOSE, HEALTHCHECK, ENTRYPOINT, CMD),
deploy/base/hgraph-server.yaml and deploy/compose/compose.yaml, and checks that the HEALTHCHECK
probes the plaintext health-only port the image opens by default (HGRAPH_HEALTH_LISTEN, read by
--health-listen), that the port is exposed and is not the gRPC port, and that Kubernetes' probes
and compose's healthcheck use the same port.

Then runs what a TLS deployment of the image runs: the real hgraph-server with the image's
environment and arguments of its own (--listen with --tls-cert/--tls-key, replacing the image's
CMD as `docker run IMAGE ARGS` does), its addresses moved to loopback ports chosen now, and the
HEALTHCHECK's command (the real hgraph CLI) against it: exit 0, SERVING. The same probe on the
gRPC port fails (it speaks TLS), which is why the HEALTHCHECK must not probe it.
Usage: image_health_test.py --root DIR --server-bin B --cli B. Exits 77 without openssl.
"""
import argparse
import json
import os
import pathlib
import re
import shutil
import subprocess
import sys
import tempfile

import yaml

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "integration"))
from server_process import ServerProcess, free_port  # noqa: E402

SKIP = 77
failures = []


def expect(ok, what):
    if not ok:
        failures.append(what)
        print("FAIL:", what)


def runtime_stage(dockerfile):
    """The instructions after the last FROM, as (INSTRUCTION, argument text) with continuation
    lines joined."""
    text = re.sub(r"\\\n", " ", dockerfile.read_text())
    stage = []
    for line in text.splitlines():
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        word, _, rest = line.partition(" ")
        if word.upper() == "FROM":
            stage = []
        stage.append((word.upper(), rest.strip()))
    return stage


def port_of(address):
    return int(address.rsplit(":", 1)[1])


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--root", required=True, type=pathlib.Path)
    parser.add_argument("--server-bin", required=True)
    parser.add_argument("--cli", required=True)
    args = parser.parse_args()
    if shutil.which("openssl") is None:
        print("SKIP: openssl is not installed")
        return SKIP

    stage = runtime_stage(args.root / "Dockerfile")
    env, exposed, healthcheck, entrypoint, cmd = {}, set(), None, None, None
    for word, rest in stage:
        if word == "ENV":
            for pair in rest.split():
                key, _, value = pair.partition("=")
                env[key] = value
        elif word == "EXPOSE":
            exposed |= {int(p.split("/")[0]) for p in rest.split()}
        elif word == "HEALTHCHECK":
            healthcheck = json.loads(rest.split(" CMD ", 1)[1])
        elif word == "ENTRYPOINT":
            entrypoint = json.loads(rest)
        elif word == "CMD":
            cmd = json.loads(rest)
    expect(entrypoint == ["hgraph-server"], f"ENTRYPOINT {entrypoint}")
    expect(healthcheck is not None and healthcheck[:2] == ["hgraph", "health"],
           f"HEALTHCHECK is not `hgraph health`: {healthcheck}")
    health_listen = env.get("HGRAPH_HEALTH_LISTEN", "")
    expect(health_listen, "the image opens no health-only port (ENV HGRAPH_HEALTH_LISTEN)")
    if failures:
        return 1
    health_port = port_of(health_listen)
    target = healthcheck[healthcheck.index("--server") + 1]
    grpc_listen = [a.split("=", 1)[1] for a in cmd if a.startswith("--listen=")]
    expect(grpc_listen and port_of(grpc_listen[0]) != health_port,
           f"the health-only port {health_port} is the gRPC port")
    expect(target == f"127.0.0.1:{health_port}",
           f"the HEALTHCHECK probes {target}, not the health-only port {health_port}")
    expect(health_port in exposed, f"port {health_port} is not EXPOSEd ({sorted(exposed)})")
    expect(not any(a.startswith("--health-listen") for a in cmd),
           "CMD sets --health-listen: arguments given to the container would drop it")

    # Kubernetes and compose probe the same port.
    [deployment] = [d for d in yaml.safe_load_all(
        (args.root / "deploy" / "base" / "hgraph-server.yaml").read_text())
        if d and d.get("kind") == "Deployment"]
    container = deployment["spec"]["template"]["spec"]["containers"][0]
    k8s_listen = [a.split("=", 1)[1] for a in container["args"]
                  if a.startswith("--health-listen=")]
    expect(k8s_listen == [f"0.0.0.0:{health_port}"],
           f"deploy/base: --health-listen {k8s_listen}, the image's is {health_listen}")
    for probe in ("readinessProbe", "livenessProbe"):
        port = container.get(probe, {}).get("grpc", {}).get("port")
        expect(port == health_port, f"deploy/base: {probe} on port {port}, not {health_port}")
    compose = yaml.safe_load((args.root / "deploy" / "compose" / "compose.yaml").read_text())
    test = compose["x-hgraph-server"]["healthcheck"]["test"]
    expect(test[1:] == healthcheck, f"compose's healthcheck {test[1:]} is not the image's")
    command = compose["x-hgraph-server"]["command"]
    expect(not any(a.startswith("--health-listen") and a != f"--health-listen={health_listen}"
                   for a in command), f"compose moves the health-only port: {command}")

    # A TLS server started as the image starts it, probed by the HEALTHCHECK's command.
    work = pathlib.Path(tempfile.mkdtemp(prefix="hgraph-image-health-"))
    server = None
    try:
        subprocess.run(["openssl", "req", "-x509", "-newkey", "rsa:2048", "-nodes", "-keyout",
                        "key.pem", "-out", "cert.pem", "-days", "2", "-subj", "/CN=localhost",
                        "-addext", "subjectAltName=IP:127.0.0.1"],
                       cwd=work, check=True, capture_output=True)
        (work / "key.pem").chmod(0o600)
        port = free_port()
        environment = dict(os.environ)
        environment["HGRAPH_HEALTH_LISTEN"] = f"127.0.0.1:{port}"
        server_args = ["--listen=127.0.0.1:0", "--metrics-listen", "", "--threads=1",
                       "--drain-s=0", "--tls-cert", str(work / "cert.pem"),
                       "--tls-key", str(work / "key.pem")]
        server = ServerProcess(args.server_bin, *server_args, name="TLS server", env=environment)
        expect(server.health_port == port,
               f"the server opened health port {server.health_port}, not {port} "
               "(HGRAPH_HEALTH_LISTEN)")

        def probe(address):
            command = [args.cli] + healthcheck[1:]
            command[command.index("--server") + 1] = address
            return subprocess.run(command + ["--timeout", "5"], capture_output=True, text=True)

        ok = probe(f"127.0.0.1:{port}")
        expect(ok.returncode == 0 and "SERVING" in ok.stdout,
               f"HEALTHCHECK on a TLS server: exit {ok.returncode} {ok.stdout} {ok.stderr}")
        on_tls = probe(server.target)
        expect(on_tls.returncode != 0,
               f"a plaintext probe of the TLS gRPC port succeeded: {on_tls.stdout}")
        print(f"HEALTHCHECK on the health-only port: exit {ok.returncode} {ok.stdout.strip()}; "
              f"on the TLS gRPC port: exit {on_tls.returncode}")
    finally:
        if server is not None:
            server.stop(timeout=30)
            if failures:
                print(server.whole_log()[-3000:])
        shutil.rmtree(work, ignore_errors=True)
    print(f"{len(failures)} problems")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
