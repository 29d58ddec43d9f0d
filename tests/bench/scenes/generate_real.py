#!/usr/bin/python3
"""Writes the benchmark's mesh problems of realistic size (issues 26 and 31):
tests/bench/scenes/<name>/scene.json, world.obj and robot.obj. Standard library only, no
randomness but a fixed-seed generator of our own; rerunning reproduces the files byte for byte.
Prints the triangle counts.

  home     SE(3): a table (172 triangles) carried from the living room to the bedroom of a
           four-room flat with furniture (1456 triangles: walls with 1 and 1.2 m doorways, sofa,
           shelves, kitchen, dining set, bed, wardrobe); no floor, the table's height is bounded
           by the space.
  office   SE(3): an office chair (260 triangles) from one cubicle to another around two blocks
           of six cubicles (1064 triangles: 1.6 m partitions, 0.9 m openings, a desk in each).
  twisty   SE(3): a rounded plate (1.2 x 0.7 x 0.16, 108 triangles) threads three plates whose
           stadium-shaped slots (0.7 wide) are turned by 0, 90 and 0 degrees, inside a closed
           tube (756 triangles): it rolls a quarter turn and back on the way.
  car_maze SE(2): a car (body, cabin, four wheels; 256 triangles) through a 7 x 7 perfect maze
           (768 triangles, corridors 1.6 wide) from one corner to the opposite one.
  flat     SE(3): a sofa (184 triangles) from the living room into the study next door of a
           furnished flat (1540 triangles): the door between them is 1.05 m wide for a sofa
           0.8 deep, the way round through the hall has 1.6 m doorways and is three times as
           long. The home-like problem where PRM's routes are poor (issue 31): its first paths
           take the way round.

The shapes are triangle meshes (boxes, prisms over convex outlines, cylinders, plates with
holes), one world mesh and one robot mesh per problem, about the size of OMPL.app's problems,
where a distance query costs far more than on the bench's box scenes. Run from anywhere:
python3 tests/bench/scenes/generate_real.py
"""

import json
import math
import os

HERE = os.path.dirname(os.path.abspath(__file__))


