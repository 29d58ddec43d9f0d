#!/usr/bin/python3
"""Writes the built-in scenes: scenes/<name>/scene.json (proto3 JSON hgraph.v1.Scene, snake_case)
and the OBJ meshes beside them.

Standard library only. Run from anywhere:  /usr/bin/python3 scenes/generate.py
The output is committed; rerunning must reproduce it byte for byte (the maze uses a seeded
generator, everything else is fixed geometry).

2D scenes: obstacles are boxes or cylinders 1 unit thick in Z centred on z = 0, and the robot
(0.2 thick) moves in the plane z = 0, so every collision is a planar one.
"""

import json
import math
import os
import random
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
# The shared test data sits beside the repository (../shared), as in CI.
SHARED_DATA = os.path.join(HERE, "..", "..", "shared", "data", "ompl-2d")

OBSTACLE_THICKNESS_2D = 1.0
ROBOT_THICKNESS_2D = 0.2


def num(x):
    """Rounds away binary noise so the JSON is stable and readable."""
    r = round(x, 9)
    return 0.0 if r == 0 else r


def box(name, center, size):
    return {
        "name": name,
        "shape": {"box": {"size": [num(s) for s in size]}},
        "pose": {"position": [num(c) for c in center]},
    }


def cylinder(name, center, radius, length):
    return {
        "name": name,
        "shape": {"cylinder": {"radius": num(radius), "length": num(length)}},
        "pose": {"position": [num(c) for c in center]},
    }


def component(ctype, lower, upper, name, translation_weight=None, rotation_weight=None, dim=None):
    c = {"type": ctype, "lower": [num(v) for v in lower], "upper": [num(v) for v in upper],
         "name": name}
    if dim is not None:
        c["dimension"] = dim
    if translation_weight is not None:
        c["translation_weight"] = translation_weight
    if rotation_weight is not None:
        c["rotation_weight"] = rotation_weight
    return c


def config(values):
    return {"values": [num(v) for v in values]}


def write_scene(name, scene, files=None):
    folder = os.path.join(HERE, name)
    os.makedirs(folder, exist_ok=True)
    for file_name, text in (files or {}).items():
        with open(os.path.join(folder, file_name), "w", newline="\n") as f:
            f.write(text)
    with open(os.path.join(folder, "scene.json"), "w", newline="\n") as f:
        json.dump(scene, f, indent=2)
        f.write("\n")
    print("wrote %s/scene.json (%d obstacles)" % (name, len(scene["obstacles"])))


# ----------------------------------------------------------------------------------------------
# maze: R^2, a small square in a perfect maze.
#
# A perfect maze (a spanning tree of the cell grid, drawn by a seeded depth-first search) has
# exactly one corridor from start to goal, and every other branch ends in a dead end: the 2D
# maze of the paper (Geraerts et al.), "a corridor flanked by branching paths that all lead to
# dead-ends". Corridors are much wider than the robot, so the clearance of PRM paths fluctuates
# (the point of the paper's Figure 2).

MAZE_CELLS = 6
MAZE_CELL = 3.0
MAZE_WALL = 0.3
MAZE_ROBOT = 0.6
MAZE_SEED = 7


def maze_tree(n, seed):
    """Returns the set of open walls {((i, j), (i2, j2))} of a depth-first spanning tree."""
    rng = random.Random(seed)
    visited = {(0, 0)}
    stack = [(0, 0)]
    open_walls = set()
    while stack:
        i, j = stack[-1]
        nbrs = [(i + di, j + dj) for di, dj in ((1, 0), (-1, 0), (0, 1), (0, -1))
                if 0 <= i + di < n and 0 <= j + dj < n and (i + di, j + dj) not in visited]
        if not nbrs:
            stack.pop()
            continue
        nxt = rng.choice(nbrs)
        open_walls.add(frozenset(((i, j), nxt)))
        visited.add(nxt)
        stack.append(nxt)
    return open_walls


def tree_path(n, open_walls, a, b):
    prev = {a: None}
    queue = [a]
    while queue:
        c = queue.pop(0)
        for d in ((1, 0), (-1, 0), (0, 1), (0, -1)):
            nb = (c[0] + d[0], c[1] + d[1])
            if nb not in prev and frozenset((c, nb)) in open_walls:
                prev[nb] = c
                queue.append(nb)
    path = [b]
    while prev[path[-1]] is not None:
        path.append(prev[path[-1]])
    return path[::-1]


