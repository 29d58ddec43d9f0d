#!/usr/bin/env python3
"""Merges the two input paths of OMPL's circles problem on a running hgraph server, then
re-queries the same H-Graph for clearance without new collision checks.

    /usr/bin/python3 -m pip install --no-deps --no-build-isolation --target DIR ./client/python
    # then PYTHONPATH=DIR (or PYTHONPATH=client/python:build/python from a build)
    /usr/bin/python3 client/python/examples/merge_circles.py --server localhost:50051
"""
import argparse
import pathlib
import sys

import hgraph_client
from hgraph.v1 import merge_pb2

ROOT = pathlib.Path(__file__).resolve().parents[3]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--server", default="localhost:50051")
    parser.add_argument("--scene", default=str(ROOT / "tests/data/circles/scene.json"))
    parser.add_argument("--paths", default=str(ROOT / "tests/data/circles/paths.txt"))
    args = parser.parse_args()

    with hgraph_client.connect(args.server) as client:
        digest = client.upload_scene(args.scene)
        session = client.create_session(digest)
        print(f"session {session.name} on scene {digest.sha256[:12]}")
        paths = hgraph_client.load_paths_text(pathlib.Path(args.paths).read_text())

        def show(p: hgraph_client.Progress) -> None:
            print(f"  {p.phase:10s} {p.done}/{p.total}  checks={p.collision_checks}")

        merged = client.merge(paths, measure="length", variant="all-pairs", on_progress=show)
        r = merged.result
        # `best` is unset when no input is known valid (a lazy merge checks only what its search
        # needs: the others say VALIDITY_UNKNOWN); never index inputs with best_input's -1.
        best = (f"best input {r.inputs[r.best.index].name} {r.best.objective:.3f}"
                if r.HasField("best") else "no input known valid")
        unknown = sum(i.validity == merge_pb2.VALIDITY_UNKNOWN for i in r.inputs)
        print(f"merged: length {r.quality.length:.3f} ({best}; {unknown} inputs unchecked, "
              f"{merge_pb2.Evaluation.Name(r.evaluation)}), "
              f"{r.stats.collision_checks} collision checks, H-Graph {merged.hgraph}")
        again = client.requery(merged.hgraph, measure="bottleneck-clearance")
        # A clearance measure always profiles the path: min_clearance is present.
        print(f"requery bottleneck-clearance: min clearance {again.quality.min_clearance:.3f}, "
              f"{again.stats.collision_checks} new collision checks, "
              f"{again.stats.edges_reused} edges reused")
        client.delete_session()
    return 0


if __name__ == "__main__":
    sys.exit(main())