class Mesh:
    """A triangle soup (vertices and 0-based triangles), written as OBJ."""

    def __init__(self):
        self.vertices, self.triangles = [], []

    def add(self, vertices, triangles, transform=None):
        base = len(self.vertices)
        if transform is not None:
            vertices = [transform(v) for v in vertices]
        self.vertices += vertices
        self.triangles += [(a + base, b + base, c + base) for a, b, c in triangles]

    def box(self, lo, hi, transform=None):
        v = [(hi[0] if i & 1 else lo[0], hi[1] if i & 2 else lo[1], hi[2] if i & 4 else lo[2])
             for i in range(8)]
        t = [(0, 2, 1), (1, 2, 3), (4, 5, 6), (5, 7, 6), (0, 1, 4), (1, 5, 4),
             (2, 6, 3), (3, 6, 7), (0, 4, 2), (2, 4, 6), (1, 3, 5), (3, 7, 5)]
        self.add(v, t, transform)

    def prism(self, outline, z0, z1, transform=None):
        """A prism over a convex outline (counterclockwise in xy) from z0 to z1."""
        n = len(outline)
        v = [(x, y, z0) for x, y in outline] + [(x, y, z1) for x, y in outline]
        t = []
        for i in range(1, n - 1):
            t.append((0, i + 1, i))          # bottom, facing -z
            t.append((n, n + i, n + i + 1))  # top, facing +z
        for i in range(n):
            j = (i + 1) % n
            t += [(i, j, n + j), (i, n + j, n + i)]
        self.add(v, t, transform)

    def cylinder(self, radius, z0, z1, segments, transform=None):
        """Axis along z; move and turn it with `transform`."""
        outline = [(radius * math.cos(2 * math.pi * k / segments),
                    radius * math.sin(2 * math.pi * k / segments)) for k in range(segments)]
        self.prism(outline, z0, z1, transform)

    def plate_with_hole(self, x0, x1, half_size, hole, angle):
        """A square plate (|y|, |z| <= half_size in its own frame) between x = x0 and x1 with a
        convex hole (counterclockwise (y, z) points around the origin), all turned by `angle`
        about x. The face between the square and the hole is cut along rays from the centre,
        one per hole vertex and one per corner of the square."""
        corners = [math.pi / 4 + k * math.pi / 2 for k in range(4)]
        ring = []
        for k, p in enumerate(hole):
            ring.append(p)
            q = hole[(k + 1) % len(hole)]
            a0, a1 = math.atan2(p[1], p[0]), math.atan2(q[1], q[0])
            for c in corners:
                # A corner's ray crossing the hole's edge p-q adds the crossing to the hole.
                if (c - a0) % (2 * math.pi) < (a1 - a0) % (2 * math.pi) and \
                        (c - a0) % (2 * math.pi) > 1e-12:
                    d = (math.cos(c), math.sin(c))
                    ex, ey = q[0] - p[0], q[1] - p[1]
                    # p + s e = r d
                    den = ex * d[1] - ey * d[0]
                    s = (p[1] * d[0] - p[0] * d[1]) / den
                    ring.append((p[0] + s * ex, p[1] + s * ey))
        outer = []
        for y, z in ring:
            m = max(abs(y), abs(z))
            outer.append((y * half_size / m, z * half_size / m))
        n = len(ring)
        ca, sa = math.cos(angle), math.sin(angle)

        def turn(x, y, z):
            return (x, ca * y - sa * z, sa * y + ca * z)

        v = [turn(x0, *p) for p in ring] + [turn(x1, *p) for p in ring] + \
            [turn(x0, *p) for p in outer] + [turn(x1, *p) for p in outer]
        t = []
        for i in range(n):
            j = (i + 1) % n
            t += [(i, 2 * n + i, 2 * n + j), (i, 2 * n + j, j)]                  # face x0
            t += [(n + i, n + j, 3 * n + j), (n + i, 3 * n + j, 3 * n + i)]      # face x1
            t += [(i, j, n + j), (i, n + j, n + i)]                              # hole side
        self.add(v, t)
        # The outer rim: the square's four sides.
        h = half_size
        square = [(h, h), (-h, h), (-h, -h), (h, -h)]
        rim = [turn(x0, *p) for p in square] + [turn(x1, *p) for p in square]
        self.add(rim, [tri for i in range(4) for tri in
                       ((i, (i + 1) % 4, 4 + (i + 1) % 4), (i, 4 + (i + 1) % 4, 4 + i))])

    def write(self, path, title):
        lines = ["# " + title + ", written by tests/bench/scenes/generate_real.py."]
        lines += ["v %s %s %s" % tuple(fmt(c) for c in p) for p in self.vertices]
        lines += ["f %d %d %d" % (a + 1, b + 1, c + 1) for a, b, c in self.triangles]
        with open(path, "w") as f:
            f.write("\n".join(lines) + "\n")


def fmt(x):
    s = "%.6f" % x
    s = s.rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def move(dx, dy, dz, yaw=0.0):
    """Turn by `yaw` about z, then translate."""
    c, s = math.cos(yaw), math.sin(yaw)
    return lambda p: (c * p[0] - s * p[1] + dx, s * p[0] + c * p[1] + dy, p[2] + dz)


def along_y(dx, dy, dz):
    """A z-axis shape (cylinder) turned to lie along y, then translated."""
    return lambda p: (p[0] + dx, -p[2] + dy, p[1] + dz)


def yaw_quaternion(yaw):
    return [0.0, 0.0, round(math.sin(yaw / 2), 9), round(math.cos(yaw / 2), 9)]


def write_scene(name, description, space, start, goal, world, robot, resolution=0.01):
    d = os.path.join(HERE, name)
    os.makedirs(d, exist_ok=True)
    world.write(os.path.join(d, "world.obj"), name + " world")
    robot.write(os.path.join(d, "robot.obj"), name + " robot")
    data = {
        "name": name,
        "description": description,
        "space": {"components": [space]},
        "obstacles": [{"name": "world", "shape": {"mesh": {"path": "world.obj"}}}],
        "robot": [{"name": "robot", "component": 0, "shape": {"mesh": {"path": "robot.obj"}}}],
        "start": {"values": start},
        "goal": {"values": goal},
        "resolution": resolution,
    }
    with open(os.path.join(d, "scene.json"), "w") as f:
        json.dump(data, f, indent=2)
        f.write("\n")
    print("%-9s world %5d triangles, robot %4d triangles" %
          (name, len(world.triangles), len(robot.triangles)))


