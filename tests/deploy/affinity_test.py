#!/usr/bin/env python3
"""Session affinity through nginx, and surviving the loss of a replica.

Starts three hgraph-server processes and Debian's nginx on loopback ports chosen now, with
deploy/base/nginx/hgraph.conf as the front (its listen port and upstream list templated for
loopback), then:
  1. runs several sessions through nginx with the Python client (and one with the CLI) and
     checks from the replicas' logs that every call of a session reached one replica, and that
     the sessions spread over more than one replica;
  2. stops the replica that holds the first session: a client without retries gets NOT_FOUND
     or UNAVAILABLE; clients with retries re-upload the scene by digest, re-create their session
     on another replica, retry, and their merges succeed; the sessions on the other replicas
     are untouched.
Usage: affinity_test.py --server-bin B --cli B --deploy DIR --data DIR. Exits 77 without nginx.
"""
import argparse
import pathlib
import random
import re
import shutil
import subprocess
import sys
import tempfile

import grpc

import hgraph_client

from cluster import SKIP, Nginx, Replica, missing_tools, print_failure_logs


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--server-bin", required=True)
    parser.add_argument("--cli", required=True)
    parser.add_argument("--deploy", required=True, type=pathlib.Path)
    parser.add_argument("--data", required=True, type=pathlib.Path)
    args = parser.parse_args()
    missing = missing_tools(need_redis=False)
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

    replicas = [Replica(args.server_bin, i) for i in range(3)]
    work = pathlib.Path(tempfile.mkdtemp(prefix="hgraph-affinity-"))
    nginx = None
    clients = []
    try:
        nginx = Nginx(args.deploy, work, replicas)
        front = nginx.front
        print(f"nginx on {front}; replicas on ports {[r.port for r in replicas]}")

        # 1. Sessions through nginx, named from a seeded generator (the test is repeatable).
        rng = random.Random(7)

        def open_session():
            c = hgraph_client.connect(front, backoff_s=0.1)
            c.session_name = "sessions/%032x" % rng.getrandbits(128)
            c.create_session(c.upload_scene(scene))
            return c

        for i in range(8):
            c = open_session()
            outcome = c.merge(paths, measure="length", variant="edit-distance")
            expect(outcome.result.path.waypoints, f"session {i}: empty merge")
            c.check(paths)
            clients.append(c)
        cli = subprocess.run([args.cli, "check", "--server", front, "--scene", str(scene),
                              "--paths", str(args.data / "circles" / "paths.txt")],
                             capture_output=True, text=True)
        expect(cli.returncode == 0, f"CLI check through nginx: {cli.returncode} {cli.stderr}")
        cli_session = re.search(r"session (sessions/[0-9a-f]{32})", cli.stderr)
        expect(cli_session is not None, f"CLI printed no session: {cli.stderr}")
        names = [c.session for c in clients] + ([cli_session.group(1)] if cli_session else [])
        # The ring hashes the replicas' loopback ports, chosen now: nine sessions all land on one
        # replica in about one run of 2000. Twenty-four more sessions (created, then deleted)
        # make the spread check below fail only without hashing.
        for _ in range(24):
            c = open_session()
            names.append(c.session)
            c.delete_session()
            c.close()

        home = {}
        for name in names:
            holders = [r.index for r in replicas if r.calls(name)]
            expect(len(holders) == 1, f"{name}: calls reached replicas {holders}, not one")
            if holders:
                home[name] = holders[0]
                # CreateSession, MergePaths and CheckPaths (CLI: CreateSession, CheckPaths;
                # the others: CreateSession, DeleteSession).
                expect(len(replicas[holders[0]].calls(name)) >= 2, f"{name}: too few calls")
        used = set(home.values())
        print("sessions per replica:", {r.index: sum(1 for h in home.values() if h == r.index)
                                        for r in replicas})
        expect(len(used) >= 2, f"every session went to replicas {used}: no hashing")

        # 2. Lose the replica of the first session (hgraph health, the image's HEALTHCHECK,
        # tells a live replica from a stopped one).
        lost = home[clients[0].session]
        target = f"127.0.0.1:{replicas[lost].port}"
        health = subprocess.run([args.cli, "health", "--server", target], capture_output=True,
                                text=True)
        expect(health.returncode == 0 and "SERVING" in health.stdout,
               f"hgraph health on a live replica: {health.returncode} {health.stdout}")
        replicas[lost].stop()
        print(f"stopped replica {lost}")
        health = subprocess.run([args.cli, "health", "--server", target, "--timeout", "2"],
                                capture_output=True, text=True)
        expect(health.returncode == 1, f"hgraph health on a stopped replica: {health.returncode}")
        lost_clients = [c for c in clients if home[c.session] == lost]
        kept_clients = [c for c in clients if home[c.session] != lost]

        bare = hgraph_client.Client(front, retries=0)
        bare.session = lost_clients[0].session
        try:
            bare.check(paths)
            expect(False, "a call on the lost session succeeded without recovery")
        except hgraph_client.HgraphError as e:
            expect(e.code in (grpc.StatusCode.NOT_FOUND, grpc.StatusCode.UNAVAILABLE),
                   f"lost session: {e.code.name}, expected NOT_FOUND or UNAVAILABLE")
            print(f"without retries: {e.code.name}: {e.message[:100]}")
        bare.close()

        for c in clients:
            before = c.recoveries
            outcome = c.merge(paths, measure="length", variant="edit-distance")
            expect(len(outcome.result.path.waypoints) >= 2, f"{c.session}: merge after loss")
            if c in lost_clients:
                expect(c.recoveries == before + 1, f"{c.session}: not re-created once")
                now = [r.index for r in replicas if r.index != lost and r.calls(c.session)]
                expect(len(now) == 1, f"{c.session}: re-created on replicas {now}, not one")
            else:
                expect(c.recoveries == before, f"{c.session}: recovered although its replica lives")
                expect([r.index for r in replicas if r.calls(c.session)] == [home[c.session]],
                       f"{c.session}: moved although its replica lives")
        print(f"{len(lost_clients)} sessions re-created after the loss, {len(kept_clients)} kept")
    finally:
        for c in clients:
            c.close()
        if nginx is not None:
            nginx.stop()
        for r in replicas:
            r.stop()
        if failures:
            print_failure_logs(replicas, nginx)
        shutil.rmtree(work, ignore_errors=True)
    print(f"{len(failures)} problems")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
