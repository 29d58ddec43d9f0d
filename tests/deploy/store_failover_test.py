#!/usr/bin/env python3
"""Replicas sharing a store behind nginx: affinity is a cache optimisation, not a condition of
correctness.

Starts a redis-server, two hgraph-server processes with --store redis://..., and Debian's nginx
with deploy/base/nginx/hgraph.conf (cluster.py), all on loopback ports chosen now; every client
runs without retries (a recovery would hide a lost H-Graph). Then:
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
import shutil
import sys
import tempfile

import hgraph_client

from cluster import SKIP, Nginx, Replica, missing_tools, print_failure_logs
from redis_process import Redis


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--server-bin", required=True)
    parser.add_argument("--deploy", required=True, type=pathlib.Path)
    parser.add_argument("--data", required=True, type=pathlib.Path)
    args = parser.parse_args()
    missing = missing_tools(need_redis=True)
    if missing:
        print(missing)
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
    # Long store timeouts: a loaded test machine's slow Redis is not a store down (store_test.py).
    store = ("--store", redis.url, "--store-timeout-ms", "5000")
    replicas = [Replica(args.server_bin, i, *store) for i in range(2)]
    nginx = None
    clients = []
    try:
        nginx = Nginx(args.deploy, work, replicas)
        front = nginx.front
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
        replicas.append(Replica(args.server_bin, 2, *store))
        nginx.reload(replicas)
        for c, m in zip(clients, merged):
            again = c.requery(m.hgraph, "length")
            expect(again.path == m.result.path, f"{m.hgraph}: another path after scaling")
            expect(again.stats.collision_checks == 0, f"{m.hgraph}: checks after scaling")
        loads = sum(1 for r in replicas for line in r.lines()
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
            nginx.stop()
        for r in replicas:
            if r.proc.poll() is None:
                r.stop()
        redis.stop()
        if failures:
            print_failure_logs(replicas, nginx)
        shutil.rmtree(work, ignore_errors=True)
    print(f"{len(failures)} problems")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