# ------------------------------------------------------------------------------------------------
# Furniture, built from boxes and cylinders; (x, y) is the footprint's lower corner, yaw turns the
# piece about that corner's frame origin after it is built with its back along y = 0.

def table_robot():
    """A table 1.2 x 0.7 x 0.75 centred on the origin: top, four round legs, four aprons."""
    m = Mesh()
    m.box((-0.6, -0.35, 0.335), (0.6, 0.35, 0.375))
    for sx in (-1, 1):
        for sy in (-1, 1):
            m.cylinder(0.03, -0.375, 0.335, 8, move(sx * 0.53, sy * 0.28, 0))
    m.box((-0.5, -0.30, 0.255), (0.5, -0.28, 0.335))
    m.box((-0.5, 0.28, 0.255), (0.5, 0.30, 0.335))
    m.box((-0.55, -0.25, 0.255), (-0.53, 0.25, 0.335))
    m.box((0.53, -0.25, 0.255), (0.55, 0.25, 0.335))
    return m


def sofa(m, t):
    m.box((0, 0, 0), (2.2, 0.9, 0.42), t)             # base
    m.box((0, 0.7, 0.42), (2.2, 0.9, 0.85), t)        # back
    m.box((0, 0, 0.42), (0.2, 0.7, 0.65), t)          # arms
    m.box((2.0, 0, 0.42), (2.2, 0.7, 0.65), t)
    for k in range(3):                                  # seat cushions
        m.box((0.2 + 0.6 * k, 0.02, 0.42), (0.8 + 0.6 * k, 0.7, 0.52), t)


def armchair(m, t):
    m.box((0, 0, 0), (0.9, 0.85, 0.42), t)
    m.box((0, 0.65, 0.42), (0.9, 0.85, 0.85), t)
    m.box((0, 0, 0.42), (0.15, 0.65, 0.62), t)
    m.box((0.75, 0, 0.42), (0.9, 0.65, 0.62), t)


def low_table(m, x, y, w, d, h, segments=8):
    m.box((x, y, h - 0.04), (x + w, y + d, h))
    for px in (x + 0.06, x + w - 0.06):
        for py in (y + 0.06, y + d - 0.06):
            m.cylinder(0.025, 0, h - 0.04, segments, move(px, py, 0))


def shelf(m, t, width, depth, height, shelves):
    m.box((0, 0, 0), (0.03, depth, height), t)
    m.box((width - 0.03, 0, 0), (width, depth, height), t)
    m.box((0.03, depth - 0.02, 0), (width - 0.03, depth, height), t)
    for k in range(shelves):
        z = k * (height - 0.03) / (shelves - 1)
        m.box((0.03, 0, z), (width - 0.03, depth - 0.02, z + 0.03), t)


def chair(m, t):
    m.box((0, 0, 0.43), (0.45, 0.45, 0.47), t)
    m.box((0, 0.41, 0.47), (0.45, 0.45, 0.9), t)
    for px in (0.03, 0.42):
        for py in (0.03, 0.42):
            m.box((px - 0.02, py - 0.02, 0), (px + 0.02, py + 0.02, 0.43), t)


def bed(m, t):
    m.box((0, 0, 0), (1.6, 2.1, 0.3), t)              # frame
    m.box((0.03, 0.03, 0.3), (1.57, 2.0, 0.52), t)    # mattress
    m.box((0, 2.0, 0), (1.6, 2.1, 1.0), t)            # headboard
    m.box((0.15, 1.55, 0.52), (0.75, 1.95, 0.64), t)  # pillows
    m.box((0.85, 1.55, 0.52), (1.45, 1.95, 0.64), t)


def plant(m, x, y):
    m.cylinder(0.2, 0, 0.4, 12, move(x, y, 0))       # pot
    m.cylinder(0.35, 0.4, 1.3, 12, move(x, y, 0))    # foliage


