"""Writes the fuzz seed corpus, one folder per target, from tests/data and scenes/ (and a few
malformed meshes of the bad-input catalogue). Usage: make_seeds.py OUT_DIR [PYTHONPATH for the
generated hgraph.v1 modules]."""
import pathlib
import sys

ROOT = pathlib.Path(__file__).resolve().parents[2]
out = pathlib.Path(sys.argv[1])
if len(sys.argv) > 2:
    sys.path.insert(0, sys.argv[2])
sys.path.insert(0, str(ROOT / "client" / "python"))
sys.path.insert(0, str(ROOT / "tests" / "integration"))

FORMATS = ["off", "ply", "obj", "stl", "dae", "gltf", "glb", "zae"]


def write(target, name, data):
    folder = out / target
    folder.mkdir(parents=True, exist_ok=True)
    (folder / name).write_bytes(data)


def mesh(name, fmt, data):
    write("mesh_fuzz", name, bytes([FORMATS.index(fmt)]) + data)


for scene in sorted(list(ROOT.glob("scenes/*/scene.json")) + list(ROOT.glob("tests/data/*/scene.json"))):
    write("scene_fuzz", scene.parent.name + ".json", scene.read_bytes())
for f in ROOT.glob("scenes/*/*.obj"):
    mesh(f.parent.name + ".obj", "obj", f.read_bytes()[:20000])
for f in ROOT.glob("tests/data/ompl_app/*.dae"):
    mesh(f.name, "dae", f.read_bytes())
write("ompl_files_fuzz", "wall_planar.cfg", b"\0" + (ROOT / "tests/data/ompl_app/wall_planar.cfg").read_bytes())
write("ompl_files_fuzz", "paths.txt", b"\2" + (ROOT / "tests/data/circles/paths.txt").read_bytes())
write("ompl_files_fuzz", "states.path",
      b"\1" + b"".join(f"Compound state [\nRealVectorState [{i} {i}]\nSO2State [0]\n]\n".encode()
                       for i in range(3)))

import bad_input_catalogue as catalogue  # noqa: E402
from hgraph.v1 import merge_pb2, path_pb2, service_pb2  # noqa: E402

mesh("tetra.off", "off", catalogue.OFF_TETRA)
mesh("tetra.ply", "ply", catalogue.ply_tetra_binary())
mesh("tetra.gltf", "gltf", catalogue.gltf_embedded())
mesh("mtllib.obj", "obj", catalogue.obj_with_mtllib("/etc/passwd"))

request = service_pb2.MergePathsRequest(session="s")
for ys in ([1, 8], [9, 2]):
    p = request.paths.paths.add()
    for q in ([1, 1], [ys[0], ys[1]], [9, 9]):
        p.waypoints.add(values=q)
write("merge_request_fuzz", "two_paths.bin", request.SerializeToString())
request.measure.type = merge_pb2.Measure.TYPE_INVERSE_CLEARANCE
request.options.variant = merge_pb2.VARIANT_ALL_PAIRS
write("merge_request_fuzz", "all_pairs_clearance.bin", request.SerializeToString())