def merged_segments(segments):
    """Joins collinear touching unit wall segments: fewer, longer boxes."""
    out = []
    for axis in ("h", "v"):
        lines = {}
        for s in segments:
            if s[0] == axis:
                lines.setdefault(s[1], []).append(s[2])
        for fixed in sorted(lines):
            starts = sorted(lines[fixed])
            run_start = prev = starts[0]
            for k in starts[1:] + [None]:
                if k is not None and k == prev + 1:
                    prev = k
                    continue
                out.append((axis, fixed, run_start, prev + 1))
                if k is not None:
                    run_start = prev = k
    return out


def maze():
    n, cell, wall = MAZE_CELLS, MAZE_CELL, MAZE_WALL
    open_walls = maze_tree(n, MAZE_SEED)
    segments = []  # ("h", row line y index, cell x index) / ("v", column line x index, cell y)
    for i in range(n):
        for j in range(n + 1):
            # Horizontal wall at y = j between cells (i, j-1) and (i, j).
            if j in (0, n) or frozenset(((i, j - 1), (i, j))) not in open_walls:
                segments.append(("h", j, i))
    for j in range(n):
        for i in range(n + 1):
            if i in (0, n) or frozenset(((i - 1, j), (i, j))) not in open_walls:
                segments.append(("v", i, j))
    obstacles = []
    for k, (axis, fixed, a, b) in enumerate(merged_segments(segments)):
        length = (b - a) * cell + wall
        mid = (a + b) / 2 * cell
        if axis == "h":
            obstacles.append(box("wall%d" % k, (mid, fixed * cell, 0),
                                 (length, wall, OBSTACLE_THICKNESS_2D)))
        else:
            obstacles.append(box("wall%d" % k, (fixed * cell, mid, 0),
                                 (wall, length, OBSTACLE_THICKNESS_2D)))
    size = n * cell
    start_cell, goal_cell = (0, 0), (n - 1, n - 1)
    corridor = tree_path(n, open_walls, start_cell, goal_cell)
    dead_ends = sum(1 for i in range(n) for j in range(n)
                    if (i, j) not in (start_cell, goal_cell) and
                    sum(1 for w in open_walls if (i, j) in w) == 1)
    centre = lambda c: ((c[0] + 0.5) * cell, (c[1] + 0.5) * cell)
    scene = {
        "name": "maze",
        "description": ("A %gx%g square translating (R^2) through a %dx%d perfect maze: one "
                        "corridor of %d cells from start to goal, flanked by branches that all "
                        "end in dead ends (%d of them); corridors %g wide." %
                        (MAZE_ROBOT, MAZE_ROBOT, n, n, len(corridor), dead_ends, cell - wall)),
        "space": {"components": [component("TYPE_RN", (0, 0), (size, size), "square", dim=2)]},
        "obstacles": obstacles,
        "robot": [{"name": "square", "component": 0,
                   "shape": {"box": {"size": [MAZE_ROBOT, MAZE_ROBOT, ROBOT_THICKNESS_2D]}}}],
        "self_collision": False,
        "start": config(centre(start_cell)),
        "goal": config(centre(goal_cell)),
        "resolution": 0.002,
    }
    write_scene("maze", scene)


# ----------------------------------------------------------------------------------------------
# grid: SE(2), an elongated rectangle from the top to the bottom of a grid of rectangles.
#
# Each row of obstacles leaves four passages narrower than the rectangle is long, so the
# rectangle must turn upright to squeeze through; every second row is shifted sideways so that
# passages do not line up (paper, "Elongated Rectangle in a 2D Grid"; after Nieuwenhuisen and
# Overmars). The free bands between rows are just tall enough for the rectangle to turn.
#
# Rotation weight: 0.1 per radian against 1 per unit of translation in a 10 x 10 world. A half
# turn then costs 0.31, a third of the rectangle's length: the random turning of PRM paths shows
# in their length, but a merged path's length is dominated by its translation, as in the paper
# (whose tiny OOPSMP weight has the same purpose).

