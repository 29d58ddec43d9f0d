"""The bad-input catalogue: hostile and malformed requests against a live hgraph-server on
loopback. Each case is one row (input, expected gRPC code, message fragment); after every case
the server must still answer a health check and a valid merge, so no input may crash, hang or
wedge it. Classes: overflowing and out-of-range numbers (scene, space, paths, merge options,
measures, CheckPaths, PlanPaths, Solve), malformed meshes parsed out of process (truncated and lying
OFF/PLY, a zip bomb, garbage), file names inside meshes (OBJ mtllib, glTF buffer uris: never
opened), bad names, sizes and digests.

Run through CTest (test 'bad_input_catalogue'), or by hand:
    HGRAPH_SERVER=build/hgraph-server PYTHONPATH=client/python:build/python \
    /usr/bin/python3 -m pytest tests/integration/bad_input_catalogue.py
"""
import base64
import copy
import hashlib
import io
import json
import os
import pathlib
import struct
import sys
import zipfile

import grpc
import pytest
from google.protobuf import json_format

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from test_service import DATA, Server  # noqa: E402  (the same server fixture as test_service)

import hgraph_client  # noqa: E402
from hgraph.v1 import merge_pb2, path_pb2, scene_pb2, service_pb2, service_pb2_grpc, space_pb2  # noqa: E402

C = grpc.StatusCode
TIMEOUT_S = 30

# ---------------------------------------------------------------------------------------------
# Inputs


def circles_scene():
    return json_format.Parse((DATA / "scene.json").read_text(), scene_pb2.Scene())


def scene_with(edit):
    scene = circles_scene()
    edit(scene)
    return scene


def paths():
    return hgraph_client.load_paths_text((DATA / "paths.txt").read_text())


def paths_with(edit):
    p = paths()
    edit(p)
    return p


OFF_TETRA = b"OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n3 0 1 3\n3 0 2 3\n3 1 2 3\n"
PLY_HEADER = (b"ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\n"
              b"property float y\nproperty float z\nelement face 4\n"
              b"property list uchar int vertex_indices\nend_header\n")


def ply_tetra_binary():
    body = b"".join(struct.pack("<3f", *v) for v in [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)])
    for f in [(0, 1, 2), (0, 1, 3), (0, 2, 3), (1, 2, 3)]:
        body += struct.pack("<B3i", 3, *f)
    return PLY_HEADER + body


def gltf_with_uri(uri):
    return json.dumps({
        "asset": {"version": "2.0"},
        "buffers": [{"uri": uri, "byteLength": 36}],
        "bufferViews": [{"buffer": 0, "byteLength": 36}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                       "max": [1, 1, 0], "min": [0, 0, 0]}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
        "nodes": [{"mesh": 0}], "scenes": [{"nodes": [0]}], "scene": 0}).encode()


def gltf_embedded():
    data = struct.pack("<9f", 0, 0, 0, 1, 0, 0, 0, 1, 0)
    return gltf_with_uri("data:application/octet-stream;base64," + base64.b64encode(data).decode())


def obj_with_mtllib(name):
    return f"mtllib {name}\nv 70 70 0\nv 71 70 0\nv 70 71 0\nf 1 2 3\n".encode()


def zae_bomb(inflated_mib=160):
    """A COLLADA zip archive whose one entry inflates ~1000-fold."""
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED, compresslevel=9) as z:
        z.writestr("model.dae", b"<?xml version='1.0'?><COLLADA>" + b" " * (inflated_mib << 20))
    return out.getvalue()


def mesh_scene(data, fmt):
    """The circles scene with one more obstacle, an inline mesh (MESH_AT)."""
    def edit(scene):
        o = scene.obstacles.add(name="mesh")
        o.shape.mesh.data = data
        o.shape.mesh.format = fmt
    return scene_with(edit)


MESH_AT = f"scene.obstacles[{len(circles_scene().obstacles)}].shape.mesh"
MESH = MESH_AT + ".data"


def digest(data):
    return scene_pb2.Digest(sha256=hashlib.sha256(data).hexdigest(), size_bytes=len(data))


# ---------------------------------------------------------------------------------------------
# The catalogue: (name, call, input, expected code, message fragment). `call` is one of
# put_scene, merge, merge_options, check, plan, solve, upload, session, requery.

def wrong_size(stub):
    """The circles scene's digest as the server computes it, with size_bytes off by one."""
    d = stub.PutScene(service_pb2.PutSceneRequest(scene=circles_scene()), timeout=TIMEOUT_S).digest
    return scene_pb2.Digest(sha256=d.sha256, size_bytes=d.size_bytes + 1)