def wall(m, a, b, thickness, height, doors=()):
    """An axis-aligned wall from a to b (same x or same y) with doorways (centre along the wall,
    width), each 2.1 high with a lintel above."""
    horizontal = a[1] == b[1]
    lo, hi = (min(a[0], b[0]), max(a[0], b[0])) if horizontal else (min(a[1], b[1]), max(a[1], b[1]))
    fixed = a[1] if horizontal else a[0]
    pieces, start = [], lo
    for centre, width in sorted(doors):
        pieces.append((start, centre - width / 2, 0.0, height))
        pieces.append((centre - width / 2, centre + width / 2, 2.1, height))
        start = centre + width / 2
    pieces.append((start, hi, 0.0, height))
    t = thickness / 2
    for s0, s1, z0, z1 in pieces:
        if horizontal:
            m.box((s0, fixed - t, z0), (s1, fixed + t, z1))
        else:
            m.box((fixed - t, s0, z0), (fixed + t, s1, z1))


def home():
    w = Mesh()
    H = 2.6
    # A 12 x 8 flat: living room (x < 6, y < 5), hall (x < 6, y > 5), kitchen (x > 6, y < 4),
    # bedroom (x > 6, y > 4); doorways living-hall, living-kitchen, hall-bedroom, kitchen-bedroom.
    wall(w, (0, 0), (12, 0), 0.2, H)
    wall(w, (0, 8), (12, 8), 0.2, H)
    wall(w, (0, 0), (0, 8), 0.2, H)
    wall(w, (12, 0), (12, 8), 0.2, H)
    wall(w, (6, 0), (6, 8), 0.15, H, doors=[(2.2, 1.0), (6.5, 1.2)])
    wall(w, (0, 5), (6, 5), 0.15, H, doors=[(4.5, 1.2)])
    wall(w, (6, 4), (12, 4), 0.15, H, doors=[(9.0, 1.2)])
    # Living room.
    sofa(w, move(0.5, 4.0, 0))                        # back against the hall's wall
    armchair(w, move(1.0, 1.2, 0, math.pi / 2))        # back against the west wall
    low_table(w, 1.6, 2.6, 1.1, 0.6, 0.45)
    w.box((1.2, 0.1, 0), (3.2, 0.55, 0.5))             # TV stand
    w.box((1.5, 0.3, 0.5), (2.9, 0.36, 1.3))           # TV
    shelf(w, move(5.9, 0.4, 0, math.pi / 2), 1.2, 0.35, 2.0, 5)
    plant(w, 5.5, 4.5)
    # Hall.
    w.box((0.1, 7.5, 0), (1.4, 7.9, 1.0))              # shoe cabinet
    w.cylinder(0.03, 0, 1.8, 8, move(2.0, 7.7, 0))     # coat stand
    w.cylinder(0.25, 0, 0.04, 12, move(2.0, 7.7, 0))
    plant(w, 0.5, 5.5)
    # Kitchen: counter and wall cabinets along the outer wall, fridge, dining set.
    w.box((6.1, 0.1, 0), (10.4, 0.7, 0.9))
    w.box((6.1, 0.1, 1.5), (10.4, 0.45, 2.2))
    w.box((10.5, 0.1, 0), (11.3, 0.8, 1.9))
    w.box((11.3, 0.1, 0), (11.9, 0.75, 0.9))
    low_table(w, 8.0, 1.9, 1.4, 0.9, 0.75)
    chair(w, move(8.25, 1.85, 0, math.pi))
    chair(w, move(8.9, 1.85, 0, math.pi))
    chair(w, move(8.7, 2.85, 0))
    chair(w, move(9.35, 2.85, 0))
    # Bedroom: bed against the outer wall, nightstands, wardrobe, desk with a chair.
    bed(w, move(9.2, 5.8, 0))
    w.box((8.65, 7.4, 0), (9.15, 7.9, 0.55))
    w.box((10.85, 7.4, 0), (11.35, 7.9, 0.55))
    w.box((6.1, 7.3, 0), (8.0, 7.9, 2.1))              # wardrobe
    w.box((11.3, 4.2, 0), (11.9, 5.5, 0.75))           # desk
    chair(w, move(11.2, 4.6, 0, math.pi / 2))
    robot = table_robot()
    desc = ("A table (1.2 x 0.7 x 0.75, round legs) carried from the living room to the bedroom of "
            "a 12 x 8 flat of four rooms with furniture; doorways 1 and 1.2 m wide, 2.1 m high. "
            "SE(3); no floor, the space keeps the table below the lintels.")
    space = {"type": "TYPE_SE3", "lower": [0.3, 0.3, 0.4], "upper": [11.7, 7.7, 1.3],
             "name": "table"}
    write_scene("home", desc, space, [3.0, 1.6, 0.4, 0.0, 0.0, 0.0, 1.0],
                [8.5, 5.2, 0.4] + yaw_quaternion(math.pi / 2), w, robot)


