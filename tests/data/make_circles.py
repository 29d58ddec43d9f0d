#!/usr/bin/env python3
"""Writes the OMPL 2D circles problem as an hgraph scene and paths file.

Source: ompl-2d/circle_obstacles.txt and circle_paths_to_simplify.txt from OMPL's test data
(BSD licence, see the LICENSE next to them). Each disc becomes a vertical cylinder; the robot
is a point (sphere of radius 0) driven by an R^2 component with bounds [0, 80]^2, as in
tests/unit/test_scenes.h. Usage: make_circles.py OMPL_2D_DIR OUT_DIR
"""
import json
import pathlib
import sys


def main():
    src, out = pathlib.Path(sys.argv[1]), pathlib.Path(sys.argv[2])
    out.mkdir(parents=True, exist_ok=True)
    obstacles = []
    for line in (src / "circle_obstacles.txt").read_text().splitlines()[2:]:
        fields = line.split()
        if len(fields) != 4:
            continue
        number, x, y, r = fields
        obstacles.append({
            "name": "disc" + number,
            "shape": {"cylinder": {"radius": float(r), "length": 2.0}},
            "pose": {"position": [float(x), float(y), 0.0]},
        })
    scene = {
        "name": "ompl-circles",
        "description": "OMPL's 2D circles problem: a point robot among discs.",
        "space": {"components": [{"type": "TYPE_RN", "dimension": 2,
                                  "lower": [0, 0], "upper": [80, 80], "name": "xy"}]},
        "obstacles": obstacles,
        "robot": [{"name": "point", "shape": {"sphere": {"radius": 0}}, "component": 0}],
        # A step of 0.1% of the extent (about 0.11) keeps the smallest discs (r = 1.4) from
        # slipping between two samples.
        "resolution": 0.001,
    }
    # One obstacle per line keeps the file short and diffable.
    text = json.dumps(dict(scene, obstacles=["@"]), indent=1)
    rows = ",\n  ".join(json.dumps(o) for o in obstacles)
    (out / "scene.json").write_text(text.replace('"@"', rows) + "\n")

    # The paths file is already OMPL's matrix format once its two header lines are dropped.
    lines = (src / "circle_paths_to_simplify.txt").read_text().splitlines()[2:]
    header = ["# OMPL circle_paths_to_simplify.txt: two paths, x y per line", ""]
    (out / "paths.txt").write_text("\n".join(header + lines).rstrip("\n") + "\n")


if __name__ == "__main__":
    main()
