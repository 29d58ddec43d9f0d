#!/usr/bin/env python3
"""A rolling restart under load: replicas sharing a store lose no request and no H-Graph.

Starts a redis-server, three hgraph-server processes with --store redis://... on loopback ports
chosen now, and Debian's nginx with deploy/base/nginx/hgraph.conf in front (cluster.py). Worker
threads, each a Python client through nginx with its default retries, in a session of its own,
repeat: merge the circle paths (a variant and a measure drawn from a seeded generator), add a
path to the new H-Graph (AddPaths), publish the H-Graph with the addition's answer, and requery
an H-Graph some worker published under its measure, which must answer that path again.

While they run, each replica in turn is restarted as a rolling update restarts a pod: SIGTERM
(exit status 0), a new process on the same port, health SERVING, the next restart 3 s after
this one began. After each restart every H-Graph published so far is requeried through nginx
under its measure: the same path.

Fails on any call that fails after the client's retries, a different path, an H-Graph not
written to the store, or a non-zero exit status. Usage: store_restart_test.py --server-bin B
--deploy DIR --data DIR. Exits 77 without nginx or redis-server.
"""
import argparse
import pathlib
import random
import shutil
import sys
import tempfile
import threading
import time

import hgraph_client

from cluster import SKIP, Nginx, Replica, missing_tools, print_failure_logs
from redis_process import Redis

WORKERS = 3
VARIANTS = ["all-pairs", "edit-distance", "k-nearest", "neighborhood"]
MEASURES = ["length", "inverse-clearance"]
# From one restart to the next: more than nginx skips a replica that refused a connection
# (fail_timeout, deploy/base/nginx/upstreams.inc), as a rolling update that waits for each new
# replica to be ready. Restarts closer than that leave nginx no replica for a moment ("no live
# upstreams"), longer than the client's retries.
SPACING_S = 3.0
# Between a worker's rounds (merge, addition, requery): a steady load whose H-Graphs can all be
# requeried after each restart in a few seconds.
PAUSE_S = 0.1


class Published:
    """H-Graphs the workers made, each with its measure and the path it must answer."""

    def __init__(self):
        self.lock = threading.Lock()
        self.items = []  # (hgraph name, measure, path)

    def add(self, item):
        with self.lock:
            self.items.append(item)

    def snapshot(self):
        with self.lock:
            return list(self.items)