def sofa_robot():
    """A two-seat sofa 1.6 x 0.8 x 0.8 centred on the origin: base, back, arms, two seat
    cushions, four round legs."""
    m = Mesh()
    zb = -0.4
    m.box((-0.8, -0.4, zb + 0.12), (0.8, 0.4, zb + 0.42))         # base
    m.box((-0.8, 0.22, zb + 0.42), (0.8, 0.4, zb + 0.8))          # back
    for sx in (-1, 1):                                          # arms
        m.box((sx * 0.8 - 0.14 * (sx > 0), -0.4, zb + 0.42),
              (sx * 0.8 + 0.14 * (sx < 0), 0.22, zb + 0.62))
    for k in range(2):                                          # seat cushions
        m.box((-0.66 + 0.66 * k, -0.38, zb + 0.42), (0.0 + 0.66 * k, 0.22, zb + 0.5))
    for sx in (-1, 1):
        for sy in (-1, 1):
            m.cylinder(0.03, zb, zb + 0.12, 8, move(sx * 0.72, sy * 0.32, 0))
    return m


def desk(m, t):
    m.box((0, 0, 0.72), (1.4, 0.7, 0.76), t)          # top
    m.box((0, 0, 0), (0.04, 0.7, 0.72), t)            # side panels
    m.box((1.36, 0, 0), (1.4, 0.7, 0.72), t)
    m.box((0.04, 0.66, 0.3), (1.36, 0.7, 0.72), t)    # modesty panel


def flat():
    """The home-like problem where PRM's routes are poor: the study is next to the living room,
    but the door between them is narrow (1.05 m for a sofa 0.8 deep: it passes square to the
    door only), while the way round through the hall has wide doorways. PRM's first paths take
    the way round; a shorter path needs the narrow door."""
    w = Mesh()
    H = 2.6
    # A 14 x 10 flat: living room (x < 7, y < 6), study (x > 7, y < 6), hall (y > 6) along
    # both; doorways living-hall (x 3.2) and study-hall (x 10.8) 1.6 wide, living-study 1.05.
    wall(w, (0, 0), (14, 0), 0.2, H)
    wall(w, (0, 10), (14, 10), 0.2, H)
    wall(w, (0, 0), (0, 10), 0.2, H)
    wall(w, (14, 0), (14, 10), 0.2, H)
    wall(w, (0, 6), (14, 6), 0.15, H, doors=[(3.2, 1.6), (10.8, 1.6)])
    wall(w, (7, 0), (7, 6), 0.15, H, doors=[(2.6, 1.05)])
    # Living room: sofa along the south wall, armchairs, low table, TV wall, shelf, plant.
    sofa(w, move(0.6, 0.15, 0))
    armchair(w, move(0.15, 2.2, 0, -math.pi / 2))      # back against the west wall
    low_table(w, 1.2, 1.4, 1.1, 0.6, 0.45)
    w.box((0.1, 4.3, 0), (0.55, 5.8, 0.5))             # TV stand along the west wall
    w.box((0.25, 4.45, 0.5), (0.31, 5.65, 1.2))        # TV
    shelf(w, move(6.9, 3.6, 0, math.pi / 2), 1.2, 0.35, 2.0, 5)
    plant(w, 6.5, 0.5)
    plant(w, 5.4, 5.5)
    # Study: desk with a chair under the window, bookshelves along the east wall, a reading
    # chair, a plant.
    desk(w, move(9.0, 0.1, 0))
    chair(w, move(9.5, 0.75, 0, 0))
    shelf(w, move(13.9, 0.4, 0, math.pi / 2), 1.2, 0.35, 2.0, 5)
    shelf(w, move(13.9, 1.7, 0, math.pi / 2), 1.2, 0.35, 2.0, 5)
    armchair(w, move(13.05, 4.1, 0, -math.pi / 2))     # back against the east wall
    plant(w, 7.5, 5.5)
    # Hall: shoe cabinet, coat stand, console table, plants, a bench.
    w.box((0.1, 9.5, 0), (1.4, 9.9, 1.0))
    w.cylinder(0.03, 0, 1.8, 8, move(2.0, 9.7, 0))
    w.cylinder(0.25, 0, 0.04, 12, move(2.0, 9.7, 0))
    low_table(w, 6.2, 9.45, 1.6, 0.45, 0.8)
    w.box((9.0, 9.5, 0), (10.6, 9.9, 0.45))            # bench
    plant(w, 13.5, 9.5)
    plant(w, 0.5, 6.5)
    robot = sofa_robot()
    desc = ("A sofa (1.6 x 0.8 x 0.8, round legs) carried from the living room into the study "
            "next door in a 14 x 10 flat: the door between them is 1.05 m wide (the sofa passes "
            "it square on only), the way round through the hall has 1.6 m doorways. Doorways "
            "2.1 m high. SE(3); no floor, the space keeps the sofa below the lintels.")
    space = {"type": "TYPE_SE3", "lower": [0.3, 0.3, 0.4], "upper": [13.7, 9.7, 1.2],
             "name": "sofa"}
    write_scene("flat", desc, space, [4.5, 2.6, 0.4, 0.0, 0.0, 0.0, 1.0],
                [9.5, 3.0, 0.4] + yaw_quaternion(math.pi / 2), w, robot)


