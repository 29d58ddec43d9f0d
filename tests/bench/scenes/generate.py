#!/usr/bin/python3
"""Writes the benchmark's SE(3) mesh problems: tests/bench/scenes/<name>/scene.json and their OBJ
meshes. Standard library only; rerunning reproduces the files byte for byte.

  hole_wall  a rod (3 x 0.4 x 0.4 box mesh) starts across the direction of travel and must turn
             end first through a 1.6 x 1.6 square hole in a wall (one mesh, 0.3 thick).
  two_slots  a rod (1.6 x 0.3 x 0.3) passes two walls 3 apart whose 1.3 x 1.3 holes are offset by
             3 in y, so it threads one hole, turns between the walls and threads the other.
"""

import json
import os

HERE = os.path.dirname(os.path.abspath(__file__))


def box_faces(lo, hi, base):
    """Vertices and triangles (1-based, outward) of an axis-aligned box."""
    v = []
    for i in range(8):
        v.append((hi[0] if i & 1 else lo[0], hi[1] if i & 2 else lo[1], hi[2] if i & 4 else lo[2]))
    faces = [(0, 2, 1), (1, 2, 3), (4, 5, 6), (5, 7, 6), (0, 1, 4), (1, 5, 4),
             (2, 6, 3), (3, 6, 7), (0, 4, 2), (2, 4, 6), (1, 3, 5), (3, 7, 5)]
    return v, [(a + base + 1, b + base + 1, c + base + 1) for a, b, c in faces]


def write_obj(path, title, boxes):
    lines = ["# " + title + ", written by tests/bench/scenes/generate.py."]
    verts, tris = [], []
    for lo, hi in boxes:
        v, t = box_faces(lo, hi, len(verts))
        verts += v
        tris += t
    lines += ["v %g %g %g" % p for p in verts]
    lines += ["f %d %d %d" % t for t in tris]
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")


def wall_with_hole(x, thickness, half_extent, hole_center, hole_size):
    """Four boxes around a square hole, in the plane x = const."""
    t = thickness / 2
    cy, cz = hole_center
    h = hole_size / 2
    e = half_extent
    return [
        ((x - t, -e, -e), (x + t, cy - h, e)),       # left of the hole
        ((x - t, cy + h, -e), (x + t, e, e)),        # right
        ((x - t, cy - h, -e), (x + t, cy + h, cz - h)),  # below
        ((x - t, cy - h, cz + h), (x + t, cy + h, e)),   # above
    ]


def scene(name, description, lower, upper, start, goal, resolution):
    return {
        "name": name,
        "description": description,
        "space": {"components": [{"type": "TYPE_SE3", "lower": lower, "upper": upper,
                                  "name": "rod"}]},
        "obstacles": [{"name": "walls", "shape": {"mesh": {"path": "walls.obj"}}}],
        "robot": [{"name": "rod", "component": 0, "shape": {"mesh": {"path": "rod.obj"}}}],
        "start": {"values": start},
        "goal": {"values": goal},
        "resolution": resolution,
    }


# Quaternion (x y z w) of a quarter turn about z: the rod (along x) lies along y.
ACROSS = [0.0, 0.0, 0.707106781, 0.707106781]


def write(name, data, walls, rod_size, description):
    d = os.path.join(HERE, name)
    os.makedirs(d, exist_ok=True)
    write_obj(os.path.join(d, "walls.obj"), name + " walls", walls)
    hx, hy, hz = (s / 2 for s in rod_size)
    write_obj(os.path.join(d, "rod.obj"), name + " rod", [((-hx, -hy, -hz), (hx, hy, hz))])
    with open(os.path.join(d, "scene.json"), "w") as f:
        json.dump(data, f, indent=2)
        f.write("\n")


def main():
    desc = ("A rod (2.5 x 0.4 x 0.4) starts across the direction of travel and must turn end first "
            "through a 1.6 x 1.6 square hole in a 0.3 thick wall mesh.")
    write("hole_wall",
          scene("hole_wall", desc, [-5.0, -3.0, -3.0], [5.0, 3.0, 3.0],
                [-3.5, 0.0, 0.0] + ACROSS, [3.5, 0.0, 0.0] + ACROSS, 0.005),
          wall_with_hole(0.0, 0.3, 3.5, (0.0, 0.0), 1.6), (2.5, 0.4, 0.4), desc)
    desc = ("A rod (1.6 x 0.3 x 0.3) threads two 0.3 thick walls 3 apart whose 1.3 x 1.3 holes are "
            "offset by 3 in y: through one hole, a turn between the walls, through the other.")
    write("two_slots",
          scene("two_slots", desc, [-5.0, -3.0, -3.0], [5.0, 3.0, 3.0],
                [-3.5, 1.5, 0.0] + ACROSS, [3.5, -1.5, 0.0] + ACROSS, 0.005),
          wall_with_hole(-1.5, 0.3, 3.5, (1.5, 0.0), 1.3)
          + wall_with_hole(1.5, 0.3, 3.5, (-1.5, 0.0), 1.3), (1.6, 0.3, 0.3), desc)


if __name__ == "__main__":
    main()