def midpoints(path):
    """The path with a waypoint inserted in the middle of each segment: the same motion, other
    nodes (an addition that changes the H-Graph and keeps it free)."""
    out = []
    for a, b in zip(path, path[1:]):
        out.append(a)
        out.append([(x + y) / 2 for x, y in zip(a, b)])
    out.append(path[-1])
    return out


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
    first = [list(w.values) for w in paths.paths[0].waypoints]
    extra = hgraph_client.make_paths([midpoints(first)])
    extra.paths[0].name = "midpoints"
    failures = []
    failures_lock = threading.Lock()

    def expect(ok, what):
        if not ok:
            with failures_lock:
                failures.append(what)
            print("FAIL:", what, flush=True)

    work = pathlib.Path(tempfile.mkdtemp(prefix="hgraph-store-restart-"))
    (work / "redis").mkdir()
    redis = Redis(work / "redis")
    replicas = []
    nginx = None
    published = Published()
    stop = threading.Event()
    counts = {"merge": 0, "add_paths": 0, "requery": 0}
    counts_lock = threading.Lock()
    clients = []

    def count(method):
        with counts_lock:
            counts[method] += 1

    def worker(index):
        rng = random.Random(100 + index)
        c = hgraph_client.connect(nginx.front)
        clients.append(c)
        c.session_name = "sessions/%032x" % rng.getrandbits(128)
        try:
            c.create_session(c.upload_scene(scene))
            while not stop.is_set():
                measure = rng.choice(MEASURES)
                merged = c.merge(paths, measure=measure, variant=rng.choice(VARIANTS),
                                 optimize_ms=0)
                count("merge")
                expect(merged.kept and merged.shared,
                       f"{merged.hgraph}: not kept in the store ({merged.retention})")
                added = c.add_paths(merged.hgraph, extra, measure,
                                    request_id="add-%032x" % rng.getrandbits(128),
                                    expected_generation=merged.generation)
                count("add_paths")
                expect(added.shared and added.generation == merged.generation + 1,
                       f"{merged.hgraph}: the addition was not stored (generation "
                       f"{added.generation}, shared {added.shared})")
                published.add((merged.hgraph, measure, added.result.path))
                hgraph, m, path = rng.choice(published.snapshot())
                expect(c.requery(hgraph, m).path == path, f"{hgraph}: another path under {m}")
                count("requery")
                stop.wait(PAUSE_S)
        except hgraph_client.HgraphError as e:
            expect(False, f"worker {index}: a call failed after the client's retries: "
                   f"{e.code.name}: {e.message}")

    def verify(after):
        """Requeries every published H-Graph through nginx: the same path."""
        items = published.snapshot()
        # With the client's retries on transient errors: a lost H-Graph is NOT_FOUND, not those.
        with hgraph_client.connect(nginx.front) as v:
            for hgraph, measure, path in items:
                try:
                    got = v.requery(hgraph, measure)
                    expect(got.path == path, f"{hgraph}: another path under {measure} {after}")
                except hgraph_client.HgraphError as e:
                    expect(False, f"{hgraph}: {e.code.name} {after}: {e.message}")
        print(f"{after}: {len(items)} H-Graphs answer as before", flush=True)
        return len(items)

    threads = []
    started = time.monotonic()
    try:
        # A store slower than --store-timeout-ms (500 ms by default) is "down" and the replicas
        # serve from memory, as they should (store_test.py); on a loaded test machine it is only
        # slow, so the timeout here is long.
        replicas = [Replica(args.server_bin, i, "--store", redis.url, "--store-timeout-ms", "5000")
                    for i in range(3)]
        nginx = Nginx(args.deploy, work, replicas)
        print(f"nginx on {nginx.front}; replicas on ports {[r.port for r in replicas]}")
        threads = [threading.Thread(target=worker, args=(i,)) for i in range(WORKERS)]
        for t in threads:
            t.start()
        time.sleep(2.0)  # H-Graphs on every replica before the first restart
        checked = []
        for r in replicas:
            began = time.monotonic()
            status = r.restart()
            expect(status == 0, f"replica {r.index}: exit status {status} on SIGTERM")
            print(f"restarted replica {r.index} (exit status {status})", flush=True)
            checked.append(verify(f"after restarting replica {r.index}"))
            time.sleep(max(0.0, began + SPACING_S - time.monotonic()))  # load meanwhile
        stop.set()
        for t in threads:
            t.join(timeout=120)
            expect(not t.is_alive(), "a worker did not finish")
        final = verify("after the load")
        expect(counts["merge"] >= 6 and checked[0] > 0,
               f"too little load to tell: {counts}, H-Graphs checked {checked}")
        recoveries = sum(c.recoveries for c in clients)
        repeats = sum(c.repeats for c in clients)
        loads = sum(1 for r in replicas for line in r.lines()
                    if "loaded from the store" in line and "/hgraphs/" in line)
        print(f"{counts['merge']} merges, {counts['add_paths']} additions, {counts['requery']} "
              f"requeries by {WORKERS} workers; {final} H-Graphs checked after the load; "
              f"{loads} H-Graph loads from the store; the workers' clients: {recoveries} "
              f"recoveries, {repeats} calls repeated; {time.monotonic() - started:.1f} s")
    finally:
        stop.set()
        for t in threads:
            t.join(timeout=120)
        for c in clients:
            c.close()
        if nginx is not None:
            nginx.stop()
        for r in replicas:
            if r.proc.poll() is None:
                r.stop()
        redis.stop()
        if failures:
            print_failure_logs(replicas, nginx, 60)
        shutil.rmtree(work, ignore_errors=True)
    print(f"{len(failures)} problems")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