def office_chair_robot():
    """An office chair about 0.64 x 0.64 x 1.0 centred on the origin: five-star base with
    casters, gas lift, seat, back and arms."""
    m = Mesh()
    zb = -0.5
    for k in range(5):
        a = 2 * math.pi * k / 5
        m.box((0, -0.025, zb + 0.05), (0.3, 0.025, zb + 0.09), move(0, 0, 0, a))
        m.cylinder(0.03, zb, zb + 0.05, 6, move(0.28 * math.cos(a), 0.28 * math.sin(a), 0))
    m.cylinder(0.035, zb + 0.09, zb + 0.45, 8)
    m.box((-0.25, -0.25, zb + 0.45), (0.25, 0.25, zb + 0.53))   # seat
    m.box((-0.23, 0.22, zb + 0.53), (0.23, 0.27, zb + 1.0))     # back
    for sx in (-1, 1):                                          # arms
        m.box((sx * 0.25 - 0.02, -0.2, zb + 0.53), (sx * 0.25 + 0.02, -0.16, zb + 0.7))
        m.box((sx * 0.25 - 0.03, -0.22, zb + 0.7), (sx * 0.25 + 0.03, 0.15, zb + 0.73))
    return m


def office():
    w = Mesh()
    H, P, C = 2.8, 1.6, 2.4  # room height, partition height, cubicle size
    wall(w, (0, 0), (19, 0), 0.2, H)
    wall(w, (0, 8.6), (19, 8.6), 0.2, H)
    wall(w, (0, 0), (0, 8.6), 0.2, H)
    wall(w, (19, 0), (19, 8.6), 0.2, H)
    t = 0.03
    for bx in (1.4, 10.4):
        by = 1.5
        # Back-to-back rows of three cubicles: row 0 opens south, row 1 north.
        w.box((bx, by + C - t, 0), (bx + 3 * C, by + C + t, P))
        for i in range(4):
            w.box((bx + i * C - t, by, 0), (bx + i * C + t, by + 2 * C, P))
        for row, y in ((0, by), (1, by + 2 * C)):
            for i in range(3):
                x0 = bx + i * C
                # A 0.9 opening beside the cubicle's west side.
                w.box((x0 + 1.25, y - t, 0), (x0 + C, y + t, P))
                w.box((x0, y - t, 0), (x0 + 0.35, y + t, P))
                # The desk along the back partition, with two side panels.
                yd = by + C - t - 0.7 if row == 0 else by + C + t
                w.box((x0 + 0.4, yd, 0.7), (x0 + C - 0.1, yd + 0.7, 0.74))
                w.box((x0 + 0.4, yd, 0), (x0 + 0.44, yd + 0.7, 0.7))
                w.box((x0 + C - 0.14, yd, 0), (x0 + C - 0.1, yd + 0.7, 0.7))
    for x in (9.1, 18.4):
        plant(w, x, 0.5)
    robot = office_chair_robot()
    desc = ("An office chair (0.64 x 0.64 x 1.0) from a cubicle of the west block to one on the "
            "far side of the east block: two blocks of six 2.4 m cubicles with 1.6 m partitions, "
            "0.9 m openings and a desk each. SE(3); the space keeps the chair below the "
            "partitions' tops.")
    space = {"type": "TYPE_SE3", "lower": [0.4, 0.4, 0.5], "upper": [18.6, 8.2, 0.85],
             "name": "chair"}
    write_scene("office", desc, space, [2.2, 2.2, 0.5, 0.0, 0.0, 0.0, 1.0],
                [16.0, 5.5, 0.5] + yaw_quaternion(math.pi), w, robot)


