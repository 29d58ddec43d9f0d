#!/usr/bin/env python3
"""Integration tests of the hgraph CLI: runs the real binary on the OMPL circles problem and on
bad inputs. Usage: cli_test.py --hgraph BIN --data tests/data --work DIR CASE, or --list.

Exit codes under test: 0 success, 1 `check` found an invalid edge, 2 bad input with one
"error: <field>: <problem>" line on stderr.
"""
import argparse
import json
import pathlib
import shutil
import subprocess
import sys

CASES = {}


def case(fn):
    CASES[fn.__name__] = fn
    return fn


class Failure(Exception):
    pass


def expect(condition, message):
    if not condition:
        raise Failure(message)


class Env:
    def __init__(self, hgraph, data, work):
        self.hgraph = hgraph
        self.data = data
        self.work = work
        self.scene = str(data / "circles" / "scene.json")
        self.paths = str(data / "circles" / "paths.txt")

    def run(self, *args):
        cmd = [self.hgraph, *[str(a) for a in args]]
        proc = subprocess.run(cmd, cwd=self.work, capture_output=True, text=True, timeout=240)
        print("$", " ".join(cmd), "->", proc.returncode)
        print(proc.stdout, end="")
        print(proc.stderr, end="", file=sys.stderr)
        return proc

    def write(self, name, contents):
        path = self.work / name
        path.write_text(contents if isinstance(contents, str) else json.dumps(contents, indent=1))
        return str(path)

    def circle_paths(self):
        """The two input paths as lists of [x, y]."""
        paths, current = [], []
        for line in pathlib.Path(self.paths).read_text().splitlines():
            line = line.split("#")[0].strip()
            if not line:
                if current:
                    paths.append(current)
                current = []
                continue
            current.append([float(v) for v in line.split()])
        if current:
            paths.append(current)
        return paths

    def path_set(self, paths):
        return {"paths": [{"name": "p%d" % i, "waypoints": [{"values": q} for q in p]}
                          for i, p in enumerate(paths)]}

    def expect_bad_input(self, proc, field):
        expect(proc.returncode == 2, "expected exit 2, got %d" % proc.returncode)
        lines = [l for l in proc.stderr.splitlines() if l.strip()]
        expect(lines, "no message on stderr")
        last = lines[-1]
        expect(last.startswith("error: "), "last stderr line is not 'error: ...': %r" % last)
        expect(field in last, "error does not name %r: %r" % (field, last))
        errors = [l for l in lines if l.startswith("error: ")]
        expect(len(errors) == 1, "expected one error line, got %r" % errors)

    def merge_bad(self, field, *extra, paths=None, scene=None):
        proc = self.run("merge", "--scene", scene or self.scene, "--paths", paths or self.paths,
                        "--out", "result.json", *extra)
        self.expect_bad_input(proc, field)


def check_result(env, result, measure_key="length"):
    inputs = result["inputs"]
    expect(len(inputs) == 2, "expected 2 input reports")
    expect(all(i["valid"] for i in inputs), "the OMPL input paths should be valid")
    path = result["path"]["waypoints"]
    expect(len(path) >= 2, "merged path has fewer than 2 waypoints")
    first, last = env.circle_paths()[0][0], env.circle_paths()[0][-1]
    expect(path[0]["values"] == first and path[-1]["values"] == last,
           "merged path does not keep the shared start and goal")
    for key in ("length", "min_clearance", "avg_clearance", "inverse_clearance"):
        expect(key in result["quality"], "quality has no %s" % key)
    for key in ("stats", "timing", "source_path", "source_index"):
        expect(key in result, "result has no %s" % key)
    return path


def check_path_valid(env, waypoints, name):
    pathset = env.write(name, {"paths": [{"name": "merged",
                                          "waypoints": [{"values": w["values"]} for w in waypoints]}]})
    proc = env.run("check", "--scene", env.scene, "--paths", pathset)
    expect(proc.returncode == 0, "check rejected the merged path: exit %d" % proc.returncode)
    expect("valid" in proc.stdout, "check printed no verdict")