GRID_WIDTH = 10.0
GRID_HEIGHT = 10.0
GRID_ROWS = 6
GRID_ROW_HEIGHT = 0.5       # thickness of a row of rectangles (along y)
GRID_PASSAGE = 0.30         # width of a passage (along x)
GRID_SHIFT = 0.3            # sideways shift of every second row
GRID_ROBOT = (0.8, 0.12)    # length, width
GRID_ROTATION_WEIGHT = 0.1


def grid():
    rows = GRID_ROWS
    pitch = GRID_HEIGHT / (rows + 1)
    obstacles = []
    for r in range(rows):
        y = GRID_HEIGHT - pitch * (r + 1)
        shift = GRID_SHIFT if r % 2 else 0.0
        # Four evenly spaced passages (+ shift): five rectangles from wall to wall.
        centres = [GRID_WIDTH * (k + 1) / 5 + shift for k in range(4)]
        edges = [0.0]
        for c in centres:
            edges += [c - GRID_PASSAGE / 2, c + GRID_PASSAGE / 2]
        edges.append(GRID_WIDTH)
        for k in range(5):
            x0, x1 = edges[2 * k], edges[2 * k + 1]
            obstacles.append(box("row%d_block%d" % (r, k), ((x0 + x1) / 2, y, 0),
                                 (x1 - x0, GRID_ROW_HEIGHT, OBSTACLE_THICKNESS_2D)))
    length, width = GRID_ROBOT
    scene = {
        "name": "grid",
        "description": ("A %gx%g rectangle translating and rotating (SE(2)) from the top to the "
                        "bottom of a %gx%g workspace through %d rows of rectangles; each row has "
                        "four %g-wide passages and every second row is shifted by %g, so the "
                        "passages do not line up. Weights: translation 1, rotation %g." %
                        (length, width, GRID_WIDTH, GRID_HEIGHT, rows, GRID_PASSAGE, GRID_SHIFT,
                         GRID_ROTATION_WEIGHT)),
        "space": {"components": [component("TYPE_SE2", (0, 0), (GRID_WIDTH, GRID_HEIGHT), "rod",
                                           translation_weight=1.0,
                                           rotation_weight=GRID_ROTATION_WEIGHT)]},
        "obstacles": obstacles,
        "robot": [{"name": "rod", "component": 0,
                   "shape": {"box": {"size": [length, width, ROBOT_THICKNESS_2D]}}}],
        "self_collision": False,
        # Lying flat at the top, lying flat at the bottom: it has to turn upright in between.
        "start": config((GRID_WIDTH / 2, GRID_HEIGHT - pitch / 2, 0.0)),
        "goal": config((GRID_WIDTH / 2, pitch / 2, 0.0)),
        "resolution": 0.002,
    }
    write_scene("grid", scene)


# ----------------------------------------------------------------------------------------------
# wrench, double_wrench: SE(3), free-flying wrenches through a frame of 13 axis-aligned beams.
#
# The frame (after Geraerts and Overmars' wrench scene) is a wall in the plane x = 0: four posts
# along z and four bars along y make a 3 x 3 lattice of square windows, and five beams along x
# stick out of it (four at the outer corners, one through the middle window, closing it). The
# wrench starts lying across the x direction on one side and ends on the other side: it fits
# through a window only nearly aligned with x, handle first, so it has to turn while it
# approaches the wall and turn back after it (synchronised rotation and translation).

def box_mesh(center, size):
    """Vertices and outward-facing triangles (1-based faces added by the caller) of a box."""
    cx, cy, cz = center
    hx, hy, hz = (s / 2 for s in size)
    v = [(cx + sx * hx, cy + sy * hy, cz + sz * hz)
         for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]
    # Index = 4 * (sx > 0) + 2 * (sy > 0) + (sz > 0).
    quads = [(0, 1, 3, 2), (4, 6, 7, 5),  # -x, +x
             (0, 4, 5, 1), (2, 3, 7, 6),  # -y, +y
             (0, 2, 6, 4), (1, 5, 7, 3)]  # -z, +z
    tris = []
    for a, b, c, d in quads:
        tris += [(a, b, c), (a, c, d)]
    return v, tris


