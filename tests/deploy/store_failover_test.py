#!/usr/bin/env python3
"""Replicas sharing a store behind nginx: affinity is a cache optimisation, not a condition of
correctness.

Starts a redis-server, two hgraph-server processes with --store redis://..., and Debian's nginx
with deploy/base/nginx/hgraph.conf (as affinity_test.py does), all on loopback ports chosen now;
every client runs without retries (a recovery would hide a lost H-Graph). Then:
  1. merges in six sessions through nginx;
  2. scales from two replicas to three and reloads nginx (part of the hash ring moves): every
     session's next call, a requery of its H-Graph, answers as before, without a check;
  3. SIGKILLs the replica that built the first session's H-Graph and at once requeries it under
     the merge's measure through nginx: the same path, 0 collision checks, 0 distance queries.
Usage: store_failover_test.py --server-bin B --deploy DIR --data DIR. Exits 77 without nginx or
redis-server.
"""
import argparse
import pathlib
import random
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time

import hgraph_client

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "integration"))
from server_process import ServerProcess, free_port  # noqa: E402
from affinity_test import start_nginx  # noqa: E402
from store_test import Redis  # noqa: E402

SKIP = 77


class Replica(ServerProcess):
    def __init__(self, binary, index, store):
        self.index = index
        super().__init__(binary, "--listen", "127.0.0.1:0", "--metrics-listen", "", "--threads",
                         "1", "--drain-s", "0", "--grace-s", "2", "--store", store,
                         name=f"replica {index}")

    def built(self, hgraph_name):
        session = hgraph_name.split("/hgraphs/")[0]
        return any(" MergePaths session=" + session in line for line in list(self.log))


def write_upstreams(deploy, work, replicas):
    k8s = [l for l in (deploy / "base" / "nginx" / "upstreams.inc").read_text().splitlines()
           if l.startswith("server ")]
    (work / "conf" / "conf.d" / "upstreams.inc").write_text("".join(
        re.sub(r"server \S+", f"server 127.0.0.1:{r.port}", k8s[0]) + "\n" for r in replicas))


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--server-bin", required=True)
    parser.add_argument("--deploy", required=True, type=pathlib.Path)
    parser.add_argument("--data", required=True, type=pathlib.Path)
    args = parser.parse_args()
    if shutil.which("nginx") is None and not pathlib.Path("/usr/sbin/nginx").exists():
        print("SKIP: nginx is not installed (scripts/install-deps.sh installs it)")
        return SKIP
    if shutil.which("redis-server") is None:
        print("SKIP: redis-server is not installed (scripts/install-deps.sh installs it)")
        return SKIP

    scene = args.data / "circles" / "scene.json"
    paths = hgraph_client.load_paths_text((args.data / "circles" / "paths.txt").read_text())
    failures = []

    def expect(ok, what):
        if not ok:
            failures.append(what)
            print("FAIL:", what)

    work = pathlib.Path(tempfile.mkdtemp(prefix="hgraph-store-failover-"))
    (work / "redis").mkdir()
    redis = Redis(work / "redis")
    replicas = [Replica(args.server_bin, i, redis.url) for i in range(2)]
    nginx = None
    clients = []
    try:
        nginx, front = start_nginx(args.deploy, replicas, work)
        print(f"nginx on {front}; replicas on ports {[r.port for r in replicas]}")

        # 1. Merges through nginx, in sessions named from a seeded generator.
        rng = random.Random(11)
        merged = []
        for i in range(6):
            c = hgraph_client.connect(front, retries=0)
            c.session_name = "sessions/%032x" % rng.getrandbits(128)
            c.create_session(c.upload_scene(scene))
            outcome = c.merge(paths, measure="length", variant="all-pairs", optimize_ms=0)
            expect(outcome.kept and outcome.shared, f"session {i}: not kept in the store")
            clients.append(c)
            merged.append(outcome)

        # 2. Scale to three and reload nginx: the ring moves, every H-Graph still answers.
        replicas.append(Replica(args.server_bin, 2, redis.url))
        write_upstreams(args.deploy, work, replicas)
        nginx.send_signal(signal.SIGHUP)
        time.sleep(1.0)  # the new workers take over
        for c, m in zip(clients, merged):
            again = c.requery(m.hgraph, "length")
            expect(again.path == m.result.path, f"{m.hgraph}: another path after scaling")
            expect(again.stats.collision_checks == 0, f"{m.hgraph}: checks after scaling")
        loads = sum(1 for r in replicas for line in list(r.log)
                    if "loaded from the store" in line and "/hgraphs/" in line)
        print(f"after scaling to 3: {len(merged)} H-Graphs answered, {loads} of them loaded by "
              "a replica that had not held them")

        # 3. Kill the first H-Graph's builder at once, requery it through nginx.
        first = merged[0]
        [builder] = [r for r in replicas if r.built(first.hgraph)]
        builder.proc.kill()
        builder.proc.wait()
        print(f"SIGKILLed replica {builder.index}, the builder of {first.hgraph}")
        again = clients[0].requery(first.hgraph, "length")
        expect(again.path == first.result.path, "another path after the builder was killed")
        expect(again.stats.collision_checks == 0 and again.stats.distance_queries == 0,
               f"checks after the builder was killed: {again.stats.collision_checks} collision "
               f"checks, {again.stats.distance_queries} distance queries")
        for c, m in zip(clients[1:], merged[1:]):
            expect(c.requery(m.hgraph, "length").path == m.result.path,
                   f"{m.hgraph}: another path after the kill")
        expect(all(c.recoveries == 0 for c in clients), "a client re-created its session")
    except hgraph_client.HgraphError as e:
        expect(False, f"a call failed: {e.code.name}: {e.message}")
    finally:
        for c in clients:
            c.close()
        if nginx is not None:
            nginx.send_signal(signal.SIGQUIT)
            try:
                nginx.wait(timeout=20)
            except subprocess.TimeoutExpired:
                nginx.kill()
        for r in replicas:
            if r.proc.poll() is None:
                r.stop(timeout=30)
        redis.stop()
        if failures:
            for r in replicas:
                print(f"--- replica {r.index} log\n" + "".join(r.log[-30:]))
            if (work / "error.log").exists():
                print("--- nginx error.log\n" + (work / "error.log").read_text()[-3000:])
        shutil.rmtree(work, ignore_errors=True)
    print(f"{len(failures)} problems")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
