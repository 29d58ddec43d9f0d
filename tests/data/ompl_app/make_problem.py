#!/usr/bin/env python3
"""Writes a small OMPL.app problem in OMPL.app's own format, to test `hgraph import-cfg`:
a wall with a gap (wall_env.dae), a box robot (box_robot.dae) and wall_planar.cfg.

Both meshes are Z_UP COLLADA files drawn the way OMPL.app's SketchUp files are: the planar shapes
lie in the file's XZ plane, so that assimp's default Z_UP -> Y_UP rotation, (x, y, z) ->
(x, z, -y), puts them in the XY plane where OMPL.app plans. The robot's geometry is 100 times too
small and its node carries a scale of 100 and a translation, as some OMPL.app files do; its
vertex centroid therefore lies at file (1.0, 0, 0.45) = world (1.0, 0.45, 0), away from the origin.
Run from this folder: python3 make_problem.py
"""


def box(lo, hi):
    """The 8 corners and 12 triangles of an axis-aligned box (outward winding)."""
    v = [(hi[0] if i & 1 else lo[0], hi[1] if i & 2 else lo[1], hi[2] if i & 4 else lo[2])
         for i in range(8)]
    t = [(0, 2, 1), (1, 2, 3), (4, 5, 6), (5, 7, 6), (0, 1, 4), (1, 5, 4),
         (2, 6, 3), (3, 6, 7), (0, 4, 2), (2, 4, 6), (1, 3, 5), (3, 7, 5)]
    return v, t


def collada(boxes, matrix):
    verts, tris = [], []
    for lo, hi in boxes:
        v, t = box(lo, hi)
        tris += [tuple(i + len(verts) for i in tri) for tri in t]
        verts += v
    floats = " ".join("%g" % c for p in verts for c in p)
    indices = " ".join(str(i) for tri in tris for i in tri)
    m = " ".join("%g" % c for c in matrix)
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
          <float_array id="shape-positions-array" count="{3 * len(verts)}">{floats}</float_array>
          <technique_common>
            <accessor source="#shape-positions-array" count="{len(verts)}" stride="3">
              <param name="X" type="float"/>
              <param name="Y" type="float"/>
              <param name="Z" type="float"/>
            </accessor>
          </technique_common>
        </source>
        <vertices id="shape-vertices">
          <input semantic="POSITION" source="#shape-positions"/>
        </vertices>
        <triangles count="{len(tris)}">
          <input semantic="VERTEX" source="#shape-vertices" offset="0"/>
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


IDENTITY = [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]
# Wall at x = 0 from world y = -5 to 5 with a gap |y| < 0.5; world z in [-0.5, 0.5] is file -y.
WALL = [((-0.25, -0.5, 0.5), (0.25, 0.5, 5.0)), ((-0.25, -0.5, -5.0), (0.25, 0.5, -0.5))]
# A 0.6 x 0.3 x 0.2 box at 1/100 scale; the node scales it by 100 and moves it by (0.5, 0, 0.2).
ROBOT = [((0.002, -0.001, 0.001), (0.008, 0.001, 0.004))]
ROBOT_MATRIX = [100, 0, 0, 0.5, 0, 100, 0, 0, 0, 0, 100, 0.2, 0, 0, 0, 1]

CFG = """[problem]
name = WallWithGap
robot = box_robot.dae
world = wall_env.dae
start.x = -3.0
start.y = 2.0
start.theta = 0.0
goal.x = 3.0
goal.y = -2.0
goal.theta = 1.5707963267949
volume.min.x = -5.0
volume.min.y = -5.0
volume.max.x = 5.0
volume.max.y = 5.0

[benchmark]
time_limit = 5.0
run_count = 10

[planner]
prm =
"""

if __name__ == "__main__":
    with open("wall_env.dae", "w") as f:
        f.write(collada(WALL, IDENTITY))
    with open("box_robot.dae", "w") as f:
        f.write(collada(ROBOT, ROBOT_MATRIX))
    with open("wall_planar.cfg", "w") as f:
        f.write(CFG)