def cylinder_mesh(center, radius, length, segments=16):
    """A closed cylinder with its axis along z."""
    cx, cy, cz = center
    v = []
    for z in (cz - length / 2, cz + length / 2):
        for k in range(segments):
            a = 2 * math.pi * k / segments
            v.append((cx + radius * math.cos(a), cy + radius * math.sin(a), z))
    v += [(cx, cy, cz - length / 2), (cx, cy, cz + length / 2)]
    bottom_centre, top_centre = 2 * segments, 2 * segments + 1
    tris = []
    for k in range(segments):
        k2 = (k + 1) % segments
        tris += [(k, k2, segments + k2), (k, segments + k2, segments + k)]
        tris += [(bottom_centre, k2, k), (top_centre, segments + k, segments + k2)]
    return v, tris


def wrench_obj(scale):
    """An open-end wrench along x, centred on its handle, built from boxes and cylinders."""
    parts = []
    s = scale
    parts.append(box_mesh((0, 0, 0), (3.0 * s, 0.4 * s, 0.2 * s)))  # handle
    for side in (-1, 1):
        x = side * 1.7 * s
        parts.append(cylinder_mesh((x, 0, 0), 0.55 * s, 0.24 * s))   # round head
        # Two jaws reaching out past the head: the opening between them is 0.4 wide.
        for jaw in (-1, 1):
            parts.append(box_mesh((side * 2.3 * s, jaw * 0.4 * s, 0), (0.8 * s, 0.4 * s, 0.24 * s)))
    lines = ["# Open-end wrench for hgraph's built-in scenes, written by scenes/generate.py.",
             "# Handle along x; %d closed parts (boxes and 16-sided cylinders)." % len(parts)]
    faces = []
    offset = 0
    for verts, tris in parts:
        for x, y, z in verts:
            lines.append("v %.6f %.6f %.6f" % (num(x), num(y), num(z)))
        faces += ["f %d %d %d" % (a + 1 + offset, b + 1 + offset, c + 1 + offset)
                  for a, b, c in tris]
        offset += len(verts)
    return "\n".join(lines + faces) + "\n"


FRAME_WINDOW_PITCH = 3.0   # distance between neighbouring posts (and bars)
FRAME_BEAM = 0.5           # beam cross-section side
FRAME_DEPTH = 6.0          # length of the beams along x


def frame(pitch):
    """The 13 beams: 4 posts (z), 4 bars (y), 5 beams along x."""
    half_span = 1.5 * pitch          # posts at +-0.5 pitch and +-1.5 pitch
    extent = 2 * half_span + FRAME_BEAM
    beams = []
    for k, p in enumerate((-1.5, -0.5, 0.5, 1.5)):
        beams.append(box("post%d" % k, (0, p * pitch, 0), (FRAME_BEAM, FRAME_BEAM, extent)))
        beams.append(box("bar%d" % k, (0, 0, p * pitch), (FRAME_BEAM, extent, FRAME_BEAM)))
    for k, (y, z) in enumerate(((-half_span, -half_span), (-half_span, half_span),
                                (half_span, -half_span), (half_span, half_span), (0, 0))):
        beams.append(box("rail%d" % k, (0, y, z), (FRAME_DEPTH, FRAME_BEAM, FRAME_BEAM)))
    assert len(beams) == 13
    return beams


def quat_about(axis, angle):
    s = math.sin(angle / 2)
    return [axis[0] * s, axis[1] * s, axis[2] * s, math.cos(angle / 2)]


def se3(position, quaternion):
    return list(position) + list(quaternion)


def wrench_component(name, bounds):
    lower, upper = bounds
    # OMPL's SE(3) weights (1 and 1): lengths compare directly with what OMPL users see.
    return component("TYPE_SE3", lower, upper, name)


# The wrench's reference point may not leave the lattice's outline in y and z (the outer posts
# and bars are at +-4.5), so it cannot fly around the frame: it must pass through a window.
WRENCH_BOUNDS = ((-8.0, -4.5, -4.5), (8.0, 4.5, 4.5))