def rounded_rectangle(a, b, r, segments):
    """Counterclockwise outline of an a x b rectangle with corners of radius r."""
    pts = []
    centres = [(a / 2 - r, b / 2 - r), (-a / 2 + r, b / 2 - r), (-a / 2 + r, -b / 2 + r),
               (a / 2 - r, -b / 2 + r)]
    for k, (cx, cy) in enumerate(centres):
        for s in range(segments + 1):
            ang = k * math.pi / 2 + s * (math.pi / 2) / segments
            pts.append((cx + r * math.cos(ang), cy + r * math.sin(ang)))
    return pts


def stadium(length, width, segments):
    """Counterclockwise (y, z) outline of a slot `length` long along z, `width` wide."""
    r = width / 2
    h = length / 2 - r
    pts = []
    for s in range(segments + 1):
        ang = s * math.pi / segments
        pts.append((r * math.cos(ang), h + r * math.sin(ang)))
    for s in range(segments + 1):
        ang = math.pi + s * math.pi / segments
        pts.append((r * math.cos(ang), -h + r * math.sin(ang)))
    return pts


# The twisty slots: length and width, and their turns about x, plate by plate.
TWISTY_SLOT = (1.8, 0.7)
TWISTY_TURNS = (0.0, math.pi / 2, 0.0)


def twisty():
    w = Mesh()
    slot = stadium(TWISTY_SLOT[0], TWISTY_SLOT[1], 16)
    # Three plates with turned slots; the outer two close the room, the middle one the tube
    # (2 x 2, between them).
    w.plate_with_hole(-1.6, -1.4, 3.5, slot, TWISTY_TURNS[0])
    w.plate_with_hole(-0.1, 0.1, 1.5, slot, TWISTY_TURNS[1])
    w.plate_with_hole(1.4, 1.6, 3.5, slot, TWISTY_TURNS[2])
    w.box((-1.5, -1.1, -1.1), (1.5, -1.0, 1.1))
    w.box((-1.5, 1.0, -1.1), (1.5, 1.1, 1.1))
    w.box((-1.5, -1.0, -1.1), (1.5, 1.0, -1.0))
    w.box((-1.5, -1.0, 1.0), (1.5, 1.0, 1.1))
    # The robot: a plate 0.7 (x) x 1.2 (z) with rounded corners, 0.16 thick along y.
    robot = Mesh()
    robot.prism(rounded_rectangle(0.7, 1.2, 0.15, 6), -0.08, 0.08,
                lambda p: (p[0], -p[2], p[1]))
    desc = ("A rounded plate (0.7 x 1.2 x 0.16) threads three 0.2 thick plates 1.5 apart whose "
            "0.7 x 1.8 stadium slots are turned by 0, 90 and 0 degrees about the direction of "
            "travel, inside a closed 2 x 2 tube: it rolls a quarter turn and back. SE(3).")
    space = {"type": "TYPE_SE3", "lower": [-3.2, -1.0, -1.0], "upper": [3.2, 1.0, 1.0],
             "name": "plate"}
    write_scene("twisty", desc, space, [-2.6, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0],
                [2.6, 0.0, 0.0, round(math.sin(TWISTY_TURNS[2] / 2), 9), 0.0, 0.0,
                 round(math.cos(TWISTY_TURNS[2] / 2), 9)], w, robot)