@case
def merge_circles_shorter_than_both(env):
    proc = env.run("merge", "--scene", env.scene, "--paths", env.paths, "--out", "result.json",
                   "--out-path", "merged.txt", "--threads", "2")
    expect(proc.returncode == 0, "merge failed: exit %d" % proc.returncode)
    result = json.loads((env.work / "result.json").read_text())
    path = check_result(env, result)
    length = result["quality"]["length"]
    input_lengths = [i["quality"]["length"] for i in result["inputs"]]
    expect(all(length < l - 1e-9 for l in input_lengths),
           "merged length %g is not below both inputs %r" % (length, input_lengths))
    expect("merged" in proc.stdout and "timing" in proc.stdout, "no summary table on stdout")
    check_path_valid(env, path, "merged.json")
    # --out-path writes the same path in the text format.
    proc = env.run("check", "--scene", env.scene, "--paths", "merged.txt")
    expect(proc.returncode == 0, "check rejected merged.txt")


@case
def merge_every_variant_and_measure(env):
    runs = [
        ("all-pairs", "length", []),
        ("neighborhood", "length", ["--radius", "10"]),
        ("knn", "inverse-clearance", ["--phi", "4", "--k", "2"]),
        ("edit-distance", "bottleneck-clearance", ["--gap-init", "4", "--gap-extend", "2"]),
        ("edit-distance-neighborhood", "safe-length", ["--safety", "0.05"]),
    ]
    for variant, measure, extra in runs:
        proc = env.run("merge", "--scene", env.scene, "--paths", env.paths, "--variant", variant,
                       "--measure", measure, "--out", "result.json", "--quiet", *extra)
        expect(proc.returncode == 0, "%s/%s failed: exit %d" % (variant, measure, proc.returncode))
        result = json.loads((env.work / "result.json").read_text())
        path = check_result(env, result)
        best = min(i["quality"]["length"] for i in result["inputs"])
        if measure == "length":
            expect(result["quality"]["length"] <= best + 1e-9,
                   "%s: merged path longer than the best input" % variant)
        check_path_valid(env, path, "merged_%s.json" % variant)


@case
def merge_accepts_pathset_json(env):
    pathset = env.write("paths.json", env.path_set(env.circle_paths()))
    proc = env.run("merge", "--scene", env.scene, "--paths", pathset, "--out", "result.json")
    expect(proc.returncode == 0, "merge failed on PathSet JSON: exit %d" % proc.returncode)
    result = json.loads((env.work / "result.json").read_text())
    expect([i["name"] for i in result["inputs"]] == ["p0", "p1"], "input names not kept")


@case
def check_accepts_the_inputs(env):
    proc = env.run("check", "--scene", env.scene, "--paths", env.paths)
    expect(proc.returncode == 0, "check rejected the OMPL inputs: exit %d" % proc.returncode)


@case
def check_names_the_first_invalid_edge(env):
    # Straight through disc6 (centre 39, 44.5, radius 6) between two free points.
    paths = env.circle_paths() + [[[30.0, 44.5], [31.0, 44.5], [48.0, 44.5]]]
    pathset = env.write("paths.json", {"paths": [
        {"name": "ok", "waypoints": [{"values": q} for q in paths[0]]},
        {"name": "through", "waypoints": [{"values": q} for q in paths[2]]}]})
    proc = env.run("check", "--scene", env.scene, "--paths", pathset)
    expect(proc.returncode == 1, "expected exit 1, got %d" % proc.returncode)
    expect("path 'through' (index 1): edge 1 -> 2 is in collision at t=" in proc.stdout,
           "invalid edge not named")


@case
def error_wrong_dimension(env):
    paths = env.circle_paths()
    paths[0][1] = paths[0][1] + [0.0]
    env.merge_bad("paths[0].waypoints[1]", paths=env.write("p.json", env.path_set(paths)))
    text = env.write("p.txt", "30 62\n31 50 7\n")
    env.merge_bad("p.txt:2", paths=text)


@case
def error_nan(env):
    paths = env.path_set(env.circle_paths())
    paths["paths"][1]["waypoints"][2]["values"][1] = "NaN"
    env.merge_bad("paths[1].waypoints[2]", paths=env.write("p.json", paths))
    env.merge_bad("p.txt:1", paths=env.write("p.txt", "30 nan\n67 35\n"))