def wrench():
    lying_across = quat_about((0, 0, 1), math.pi / 2)  # handle along y
    scene = {
        "name": "wrench",
        "description": ("A free-flying open-end wrench (SE(3), 5 long) passing through a frame "
                        "of 13 axis-aligned beams: a 3x3 lattice of %g-wide windows with the "
                        "middle one closed by a beam along x. It starts across the direction of "
                        "travel and fits through a window only handle first, so it must turn "
                        "while it translates." % (FRAME_WINDOW_PITCH - FRAME_BEAM)),
        "space": {"components": [wrench_component("wrench", WRENCH_BOUNDS)]},
        "obstacles": frame(FRAME_WINDOW_PITCH),
        "robot": [{"name": "wrench", "component": 0,
                   "shape": {"mesh": {"path": "wrench.obj"}}}],
        "self_collision": False,
        "start": config(se3((-6.0, 0.0, 0.0), lying_across)),
        "goal": config(se3((6.0, 0.0, 0.0), lying_across)),
        "resolution": 0.004,
    }
    write_scene("wrench", scene, {"wrench.obj": wrench_obj(1.0)})


DOUBLE_WRENCH_SCALE = 0.8


def double_wrench():
    lying_across = quat_about((0, 0, 1), math.pi / 2)
    scene = {
        "name": "double_wrench",
        "description": ("Two free-flying wrenches (SE(3) x SE(3), 12 DOF, %g the size of the "
                        "single wrench) that swap sides of the 13-beam frame at once; they "
                        "collide with the beams and with each other." % DOUBLE_WRENCH_SCALE),
        "space": {"components": [wrench_component("wrench1", WRENCH_BOUNDS),
                                 wrench_component("wrench2", WRENCH_BOUNDS)]},
        "obstacles": frame(FRAME_WINDOW_PITCH),
        "robot": [{"name": "wrench1", "component": 0,
                   "shape": {"mesh": {"path": "wrench.obj"}}},
                  {"name": "wrench2", "component": 1,
                   "shape": {"mesh": {"path": "wrench.obj"}}}],
        "self_collision": True,
        "start": config(se3((-5.5, -3.0, 0.0), lying_across) + se3((-5.5, 3.0, 0.0), lying_across)),
        "goal": config(se3((5.5, -3.0, 0.0), lying_across) + se3((5.5, 3.0, 0.0), lying_across)),
        "resolution": 0.004,
    }
    write_scene("double_wrench", scene, {"wrench.obj": wrench_obj(DOUBLE_WRENCH_SCALE)})


# ----------------------------------------------------------------------------------------------
# circles: a point robot (R^2) among OMPL's disc obstacles, start (30, 62), goal (67, 35): the
# query of shared/data/ompl-2d/circle_paths_to_simplify.txt.

def circles():
    source = os.path.join(SHARED_DATA, "circle_obstacles.txt")
    with open(source) as f:
        lines = f.read().splitlines()
    obstacles = []
    for line in lines[2:]:
        if not line.strip():
            continue
        ident, x, y, r = line.split()
        obstacles.append(cylinder("disc%s" % ident, (float(x), float(y), 0), float(r),
                                  OBSTACLE_THICKNESS_2D))
    with open(os.path.join(SHARED_DATA, "LICENSE")) as f:
        license_text = f.read()
    note = ("The disc obstacles of circles/scene.json are those of OMPL's test resource\n"
            "circle_obstacles.txt (shared/data/ompl-2d/), released under the license below.\n\n")
    scene = {
        "name": "circles",
        "description": ("A point robot (R^2) among %d discs (OMPL's circle_obstacles test data), "
                        "from (30, 62) to (67, 35)." % len(obstacles)),
        "space": {"components": [component("TYPE_RN", (0, -5), (70, 65), "point", dim=2)]},
        "obstacles": obstacles,
        "robot": [{"name": "point", "component": 0, "shape": {"sphere": {"radius": 0}}}],
        "self_collision": False,
        "start": config((30, 62)),
        "goal": config((67, 35)),
        "resolution": 0.002,
    }
    write_scene("circles", scene, {"LICENSE": note + license_text})


SCENES = {"maze": maze, "grid": grid, "wrench": wrench, "double_wrench": double_wrench,
          "circles": circles}

if __name__ == "__main__":
    names = sys.argv[1:] or sorted(SCENES)
    for scene_name in names:
        if scene_name not in SCENES:
            sys.exit("generate.py: unknown scene '%s' (known: %s)" %
                     (scene_name, ", ".join(sorted(SCENES))))
        SCENES[scene_name]()