def merge_req(**options):
    return dict(options=merge_pb2.MergeOptions(**options))


CASES = [
    # Numbers in the scene and its space.
    ("bounds_1e308", "put_scene", scene_with(lambda s: (s.space.components[0].lower.__setitem__(0, -1e308), s.space.components[0].upper.__setitem__(0, 1e308))), C.INVALID_ARGUMENT, "scene.space.components[0].lower[0]"),
    ("bound_above_range", "put_scene", scene_with(lambda s: s.space.components[0].upper.__setitem__(1, 2e9)), C.INVALID_ARGUMENT, "scene.space.components[0].upper[1]"),
    ("bounds_nan", "put_scene", scene_with(lambda s: s.space.components[0].upper.__setitem__(0, float("nan"))), C.INVALID_ARGUMENT, "scene.space.components[0].upper[0]"),
    ("bounds_inverted", "put_scene", scene_with(lambda s: s.space.components[0].upper.__setitem__(0, -5)), C.INVALID_ARGUMENT, "lower < upper"),
    ("weight_1e308", "put_scene", scene_with(lambda s: setattr(s.space.components[0], "translation_weight", 1e308)), C.INVALID_ARGUMENT, "translation_weight"),
    ("weight_zero_extent", "put_scene", scene_with(lambda s: setattr(s.space.components[0], "translation_weight", 0)), C.INVALID_ARGUMENT, "extent of the space is 0"),
    ("weight_negative", "put_scene", scene_with(lambda s: setattr(s.space.components[0], "translation_weight", -1)), C.INVALID_ARGUMENT, "translation_weight"),
    ("dimension_zero", "put_scene", scene_with(lambda s: setattr(s.space.components[0], "dimension", 0)), C.INVALID_ARGUMENT, "scene.space.components[0].dimension"),
    ("component_type_unknown", "put_scene", scene_with(lambda s: setattr(s.space.components[0], "type", 99)), C.INVALID_ARGUMENT, "scene.space.components[0].type"),
    ("scene_resolution_tiny", "put_scene", scene_with(lambda s: setattr(s, "resolution", 1e-12)), C.INVALID_ARGUMENT, "scene.resolution"),
    ("scene_resolution_negative", "put_scene", scene_with(lambda s: setattr(s, "resolution", -1)), C.INVALID_ARGUMENT, "scene.resolution"),
    ("obstacle_position_1e308", "put_scene", scene_with(lambda s: s.obstacles[0].pose.position.__setitem__(0, 1e308)), C.INVALID_ARGUMENT, "scene.obstacles[0].pose.position[0]"),
    ("obstacle_position_two_values", "put_scene", scene_with(lambda s: s.obstacles[0].pose.ClearField("position") or s.obstacles[0].pose.position.extend([1, 2])), C.INVALID_ARGUMENT, "scene.obstacles[0].pose.position"),
    ("quaternion_not_unit", "put_scene", scene_with(lambda s: s.obstacles[0].pose.orientation.extend([0, 0, 0, 2])), C.INVALID_ARGUMENT, "scene.obstacles[0].pose.orientation"),
    ("cylinder_radius_1e308", "put_scene", scene_with(lambda s: setattr(s.obstacles[0].shape.cylinder, "radius", 1e308)), C.INVALID_ARGUMENT, "scene.obstacles[0].shape.cylinder.radius"),
    ("cylinder_radius_zero", "put_scene", scene_with(lambda s: setattr(s.obstacles[0].shape.cylinder, "radius", 0)), C.INVALID_ARGUMENT, "scene.obstacles[0].shape.cylinder.radius"),
    ("scale_overflow", "put_scene", scene_with(lambda s: s.obstacles[0].shape.scale.extend([1e300])), C.INVALID_ARGUMENT, "scene.obstacles[0].shape.scale[0]"),
    ("scale_product_too_large", "put_scene", scene_with(lambda s: (setattr(s.obstacles[0].shape.cylinder, "radius", 1e8), s.obstacles[0].shape.scale.extend([1e5]))), C.INVALID_ARGUMENT, "scene.obstacles[0].shape"),
    ("scale_two_values", "put_scene", scene_with(lambda s: s.obstacles[0].shape.scale.extend([1, 2])), C.INVALID_ARGUMENT, "scene.obstacles[0].shape.scale"),
    ("shape_unset", "put_scene", scene_with(lambda s: s.obstacles[0].ClearField("shape")), C.INVALID_ARGUMENT, "scene.obstacles[0].shape"),
    ("robot_component_out_of_range", "put_scene", scene_with(lambda s: setattr(s.robot[0], "component", 7)), C.INVALID_ARGUMENT, "scene.robot[0].component"),
    ("robot_missing", "put_scene", scene_with(lambda s: s.ClearField("robot")), C.INVALID_ARGUMENT, "scene.robot"),
    ("start_1e308", "put_scene", scene_with(lambda s: s.start.values.extend([1e308, 1])), C.INVALID_ARGUMENT, "scene.start"),
    ("mesh_path_refused", "put_scene", scene_with(lambda s: (setattr(s.obstacles[0].shape.mesh, "path", "/etc/passwd"))), C.INVALID_ARGUMENT, "mesh.path"),
    # Malformed meshes (parsed in hgraph-mesh-import).
    ("off_truncated_33_bytes", "put_scene", mesh_scene(OFF_TETRA[:33], "off"), C.INVALID_ARGUMENT, MESH),
    ("off_face_index_past_vertices", "put_scene", mesh_scene(b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 9\n", "off"), C.INVALID_ARGUMENT, "names vertex 9"),
    ("off_claims_1e9_vertices", "put_scene", mesh_scene(b"OFF\n1000000000 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", "off"), C.INVALID_ARGUMENT, "1000000000 vertices"),
    ("off_counts_not_numbers", "put_scene", mesh_scene(b"OFF\nmany few 0\n", "off"), C.INVALID_ARGUMENT, MESH),
    ("ply_header_stops_after_format", "put_scene", mesh_scene(b"ply\nformat ascii 1.0\n", "ply"), C.INVALID_ARGUMENT, "end_header"),
    ("ply_binary_cut_short", "put_scene", mesh_scene(ply_tetra_binary()[:-27], "ply"), C.INVALID_ARGUMENT, MESH),
    ("ply_claims_2e7_vertices", "put_scene", mesh_scene(PLY_HEADER.replace(b"vertex 4", b"vertex 20000000") + ply_tetra_binary()[len(PLY_HEADER):], "ply"), C.INVALID_ARGUMENT, "20000000 'vertex'"),
    ("ply_unknown_property_type", "put_scene", mesh_scene(PLY_HEADER.replace(b"float x", b"quad x") + b"\0" * 64, "ply"), C.INVALID_ARGUMENT, "PLY header"),
    ("ply_hint_but_off_bytes", "put_scene", mesh_scene(b"OFF\n99999999 0 0\n", "ply"), C.INVALID_ARGUMENT, "99999999 vertices"),
    ("zae_zip_bomb", "put_scene", None, C.INVALID_ARGUMENT, MESH),  # built lazily (slow)
    ("garbage_stl", "put_scene", mesh_scene(bytes(range(256)) * 4, "stl"), C.INVALID_ARGUMENT, MESH),
    ("garbage_dae", "put_scene", mesh_scene(b"<COLLADA><library_geometries><geometry", "dae"), C.INVALID_ARGUMENT, MESH),
    ("obj_without_faces", "put_scene", mesh_scene(b"v 0 0 0\nv 1 0 0\n", "obj"), C.INVALID_ARGUMENT, MESH),
    ("obj_vertex_overflows", "put_scene", mesh_scene(b"v 1e400 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "obj"), C.INVALID_ARGUMENT, MESH),
    ("obj_vertex_beyond_range", "put_scene", mesh_scene(b"v 1e12 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "obj"), C.INVALID_ARGUMENT, "outside"),
    ("mesh_data_empty", "put_scene", mesh_scene(b"", "obj"), C.INVALID_ARGUMENT, MESH_AT),
    ("mesh_format_missing", "put_scene", mesh_scene(OFF_TETRA, ""), C.INVALID_ARGUMENT, MESH_AT + ".format"),
    ("mesh_format_path", "put_scene", mesh_scene(OFF_TETRA, "../../etc/obj"), C.INVALID_ARGUMENT, MESH_AT + ".format"),
    ("mesh_format_newline", "put_scene", mesh_scene(OFF_TETRA, "off\nforged"), C.INVALID_ARGUMENT, MESH_AT + ".format"),
    # File names inside meshes: never opened. A name that exists and one that does not give the
    # same answer (test_referenced_names_are_indistinguishable checks that too).
    ("obj_mtllib_absolute", "put_scene", mesh_scene(obj_with_mtllib("/etc/passwd"), "obj"), C.OK, ""),
    ("obj_mtllib_parent", "put_scene", mesh_scene(obj_with_mtllib("../../../../etc/passwd"), "obj"), C.OK, ""),
    ("gltf_uri_etc_passwd", "put_scene", mesh_scene(gltf_with_uri("/etc/passwd"), "gltf"), C.INVALID_ARGUMENT, "could not open referenced file"),
    ("gltf_uri_absolute_missing", "put_scene", mesh_scene(gltf_with_uri("/nonexistent/buffer.bin"), "gltf"), C.INVALID_ARGUMENT, "could not open referenced file"),
    ("gltf_uri_parent", "put_scene", mesh_scene(gltf_with_uri("../../../../../etc/passwd"), "gltf"), C.INVALID_ARGUMENT, "could not open referenced file"),
    ("gltf_uri_proc_self", "put_scene", mesh_scene(gltf_with_uri("/proc/self/environ"), "gltf"), C.INVALID_ARGUMENT, "could not open referenced file"),
    # Digests and blobs.
    ("mesh_digest_not_hex", "put_scene", scene_with(lambda s: (setattr(s.obstacles[0].shape.mesh.digest, "sha256", "zz" * 32), setattr(s.obstacles[0].shape.mesh, "format", "obj"))), C.INVALID_ARGUMENT, "mesh.digest.sha256"),
    ("mesh_digest_unknown", "put_scene", scene_with(lambda s: (s.obstacles[0].shape.mesh.digest.CopyFrom(digest(b"never uploaded")), setattr(s.obstacles[0].shape.mesh, "format", "obj"))), C.NOT_FOUND, "mesh.digest"),
    ("mesh_digest_negative_size", "put_scene", scene_with(lambda s: (s.obstacles[0].shape.mesh.digest.CopyFrom(scene_pb2.Digest(sha256="a" * 64, size_bytes=-1)), setattr(s.obstacles[0].shape.mesh, "format", "obj"))), C.INVALID_ARGUMENT, "size_bytes"),
    ("upload_wrong_sha", "upload", (scene_pb2.Digest(sha256="0" * 64, size_bytes=5), [b"hello"]), C.INVALID_ARGUMENT, "digest.sha256"),
    ("upload_more_than_declared", "upload", (digest(b"hi"), [b"hello"]), C.INVALID_ARGUMENT, "digest.size_bytes"),
    ("upload_less_than_declared", "upload", (scene_pb2.Digest(sha256=hashlib.sha256(b"hello").hexdigest(), size_bytes=9), [b"hello"]), C.INVALID_ARGUMENT, "digest.size_bytes"),
    ("upload_oversized_declared", "upload", (scene_pb2.Digest(sha256="a" * 64, size_bytes=1 << 60), [b""]), C.RESOURCE_EXHAUSTED, "digest.size_bytes"),
    ("upload_sha_uppercase", "upload", (scene_pb2.Digest(sha256="A" * 64, size_bytes=1), [b"x"]), C.INVALID_ARGUMENT, "digest.sha256"),
    ("upload_empty_stream", "upload", (None, []), C.INVALID_ARGUMENT, "digest"),
    ("session_scene_unknown", "session", digest(b"no such scene"), C.NOT_FOUND, "scene"),
    ("session_scene_digest_bad", "session", scene_pb2.Digest(sha256="not hex", size_bytes=3), C.INVALID_ARGUMENT, "scene.sha256"),
    # Names.
    ("merge_session_unknown", "merge_session", "sessions/" + "0" * 32, C.NOT_FOUND, "session"),
    ("merge_session_malformed", "merge_session", "sessions/does-not-exist", C.INVALID_ARGUMENT, "session"),
    ("merge_session_newline", "merge_session", "sessions/x\nFORGED LOG LINE", C.INVALID_ARGUMENT, "session"),
    ("merge_session_huge_name", "merge_session", "s" * 100000, C.INVALID_ARGUMENT, "session"),
    ("requery_malformed_hgraph", "requery", "sessions/x/hgraphs/y", C.INVALID_ARGUMENT, "hgraph"),
    ("requery_unknown_hgraph", "requery", "sessions/" + "0" * 32 + "/hgraphs/1", C.NOT_FOUND, "hgraph"),
    ("add_paths_malformed_hgraph", "add_paths", "sessions/x/hgraphs/y", C.INVALID_ARGUMENT, "hgraph"),
    ("add_paths_unknown_hgraph", "add_paths", "sessions/" + "0" * 32 + "/hgraphs/1", C.NOT_FOUND, "hgraph"),
    # Waypoints.
    ("waypoint_1e308", "merge", dict(paths=paths_with(lambda p: p.paths[0].waypoints[1].values.__setitem__(0, 1e308))), C.INVALID_ARGUMENT, "paths.paths[0].waypoints[1][0]"),
    ("waypoint_beyond_range", "merge", dict(paths=paths_with(lambda p: p.paths[1].waypoints[2].values.__setitem__(1, -5e9))), C.INVALID_ARGUMENT, "paths.paths[1].waypoints[2][1]"),
    ("waypoint_nan", "merge", dict(paths=paths_with(lambda p: p.paths[0].waypoints[1].values.__setitem__(0, float("nan")))), C.INVALID_ARGUMENT, "paths.paths[0].waypoints[1][0]"),
    ("waypoint_wrong_dimension", "merge", dict(paths=paths_with(lambda p: p.paths[0].waypoints[1].values.append(3))), C.INVALID_ARGUMENT, "paths.paths[0].waypoints[1]"),
    ("path_one_waypoint", "merge", dict(paths=paths_with(lambda p: p.paths[0].waypoints.__delitem__(slice(1, None)))), C.INVALID_ARGUMENT, "paths.paths[0].waypoints"),
    ("paths_empty", "merge", dict(paths=path_pb2.PathSet()), C.INVALID_ARGUMENT, "paths.paths"),
    ("paths_over_limit", "merge", dict(paths=path_pb2.PathSet(paths=[paths().paths[0]] * 9)), C.RESOURCE_EXHAUSTED, "--max-paths"),
    # Merge options.
    ("resolution_1e-12", "merge", merge_req(resolution=1e-12), C.INVALID_ARGUMENT, "options.resolution"),
    ("resolution_zero", "merge", merge_req(resolution=0), C.INVALID_ARGUMENT, "options.resolution"),
    ("resolution_above_one", "merge", merge_req(resolution=2), C.INVALID_ARGUMENT, "options.resolution"),
    ("gap_extend_1e308", "merge", merge_req(gap_extend=1e308), C.INVALID_ARGUMENT, "options.gap_extend"),
    ("gap_init_1e308", "merge", merge_req(gap_init=1e308), C.INVALID_ARGUMENT, "options.gap_init"),
    ("gap_init_negative", "merge", merge_req(gap_init=-1), C.INVALID_ARGUMENT, "options.gap_init"),
    ("radius_1e308", "merge", merge_req(variant=merge_pb2.VARIANT_NEIGHBORHOOD, radius=1e308), C.INVALID_ARGUMENT, "options.radius"),
    ("radius_negative", "merge", merge_req(radius=-3), C.INVALID_ARGUMENT, "options.radius"),
    ("phi_zero", "merge", merge_req(variant=merge_pb2.VARIANT_K_NEAREST, phi=0), C.INVALID_ARGUMENT, "options.phi"),
    ("phi_huge", "merge", merge_req(variant=merge_pb2.VARIANT_K_NEAREST, phi=2000000000), C.INVALID_ARGUMENT, "options.phi"),
    ("variant_unknown", "merge", merge_req(variant=77), C.INVALID_ARGUMENT, "options.variant"),
    ("threads_negative", "merge", merge_req(threads=-1), C.INVALID_ARGUMENT, "options.threads"),
    ("threads_huge", "merge", merge_req(threads=1000000), C.INVALID_ARGUMENT, "options.threads"),
    ("endpoint_tolerance_inf", "merge", merge_req(endpoint_tolerance=float("inf")), C.INVALID_ARGUMENT, "options.endpoint_tolerance"),
    ("node_spacing_tiny", "merge", merge_req(max_node_spacing=1e-9), C.INVALID_ARGUMENT, "options.max_node_spacing"),
    ("node_spacing_many_nodes", "merge", merge_req(max_node_spacing=0.0005), C.INVALID_ARGUMENT, "options.max_node_spacing"),
    ("optimize_ms_1e308", "merge", merge_req(optimize_ms=1e308), C.INVALID_ARGUMENT, "options.optimize_ms"),
    ("optimize_restarts_negative", "merge", merge_req(optimize_restarts=-1), C.INVALID_ARGUMENT, "options.optimize_restarts"),
    ("optimize_restarts_huge", "merge", merge_req(optimize_restarts=2000000000), C.INVALID_ARGUMENT, "options.optimize_restarts"),
    ("evaluation_unknown", "merge", merge_req(evaluation=9), C.INVALID_ARGUMENT, "options.evaluation"),
    ("check_mode_unknown", "merge", merge_req(check_mode=9), C.INVALID_ARGUMENT, "options.check_mode"),
    ("progress_interval_negative", "merge", dict(progress_interval_ms=-5), C.INVALID_ARGUMENT, "progress_interval_ms"),
    # Measures.
    ("k_1e9", "merge", dict(measure=merge_pb2.Measure(type=merge_pb2.Measure.TYPE_INVERSE_CLEARANCE, k=1e9)), C.INVALID_ARGUMENT, "measure.k"),
    ("k_negative", "merge", dict(measure=merge_pb2.Measure(type=merge_pb2.Measure.TYPE_INVERSE_CLEARANCE, k=-1)), C.INVALID_ARGUMENT, "measure.k"),
    ("safety_1e308", "merge", dict(measure=merge_pb2.Measure(type=merge_pb2.Measure.TYPE_SAFE_LENGTH, safety=1e308)), C.INVALID_ARGUMENT, "measure.safety"),
    ("measure_type_unknown", "merge", dict(measure=merge_pb2.Measure(type=42)), C.INVALID_ARGUMENT, "measure.type"),
    # CheckPaths and PlanPaths.
    ("check_resolution_1e-12", "check", dict(resolution=1e-12), C.INVALID_ARGUMENT, "resolution"),
    ("check_k_1e9", "check", dict(k=1e9), C.INVALID_ARGUMENT, "k"),
    ("check_waypoint_1e308", "check", dict(paths=paths_with(lambda p: p.paths[0].waypoints[0].values.__setitem__(1, 1e308))), C.INVALID_ARGUMENT, "waypoints[0][1]"),
    ("plan_count_negative", "plan", dict(count=-4), C.INVALID_ARGUMENT, "count"),
    ("plan_count_over_limit", "plan", dict(count=100000), C.RESOURCE_EXHAUSTED, "count"),
    ("plan_time_1e308", "plan", dict(time_per_path_s=1e308), C.INVALID_ARGUMENT, "time_per_path_s"),
    ("plan_time_nan", "plan", dict(time_per_path_s=float("nan")), C.INVALID_ARGUMENT, "time_per_path_s"),
    ("plan_planner_unknown", "plan", dict(planner="no-such-planner"), C.INVALID_ARGUMENT, "planner"),
    # Client strings: escaped and cut in messages and logs; digests checked in full.
    ("planner_name_100kB", "plan", dict(planner="p" * 100000), C.INVALID_ARGUMENT, "unknown planner"),
    ("session_name_with_newline", "merge_session", "sessions/" + ("\nFORGED log line" + "x" * 32)[:32], C.INVALID_ARGUMENT, "\\nFORGED"),
    ("session_name_100kB", "merge_session", "sessions/" + "a" * 100000, C.INVALID_ARGUMENT, "bytes, cut"),
    ("hgraph_name_with_nul", "requery", "sessions/" + "0" * 32 + "/hgraphs/\x001", C.INVALID_ARGUMENT, "\\0"),
    ("scene_digest_wrong_size", "session", lambda stub: wrong_size(stub), C.INVALID_ARGUMENT, "scene.size_bytes"),
    ("plan_start_1e308", "plan", dict(start=space_pb2.Configuration(values=[1e308, 1]), goal=space_pb2.Configuration(values=[70, 70])), C.INVALID_ARGUMENT, "start"),
    # Solve (start and goal are the circles inputs' unless a case sets them).
    ("solve_budget_negative", "solve", dict(budget_s=-1), C.INVALID_ARGUMENT, "budget_s"),
    ("solve_budget_1e308", "solve", dict(budget_s=1e308), C.INVALID_ARGUMENT, "budget_s"),
    ("solve_budget_nan", "solve", dict(budget_s=float("nan")), C.INVALID_ARGUMENT, "budget_s"),
    ("solve_planner_unknown", "solve", dict(portfolio=[service_pb2.PortfolioEntry(planner="no-such-planner")]), C.INVALID_ARGUMENT, "portfolio[0].planner"),
    ("solve_planner_name_100kB", "solve", dict(portfolio=[service_pb2.PortfolioEntry(planner="p" * 100000)]), C.INVALID_ARGUMENT, "unknown planner"),
    ("solve_runs_negative", "solve", dict(portfolio=[service_pb2.PortfolioEntry(planner="prm", runs=-1)]), C.INVALID_ARGUMENT, "portfolio[0].runs"),
    ("solve_runs_2e9", "solve", dict(portfolio=[service_pb2.PortfolioEntry(planner="prm", runs=2000000000)]), C.INVALID_ARGUMENT, "portfolio[0].runs"),
    ("solve_runs_over_max_paths", "solve", dict(portfolio=[service_pb2.PortfolioEntry(planner="prm", runs=5), service_pb2.PortfolioEntry(planner="rrt", runs=5)]), C.RESOURCE_EXHAUSTED, "portfolio"),
    ("solve_plan_fraction_2", "solve", dict(plan_fraction=2.0), C.INVALID_ARGUMENT, "plan_fraction"),
    ("solve_plan_fraction_nan", "solve", dict(plan_fraction=float("nan")), C.INVALID_ARGUMENT, "plan_fraction"),
    ("solve_parallel_negative", "solve", dict(parallel=-3), C.INVALID_ARGUMENT, "parallel"),
    ("solve_optimize_ms_set", "solve", dict(options=merge_pb2.MergeOptions(optimize_ms=100)), C.INVALID_ARGUMENT, "options.optimize_ms"),
    ("solve_resolution_1e-12", "solve", dict(options=merge_pb2.MergeOptions(resolution=1e-12)), C.INVALID_ARGUMENT, "resolution"),
    ("solve_start_in_collision", "solve", dict(start=space_pb2.Configuration(values=[27, 15])), C.INVALID_ARGUMENT, "start"),
    ("solve_goal_wrong_dimension", "solve", dict(goal=space_pb2.Configuration(values=[1, 2, 3])), C.INVALID_ARGUMENT, "goal"),
    ("solve_start_1e308", "solve", dict(start=space_pb2.Configuration(values=[1e308, 1])), C.INVALID_ARGUMENT, "start"),
    ("solve_measure_k_1e9", "solve", dict(measure=merge_pb2.Measure(type=merge_pb2.Measure.TYPE_INVERSE_CLEARANCE, k=1e9)), C.INVALID_ARGUMENT, "measure.k"),
]


# ---------------------------------------------------------------------------------------------
# Running a case


@pytest.fixture(scope="module")
def server():
    s = Server("--max-paths", "8", "--cache-bytes", str(32 << 20), "--mesh-import-memory-mb",
               "256", "--mesh-import-timeout-s", "20")
    yield s
    assert s.stop() == 0, "".join(s.log)


@pytest.fixture(scope="module")
def stubs(server):
    channel = grpc.insecure_channel(server.target)
    grpc.channel_ready_future(channel).result(timeout=10)
    stub = service_pb2_grpc.PathMergerStub(channel)
    scene = stub.PutScene(service_pb2.PutSceneRequest(scene=circles_scene()), timeout=TIMEOUT_S)
    session = stub.CreateSession(service_pb2.CreateSessionRequest(scene=scene.digest),
                                 timeout=TIMEOUT_S)
    # Raw bytes: HealthCheckRequest{service: "hgraph.v1.PathMerger"} (Debian ships no
    # grpc_health module).
    yield stub, channel.unary_unary("/grpc.health.v1.Health/Check"), session.name
    channel.close()


def set_fields(request, fields):
    """Sets each field of `fields` on `request`: scalars assigned, messages copied. Returns it."""
    for key, v in fields.items():
        if isinstance(v, (int, float, str)):
            setattr(request, key, v)
        elif isinstance(v, list):
            getattr(request, key).extend(v)
        else:
            getattr(request, key).CopyFrom(v)
    return request


def run(stub, session, call, value):
    if call == "put_scene":
        stub.PutScene(service_pb2.PutSceneRequest(scene=value), timeout=TIMEOUT_S)
    elif call == "merge" or call == "merge_session":
        request = service_pb2.MergePathsRequest(session=session, paths=paths())
        if call == "merge_session":
            request.session = value
        else:
            set_fields(request, value)
        for _ in stub.MergePaths(request, timeout=TIMEOUT_S):
            pass
    elif call == "check":
        request = set_fields(service_pb2.CheckPathsRequest(session=session, paths=paths()), value)
        stub.CheckPaths(request, timeout=TIMEOUT_S)
    elif call == "plan":
        request = set_fields(service_pb2.PlanPathsRequest(session=session, time_per_path_s=0.2),
                             value)
        for _ in stub.PlanPaths(request, timeout=TIMEOUT_S):
            pass
    elif call == "solve":
        ends = paths().paths[0].waypoints
        request = service_pb2.SolveRequest(session=session, budget_s=0.2)
        request.start.CopyFrom(space_pb2.Configuration(values=ends[0].values))
        request.goal.CopyFrom(space_pb2.Configuration(values=ends[-1].values))
        for _ in stub.Solve(set_fields(request, value), timeout=TIMEOUT_S):
            pass
    elif call == "upload":
        declared, chunks = value
        messages = []
        for i, data in enumerate(chunks):
            m = service_pb2.UploadBlobRequest(data=data)
            if i == 0 and declared is not None:
                m.digest.CopyFrom(declared)
            messages.append(m)
        stub.UploadBlob(iter(messages), timeout=TIMEOUT_S)
    elif call == "session":
        stub.CreateSession(service_pb2.CreateSessionRequest(scene=value), timeout=TIMEOUT_S)
    elif call == "requery":
        stub.Requery(service_pb2.RequeryRequest(hgraph=value), timeout=TIMEOUT_S)
    elif call == "add_paths":
        stub.AddPaths(service_pb2.AddPathsRequest(hgraph=value, paths=paths()), timeout=TIMEOUT_S)
    else:
        raise AssertionError(call)


def outcome(stub, session, call, value):
    try:
        run(stub, session, call, value)
        return C.OK, ""
    except grpc.RpcError as e:
        return e.code(), e.details()


def assert_still_serving(server, stub, health, session):
    assert server.proc.poll() is None, "the server died:\n" + "".join(server.log[-30:])
    service = b"hgraph.v1.PathMerger"
    # HealthCheckResponse{status: SERVING} is field 1 = 1.
    assert health(b"\x0a" + bytes([len(service)]) + service, timeout=10) == b"\x08\x01"
    result = None
    for event in stub.MergePaths(service_pb2.MergePathsRequest(session=session, paths=paths()),
                                 timeout=TIMEOUT_S):
        if event.HasField("result"):
            result = event.result
    assert result is not None and len(result.path.waypoints) >= 2
    assert result.inputs[result.best_input].valid


def test_catalogue_has_every_class():
    assert len(CASES) >= 60
    names = {c[0] for c in CASES}
    for required in ["off_truncated_33_bytes", "off_face_index_past_vertices",
                     "ply_header_stops_after_format", "ply_binary_cut_short",
                     "off_claims_1e9_vertices", "ply_claims_2e7_vertices", "zae_zip_bomb",
                     "obj_mtllib_absolute", "obj_mtllib_parent", "gltf_uri_etc_passwd",
                     "gltf_uri_parent", "waypoint_1e308", "resolution_1e-12", "gap_extend_1e308",
                     "bounds_1e308", "k_1e9", "node_spacing_many_nodes"]:
        assert required in names


@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_bad_input(server, stubs, case):
    name, call, value, code, fragment = case
    stub, health, session = stubs
    if name == "zae_zip_bomb":
        value = mesh_scene(zae_bomb(), "zae")
    if callable(value):
        value = value(stub)
    got_code, message = outcome(stub, session, call, value)
    assert got_code == code, f"{name}: {got_code} {message!r}"
    assert fragment in message, f"{name}: {message!r}"
    # Client strings are not echoed whole into messages, nor raw.
    assert len(message) < 4000
    assert "\n" not in message and "\0" not in message
    assert_still_serving(server, stub, health, session)


def test_referenced_names_are_indistinguishable(stubs):
    """Whether a name inside a mesh exists on the server must not show in the answer."""
    stub, _, _ = stubs
    answers = []
    # Names of the same length, so that the messages' byte counts agree.
    for uri in ["/etc/passwd", "/etc/nofile"]:
        code, message = outcome(stub, None, "put_scene", mesh_scene(gltf_with_uri(uri), "gltf"))
        answers.append((code, message.replace(uri, "NAME")))
    assert answers[0] == answers[1]
    for name in ["/etc/passwd", "/etc/nofile"]:
        assert outcome(stub, None, "put_scene", mesh_scene(obj_with_mtllib(name), "obj"))[0] == C.OK


def test_valid_meshes_still_load(stubs):
    stub, _, _ = stubs
    for data, fmt in [(OFF_TETRA, "off"), (ply_tetra_binary(), "ply"), (gltf_embedded(), "gltf")]:
        assert outcome(stub, None, "put_scene", mesh_scene(data, fmt)) == (C.OK, ""), fmt
