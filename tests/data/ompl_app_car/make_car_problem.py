#!/usr/bin/env python3
"""Writes an OMPL.app problem whose robot has corners shared by faces of different normals, so
that OMPL.app's reference point (the mean of the vertices as its assimp import leaves them, one
copy per distinct normal) differs from the mean of the distinct vertex positions.

The robot (car_robot.dae) is a car body: a prism over a six-sided outline (a tapered nose), with
four extra corners on its right flank (y = -0.5) where the flank is split into panels of one
normal. Faces carry their own normals (COLLADA <input semantic="NORMAL"> per face corner), so
after OMPL.app's import every outline corner stays three times (top or bottom, two flanks) and
every flank-split corner twice: the mean moves towards the left flank. The environment
(car_env.dae) is a wall with a gap and a block. car_planar.cfg is the SE(2) problem, car_3d.cfg
the SE(3) one (same meshes, the robot's height bounded so that it cannot fly over the wall).

Both meshes are Z_UP COLLADA files drawn in the file's XZ plane, as OMPL.app's SketchUp files
are: assimp's Z_UP -> Y_UP rotation, (x, y, z) -> (x, z, -y), puts them in the world's XY plane.
The robot's node moves it by world (0.5, 0.25, 0). Run from this folder: python3 make_car_problem.py
Written for hgraph; the files it writes are under the project's license like this script.
"""

# Outline of the car body in world XY, counterclockwise; the split corners of the right flank
# lie on its edge from (-1, -0.5) to (0.6, -0.5).
OUTLINE = [(-1.0, -0.5), (-0.6, -0.5), (-0.3, -0.5), (0.0, -0.5), (0.3, -0.5), (0.6, -0.5),
           (1.0, -0.25), (1.0, 0.25), (0.6, 0.5), (-1.0, 0.5)]
HEIGHT = (-0.2, 0.2)  # world z


def to_file(p):
    """World (X, Y, Z) to file coordinates: the inverse of (x, y, z) -> (x, z, -y)."""
    return (p[0], -p[2], p[1])


def normal(polygon):
    """Newell's normal of a planar polygon: well defined with collinear corners."""
    n = [0.0, 0.0, 0.0]
    for i, a in enumerate(polygon):
        b = polygon[(i + 1) % len(polygon)]
        n[0] += (a[1] - b[1]) * (a[2] + b[2])
        n[1] += (a[2] - b[2]) * (a[0] + b[0])
        n[2] += (a[0] - b[0]) * (a[1] + b[1])
    length = sum(x * x for x in n) ** 0.5
    return tuple(x / length for x in n)