class Lcg:
    """A 64-bit linear congruential generator (Knuth's MMIX constants): fixed across Python
    versions, unlike the random module's algorithms for shuffling."""

    def __init__(self, seed):
        self.state = seed

    def below(self, n):
        self.state = (self.state * 6364136223846793005 + 1442695040888963407) % 2**64
        return (self.state >> 33) % n


def perfect_maze(n, seed):
    """Depth-first carving of an n x n grid: the set of open walls between cells, one path
    between any two cells."""
    rng = Lcg(seed)
    seen, opened, stack = {(0, 0)}, set(), [(0, 0)]
    while stack:
        x, y = stack[-1]
        nexts = [(x + dx, y + dy) for dx, dy in ((1, 0), (-1, 0), (0, 1), (0, -1))
                 if 0 <= x + dx < n and 0 <= y + dy < n and (x + dx, y + dy) not in seen]
        if not nexts:
            stack.pop()
            continue
        q = nexts[rng.below(len(nexts))]
        opened.add(frozenset(((x, y), q)))
        seen.add(q)
        stack.append(q)
    return opened


def car_robot():
    """A car 1.2 x 0.64 centred on the origin: body over a tapered outline, cabin, four
    wheels, bumpers and mirrors."""
    m = Mesh()
    m.prism([(-0.6, -0.28), (0.45, -0.28), (0.6, -0.16), (0.6, 0.16), (0.45, 0.28), (-0.6, 0.28)],
            -0.15, 0.1)
    # The cabin: a trapezoid in xz, extruded along y.
    m.prism([(-0.45, 0.1), (0.15, 0.1), (0.0, 0.3), (-0.35, 0.3)], -0.24, 0.24,
            lambda p: (p[0], -p[2], p[1]))
    for px in (-0.38, 0.35):
        for py in (-0.27, 0.27):
            m.cylinder(0.13, -0.05, 0.05, 12, along_y(px, py, -0.12))
    m.box((-0.64, -0.25, -0.12), (-0.6, 0.25, -0.02))
    m.box((0.6, -0.14, -0.12), (0.63, 0.14, -0.02))
    for sy in (-1, 1):
        m.box((0.12, sy * 0.24 - 0.04, 0.12), (0.17, sy * 0.24 + 0.04, 0.17))
    return m


def car_maze():
    n, cell, t, h = 7, 1.8, 0.2, 0.5
    opened = perfect_maze(n, 26)
    w = Mesh()
    for x in range(n + 1):
        for y in range(n):
            # The wall west of cell (x, y), unless open.
            if 0 < x < n and frozenset(((x - 1, y), (x, y))) in opened:
                continue
            w.box((x * cell - t / 2, y * cell - t / 2, -h), (x * cell + t / 2, (y + 1) * cell + t / 2, h))
    for y in range(n + 1):
        for x in range(n):
            if 0 < y < n and frozenset(((x, y - 1), (x, y))) in opened:
                continue
            w.box((x * cell - t / 2, y * cell - t / 2, -h), ((x + 1) * cell + t / 2, y * cell + t / 2, h))
    robot = car_robot()
    desc = ("A car (1.2 x 0.64, body, cabin, wheels) from one corner of a 7 x 7 perfect maze "
            "(1.8 m cells, 0.2 m walls) to the opposite one. SE(2).")
    space = {"type": "TYPE_SE2", "lower": [0.0, 0.0], "upper": [n * cell, n * cell],
             "name": "car"}
    write_scene("car_maze", desc, space, [cell / 2, cell / 2, 0.0],
                [(n - 0.5) * cell, (n - 0.5) * cell, math.pi / 2], w, robot)


def main():
    home()
    office()
    twisty()
    car_maze()
    flat()


if __name__ == "__main__":
    main()