@case
def error_non_numeric_text(env):
    env.merge_bad("p.txt:3", paths=env.write("p.txt", "30 62\n\n31 abc\n"))


@case
def error_endpoints_differ(env):
    paths = env.circle_paths()
    paths[1][-1] = [66.0, 35.0]
    env.merge_bad("paths[1].waypoints[%d]" % (len(paths[1]) - 1),
                  paths=env.write("p.json", env.path_set(paths)))


@case
def error_no_paths(env):
    env.merge_bad("paths", paths=env.write("p.json", {"paths": []}))
    proc = env.run("check", "--scene", env.scene, "--paths", env.write("e.json", {"paths": []}))
    env.expect_bad_input(proc, "paths")


@case
def error_one_node_path(env):
    paths = env.circle_paths()
    env.merge_bad("paths[0].waypoints", paths=env.write("p.json", env.path_set([paths[0][:1]])))


def scene_with_mesh(env, mesh_path):
    scene = json.loads(pathlib.Path(env.scene).read_text())
    scene["obstacles"].append({"name": "mesh", "shape": {"mesh": {"path": mesh_path}}})
    return env.write("scene.json", scene)


@case
def error_missing_mesh_file(env):
    scene = scene_with_mesh(env, "meshes/missing.obj")
    env.merge_bad("scene.obstacles[70].shape.mesh.path", scene=scene)
    proc = env.run("check", "--scene", scene, "--paths", env.paths)
    env.expect_bad_input(proc, "scene.obstacles[70].shape.mesh.path")
    expect("missing.obj" in proc.stderr, "the missing file is not named")


@case
def error_corrupt_mesh(env):
    env.write("corrupt.stl", "solid x\nfacet normal nonsense\n\x01\x02 garbage\n")
    env.merge_bad("scene.obstacles[70].shape.mesh.path", scene=scene_with_mesh(env, "corrupt.stl"))


@case
def error_unknown_scene_field(env):
    scene = json.loads(pathlib.Path(env.scene).read_text())
    scene["robots"] = []
    path = env.write("scene.json", scene)
    env.merge_bad(path, scene=path)


@case
def error_missing_scene_file(env):
    env.merge_bad("nowhere.json", scene="nowhere.json")


@case
def error_unknown_variant(env):
    env.merge_bad("--variant", "--variant", "fastest")


@case
def error_unknown_measure(env):
    env.merge_bad("--measure", "--measure", "shortest")


@case
def error_negative_parameters(env):
    env.merge_bad("measure.k", "--measure", "inverse-clearance", "--k", "-1")
    env.merge_bad("options.radius", "--variant", "neighborhood", "--radius", "-2")
    env.merge_bad("measure.safety", "--measure", "safe-length", "--safety", "-0.5")
    env.merge_bad("options.resolution", "--resolution", "-0.01")
    env.merge_bad("options.resolution", "--resolution", "0")
    proc = env.run("check", "--scene", env.scene, "--paths", env.paths, "--resolution", "-1")
    env.expect_bad_input(proc, "resolution")


@case
def error_bad_flags(env):
    proc = env.run("merge", "--scene", env.scene)
    expect(proc.returncode == 2, "missing --paths should exit 2, got %d" % proc.returncode)
    proc = env.run("frobnicate")
    expect(proc.returncode == 2, "unknown subcommand should exit 2, got %d" % proc.returncode)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--list", action="store_true")
    parser.add_argument("--hgraph")
    parser.add_argument("--data")
    parser.add_argument("--work")
    parser.add_argument("case", nargs="?")
    args = parser.parse_args()
    if args.list:
        print("\n".join(CASES))
        return 0
    if args.case not in CASES:
        print("unknown case %r" % args.case, file=sys.stderr)
        return 2
    work = pathlib.Path(args.work).resolve() / args.case
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir(parents=True)
    env = Env(str(pathlib.Path(args.hgraph).resolve()), pathlib.Path(args.data).resolve(), work)
    try:
        CASES[args.case](env)
    except Failure as e:
        print("FAIL %s: %s" % (args.case, e), file=sys.stderr)
        return 1
    print("PASS", args.case)
    return 0


if __name__ == "__main__":
    sys.exit(main())