class MeshWriter:
    """Triangles with one normal per face, indexed as COLLADA (position, normal) pairs."""

    def __init__(self):
        self.positions, self.normals, self.corners = [], [], []

    def position(self, p):
        p = to_file(p)
        if p not in self.positions:
            self.positions.append(p)
        return self.positions.index(p)

    def face(self, *polygon):
        """A planar convex polygon (world coordinates, counterclockwise seen from outside),
        fanned from its first corner (which must not be collinear with any edge but its own);
        all its triangles share the polygon's normal."""
        n = normal([to_file(p) for p in polygon])
        n = tuple(round(x, 12) + 0.0 for x in n)
        if n not in self.normals:
            self.normals.append(n)
        k = self.normals.index(n)
        for i in range(1, len(polygon) - 1):
            for p in (polygon[0], polygon[i], polygon[i + 1]):
                self.corners.append((self.position(p), k))

    def prism(self, outline, z0, z1):
        """Top and bottom are fanned from the outline's last corner."""
        fan = outline[-1:] + outline[:-1]
        self.face(*[(x, y, z1) for x, y in fan])
        self.face(*[(x, y, z0) for x, y in [fan[0]] + fan[:0:-1]])
        for i, (x0, y0) in enumerate(outline):
            x1, y1 = outline[(i + 1) % len(outline)]
            self.face((x0, y0, z0), (x1, y1, z0), (x1, y1, z1), (x0, y0, z1))

    def collada(self, matrix):
        floats = " ".join("%.17g" % c for p in self.positions for c in p)
        normals = " ".join("%.17g" % c for n in self.normals for c in n)
        indices = " ".join("%d %d" % c for c in self.corners)
        m = " ".join("%.17g" % c for c in matrix)
        return f"""<?xml version="1.0" encoding="utf-8"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
  <asset>
    <unit name="meter" meter="1"/>
    <up_axis>Z_UP</up_axis>
  </asset>
  <library_geometries>
    <geometry id="shape" name="shape">
      <mesh>
        <source id="shape-positions">
          <float_array id="shape-positions-array" count="{3 * len(self.positions)}">{floats}</float_array>
          <technique_common>
            <accessor source="#shape-positions-array" count="{len(self.positions)}" stride="3">
              <param name="X" type="float"/>
              <param name="Y" type="float"/>
              <param name="Z" type="float"/>
            </accessor>
          </technique_common>
        </source>
        <source id="shape-normals">
          <float_array id="shape-normals-array" count="{3 * len(self.normals)}">{normals}</float_array>
          <technique_common>
            <accessor source="#shape-normals-array" count="{len(self.normals)}" stride="3">
              <param name="X" type="float"/>
              <param name="Y" type="float"/>
              <param name="Z" type="float"/>
            </accessor>
          </technique_common>
        </source>
        <vertices id="shape-vertices">
          <input semantic="POSITION" source="#shape-positions"/>
        </vertices>
        <triangles count="{len(self.corners) // 3}">
          <input semantic="VERTEX" source="#shape-vertices" offset="0"/>
          <input semantic="NORMAL" source="#shape-normals" offset="1"/>
          <p>{indices}</p>
        </triangles>
      </mesh>
    </geometry>
  </library_geometries>
  <library_visual_scenes>
    <visual_scene id="scene" name="scene">
      <node id="part" name="part">
        <matrix>{m}</matrix>
        <instance_geometry url="#shape"/>
      </node>
    </visual_scene>
  </library_visual_scenes>
  <scene>
    <instance_visual_scene url="#scene"/>
  </scene>
</COLLADA>
"""


def box(writer, lo, hi):
    writer.prism([(lo[0], lo[1]), (hi[0], lo[1]), (hi[0], hi[1]), (lo[0], hi[1])], lo[2], hi[2])


IDENTITY = [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]
# World (0.5, 0.25, 0) in file coordinates is (0.5, 0, 0.25).
ROBOT_MATRIX = [1, 0, 0, 0.5, 0, 1, 0, 0, 0, 0, 1, 0.25, 0, 0, 0, 1]

COMMON = """robot = car_robot.dae
world = car_env.dae
volume.min.x = -6.0
volume.min.y = -6.0
volume.max.x = 6.0
volume.max.y = 6.0
"""
PLANAR = """[problem]
name = CarThroughGap
""" + COMMON + """start.x = -3.5
start.y = 3.0
start.theta = 0.0
goal.x = 3.5
goal.y = -3.0
goal.theta = 1.5707963267949

[benchmark]
time_limit = 5.0
run_count = 10

[planner]
prm =
"""
SPATIAL = """[problem]
name = CarThroughGap3D
""" + COMMON + """volume.min.z = -0.25
volume.max.z = 0.25
start.x = -3.5
start.y = 3.0
start.z = 0.0
start.axis.x = 0.0
start.axis.y = 0.0
start.axis.z = 1.0
start.theta = 0.0
goal.x = 3.5
goal.y = -3.0
goal.z = 0.0
goal.axis.x = 0.0
goal.axis.y = 0.0
goal.axis.z = 1.0
goal.theta = 1.5707963267949

[benchmark]
time_limit = 5.0
run_count = 10

[planner]
rrtconnect =
"""

if __name__ == "__main__":
    robot = MeshWriter()
    robot.prism(OUTLINE, *HEIGHT)
    env = MeshWriter()
    # A wall at x = 0 with a gap |y| < 0.9, and a block in the lower right.
    box(env, (-0.25, 0.9, -0.6), (0.25, 6.0, 0.6))
    box(env, (-0.25, -6.0, -0.6), (0.25, -0.9, 0.6))
    box(env, (2.0, 0.5, -0.6), (3.0, 1.5, 0.6))
    with open("car_robot.dae", "w") as f:
        f.write(robot.collada(ROBOT_MATRIX))
    with open("car_env.dae", "w") as f:
        f.write(env.collada(IDENTITY))
    with open("car_planar.cfg", "w") as f:
        f.write(PLANAR)
    with open("car_3d.cfg", "w") as f:
        f.write(SPATIAL)
