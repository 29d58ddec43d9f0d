#!/usr/bin/env python3
"""Integration tests of the hgraph CLI: runs the real binary on the OMPL circles problem and on
bad inputs, in process and through a real hgraph-server on a loopback port (--server).
Usage: cli_test.py --hgraph BIN [--server-bin BIN] --data tests/data --work DIR CASE, or --list.

Exit codes under test: 0 success, 1 `check` found an invalid edge or `plan` found fewer paths
than asked, 2 bad input with one "error: <field>: <problem>" line on stderr, 3 the server was
unreachable or failed.
"""
import argparse
import json
import pathlib
import re
import shutil
import subprocess
import sys

from server_process import IgnoredSigterm, ServerDidNotStart, ServerProcess

CASES = {}


def case(fn):
    CASES[fn.__name__] = fn
    return fn


class Failure(Exception):
    pass


class Skip(Exception):
    """The case needs something this build does not have (CTest's SKIP_RETURN_CODE)."""


SKIP_RETURN_CODE = 77


def expect(condition, message):
    if not condition:
        raise Failure(message)


class Server(ServerProcess):
    """hgraph-server on 127.0.0.1, a port it picks itself; a context manager that stops it with
    SIGTERM and expects exit 0."""

    def __init__(self, binary):
        if not binary:
            raise Skip("this case needs hgraph-server (--server-bin)")
        try:
            super().__init__(binary, "--listen", "127.0.0.1:0", "--metrics-listen", "",
                             "--threads", "2", "--drain-s", "0")
        except ServerDidNotStart as e:
            raise Failure(str(e)) from None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        try:
            code = self.stop(timeout=30)
        except IgnoredSigterm as e:
            raise Failure(str(e)) from None
        if exc[0] is None:
            expect(code == 0, "server exited %d: %s" % (code, "".join(self.log)))


class Env:
    def __init__(self, hgraph, data, work, server_bin=None):
        self.hgraph = hgraph
        self.data = data
        self.work = work
        self.server_bin = server_bin
        self.scene = str(data / "circles" / "scene.json")
        self.paths = str(data / "circles" / "paths.txt")

    def server(self):
        return Server(self.server_bin)

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
    expect("length" in result["quality"], "quality has no length")
    # The clearances are present exactly when known (PathQuality.has_clearance).
    known = result["quality"].get("has_clearance", False)
    for key in ("min_clearance", "avg_clearance", "inverse_clearance"):
        expect((key in result["quality"]) == known,
               "quality %s %s although has_clearance is %s" %
               ("has" if key in result["quality"] else "lacks", key, known))
    for key in ("stats", "timing", "source_path", "source_index"):
        expect(key in result, "result has no %s" % key)
    return path


def check_path_valid(env, waypoints, name):
    pathset = env.write(name, {"paths": [{"name": "merged",
                                          "waypoints": [{"values": w["values"]} for w in waypoints]}]})
    proc = env.run("check", "--scene", env.scene, "--paths", pathset)
    expect(proc.returncode == 0, "check rejected the merged path: exit %d" % proc.returncode)
    expect("valid" in proc.stdout, "check printed no verdict")


def mask_check_counts(line):
    """A line with its counts of collision checks and distance queries masked (a merge's stats,
    check's summary): a motion's samples and certificate may be shared by two threads, and how
    many run past the answer depends on their timing (the answer does not)."""
    return re.sub(r"\d+ (collision checks|distance queries)", r"<masked> \1", line)


SUBCOMMANDS = ["merge", "check", "plan", "solve", "render", "import-cfg", "requery", "add-paths", "health"]


@case
def every_subcommand_takes_quiet(env):
    """-q/--quiet is a common flag: every subcommand lists it, and `requery -q` (once refused
    with "argument was not expected") prints what `requery` prints."""
    for sub in SUBCOMMANDS:
        proc = env.run(sub, "--help")
        expect(proc.returncode == 0, "%s --help: exit %d" % (sub, proc.returncode))
        expect("-q,--quiet" in proc.stdout, "%s does not list -q,--quiet" % sub)
    with env.server() as server:
        merged = env.run("merge", "-q", "--server", server.target, "--scene", env.scene,
                         "--paths", env.paths)
        expect(merged.returncode == 0, "merge failed: exit %d" % merged.returncode)
        hgraph = re.search(r"^hgraph (sessions/[0-9a-f]+/hgraphs/\S+)", merged.stdout,
                           re.M).group(1)
        loud = env.run("requery", "--server", server.target, "--hgraph", hgraph, "--measure",
                       "length")
        quiet = env.run("requery", "-q", "--server", server.target, "--hgraph", hgraph,
                        "--measure", "length")
        expect(loud.returncode == 0, "requery failed: exit %d" % loud.returncode)
        expect(quiet.returncode == 0, "requery -q failed: exit %d: %s" %
               (quiet.returncode, quiet.stderr))
        expect("not expected" not in quiet.stderr, "requery -q refused: %s" % quiet.stderr)
        # The same answer (a requery's is a function of the H-Graph and the measure); only the
        # wall times and the counts of checks differ (see mask_check_counts).
        def answer(text):
            return [mask_check_counts(l) for l in text.splitlines() if not l.startswith("timing")]
        expect(answer(quiet.stdout) == answer(loud.stdout), "requery -q printed another result")


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
    env.merge_bad("--restarts", "--restarts", "-1")
    proc = env.run("check", "--scene", env.scene, "--paths", env.paths, "--resolution", "-1")
    env.expect_bad_input(proc, "resolution")


@case
def errors_name_the_flag_that_set_the_field(env):
    """Every flag that fills a request field is registered with it (client/cli/request_flags.h):
    an error about the field names the flag too, in every subcommand that takes it."""
    for field, flag, extra in (
            ("options.radius", "--radius", ["--variant", "neighborhood", "--radius", "-2"]),
            ("options.phi", "--phi", ["--variant", "knn", "--phi", "0"]),
            ("options.gap_init", "--gap-init", ["--gap-init", "-1"]),
            ("options.gap_extend", "--gap-extend", ["--gap-extend", "-1"]),
            ("options.resolution", "--resolution", ["--resolution", "2"]),
            ("options.endpoint_tolerance", "--endpoint-tolerance",
             ["--endpoint-tolerance", "-1"]),
            ("options.max_node_spacing", "--max-node-spacing", ["--max-node-spacing", "-1"]),
            ("options.optimize_ms", "--optimize-ms", ["--optimize-ms", "-5"]),
            ("options.optimize_restarts", "--restarts", ["--restarts", "-1"]),
            ("options.threads", "--threads", ["--threads", "-1"]),
            ("measure.k", "--k", ["--measure", "inverse-clearance", "--k", "-1"]),
            ("measure.safety", "--safety", ["--measure", "safe-length", "--safety", "-1"])):
        env.merge_bad("%s (%s)" % (field, flag), *extra)
    proc = env.run("check", "--scene", env.scene, "--paths", env.paths, "--resolution", "-1")
    env.expect_bad_input(proc, "options.resolution (--resolution)")
    proc = env.run("plan", "--scene", str(circles_scene(env)), "--resolution", "-1")
    env.expect_bad_input(proc, "resolution (--resolution)")
    proc = env.run("plan", "--scene", str(circles_scene(env)), "--planner", "none")
    env.expect_bad_input(proc, "planner (--planner)")


@case
def error_bad_flags(env):
    proc = env.run("merge", "--scene", env.scene)
    expect(proc.returncode == 2, "missing --paths should exit 2, got %d" % proc.returncode)
    proc = env.run("frobnicate")
    expect(proc.returncode == 2, "unknown subcommand should exit 2, got %d" % proc.returncode)


def through_disc(env):
    """The first OMPL path, and a path straight through disc6 (centre 39, 44.5, radius 6)."""
    paths = env.circle_paths()
    return env.write("through.json", {"paths": [
        {"name": "ok", "waypoints": [{"values": q} for q in paths[0]]},
        {"name": "through", "waypoints": [{"values": q} for q in
                                          [[30.0, 44.5], [31.0, 44.5], [48.0, 44.5]]]}]})


@case
def check_prints_length_and_clearance(env):
    proc = env.run("check", "--scene", env.scene, "--paths", env.paths)
    expect(proc.returncode == 0, "check failed: exit %d" % proc.returncode)
    lines = [l for l in proc.stdout.splitlines() if l.startswith("path ")]
    expect(len(lines) == 2, "expected one line per path: %r" % lines)
    for line in lines:
        expect(re.search(r": valid, \d+ waypoints, length [0-9.]+, min clearance 0\.[0-9]+", line),
               "no length and min clearance: %r" % line)
    expect("2 of 2 paths valid (certified check" in proc.stdout, "no summary")
    sampled = env.run("check", "--scene", env.scene, "--paths", env.paths, "--sampled")
    expect(sampled.returncode == 0, "check --sampled failed")
    expect("(sampled check" in sampled.stdout and "0 distance queries" in sampled.stdout,
           "--sampled ran distance queries")


@case
def check_rejects_what_merge_rejects(env):
    # At resolution 0.05 (steps of 5.66) this edge is sampled at x = 32, 37.5 and 43, all free;
    # between 37.5 and 43 it cuts the disc at (40, 60) of radius 2, 1 from its centre. The
    # sampled check passes it; the certified check, like a merge, finds the collision.
    pathset = env.write("graze.json", {"paths": [
        {"name": "graze", "waypoints": [{"values": [32.0, 61.0]}, {"values": [43.0, 61.0]}]}]})
    sampled = env.run("check", "--scene", env.scene, "--paths", pathset, "--resolution", "0.05",
                      "--sampled")
    expect(sampled.returncode == 0, "the sampled check should pass it: exit %d" % sampled.returncode)
    certified = env.run("check", "--scene", env.scene, "--paths", pathset, "--resolution", "0.05")
    expect(certified.returncode == 1, "the certified check should reject it: exit %d"
           % certified.returncode)
    expect("path 'graze' (index 0): edge 0 -> 1 is in collision at t=" in certified.stdout,
           "invalid edge not named")
    merged = env.run("merge", "--scene", env.scene, "--paths", pathset, "--resolution", "0.05",
                     "--out", "r.json", "-q")
    expect(merged.returncode == 2, "a merge of the one invalid path should fail: exit %d"
           % merged.returncode)


@case
def check_server_same_lines_and_exit_codes(env):
    with env.server() as server:
        for paths, code in ((env.paths, 0), (through_disc(env), 1)):
            local = env.run("check", "--scene", env.scene, "--paths", paths)
            remote = env.run("check", "--server", server.target, "--scene", env.scene,
                             "--paths", paths)
            expect(local.returncode == code, "in process: exit %d" % local.returncode)
            expect(remote.returncode == code, "--server: exit %d" % remote.returncode)
            expect(list(map(mask_check_counts, remote.stdout.splitlines())) ==
                   list(map(mask_check_counts, local.stdout.splitlines())),
                   "--server printed other lines:\n%s\nvs\n%s" % (remote.stdout, local.stdout))
            expect("session sessions/" in remote.stderr, "no session on stderr")
        expect("path 'through' (index 1): edge 1 -> 2 is in collision at t=" in remote.stdout,
               "invalid edge not named")
        session = re.search(r"session (sessions/\S+)", remote.stderr).group(1)
        again = env.run("check", "--server", server.target, "--session", session, "--scene",
                        env.scene, "--paths", env.paths, "--sampled")
        expect(again.returncode == 0 and "session " + session in again.stderr,
               "--session was not reused")
        expect("(sampled check" in again.stdout, "--sampled not passed on")


@case
def check_server_unknown_session(env):
    with env.server() as server:
        proc = env.run("check", "--server", server.target, "--session", "sessions/" + "0" * 32,
                       "--scene", env.scene, "--paths", env.paths)
        expect(proc.returncode == 2, "expected exit 2, got %d" % proc.returncode)
        expect("NOT_FOUND" in proc.stderr, "no NOT_FOUND: %r" % proc.stderr)


@case
def render_server_equals_in_process(env):
    with env.server() as server:
        env.run("render", "--scene", env.scene, "--paths", through_disc(env), "--svg", "local.svg")
        proc = env.run("render", "--server", server.target, "--scene", env.scene, "--paths",
                       through_disc(env), "--svg", "remote.svg")
        expect(proc.returncode == 0, "render --server failed: exit %d" % proc.returncode)
    local = (env.work / "local.svg").read_text()
    remote = (env.work / "remote.svg").read_text()
    expect(remote == local, "the SVGs differ")
    # The legend has the valid path's length and clearance and marks the invalid one.
    expect(re.search(r">ok<.*?length [0-9.]+<.*?min clearance [0-9.]+<", local, re.S),
           "legend lacks the clearance of 'ok'")
    expect(">through (invalid)<" in local, "the invalid path is not marked")


@case
def merge_server_svg_and_out_path(env):
    with env.server() as server:
        local = env.run("merge", "--scene", env.scene, "--paths", env.paths, "--svg", "local.svg",
                        "-q")
        expect(local.returncode == 0, "merge failed")
        remote = env.run("merge", "--server", server.target, "--scene", env.scene, "--paths",
                         env.paths, "--svg", "remote.svg", "-q")
        expect(remote.returncode == 0, "merge --server --svg failed: exit %d" % remote.returncode)
        expect((env.work / "remote.svg").read_text() == (env.work / "local.svg").read_text(),
               "merge --server --svg drew another picture than the in-process merge")
        out = env.run("merge", "--server", server.target, "--scene", env.scene, "--paths",
                      env.paths, "--out-path", "merged.txt", "-q")
        expect(out.returncode == 0, "merge --server --out-path failed: exit %d" % out.returncode)
        proc = env.run("check", "--server", server.target, "--scene", env.scene, "--paths",
                       "merged.txt")
        expect(proc.returncode == 0, "the merged path fails check")
        gone = env.run("merge", "--scene", env.scene, "--paths", env.paths, "--shortcut", "-q")
        expect(gone.returncode != 0 and "--shortcut" in gone.stderr,
               "merge --shortcut (OMPL's simplifier in the CLI) is still accepted")


def optimize_events(result):
    return [p for p in result.get("progress", [])
            if p["phase"] == "optimize" and p.get("objective") is not None]


@case
def merge_out_keeps_progress_local_and_remote(env):
    with env.server() as server:
        for where, extra in (("local", []), ("remote", ["--server", server.target])):
            proc = env.run("merge", *extra, "--scene", env.scene, "--paths", env.paths, "--out",
                           where + ".json", "-q")
            expect(proc.returncode == 0, "merge (%s) failed: exit %d" % (where, proc.returncode))
            result = json.loads((env.work / (where + ".json")).read_text())
            phases = [p["phase"] for p in result["progress"]]
            expect("check" in phases and "optimize" in phases,
                   "%s: the result kept no check and optimize events: %r" % (where, set(phases)))
            events = optimize_events(result)
            expect(events, "%s: the result kept no post-optimization objective" % where)
            # The first objective is the H-Graph optimum's (through the server an improvement
            # that comes while a write is in flight replaces the one waiting, so the first kept
            # may be a later, better one), each one better than the one before, the last the
            # result's.
            first_gap = events[0]["objective"] - result["hgraph_objective"]
            expect(abs(first_gap) <= 1e-9 if where == "local" else first_gap <= 1e-9,
                   "%s: first objective %r is not the H-Graph optimum %r"
                   % (where, events[0]["objective"], result["hgraph_objective"]))
            expect(all(b["objective"] < a["objective"] for a, b in zip(events, events[1:])),
                   "%s: the objectives kept do not improve one after another" % where)
            expect(abs(events[-1]["objective"] - result["objective"]) <= 1e-9,
                   "%s: last objective %r is not the result's %r"
                   % (where, events[-1]["objective"], result["objective"]))


@case
def view_writes_one_offline_file(env):
    env.run("merge", "--scene", env.scene, "--paths", env.paths, "--out", "result.json", "-q")
    proc = env.run("view", "--scene", env.scene, "--paths", env.paths, "--result", "result.json",
                   "--out", "view.html")
    expect(proc.returncode == 0, "view failed: exit %d" % proc.returncode)
    html = (env.work / "view.html").read_text()
    expect(html.startswith("<!DOCTYPE html>"), "not an HTML document")
    # Nothing is fetched when it opens: no external script, style sheet or image.
    expect(not re.search(r"""<(script|link|img)[^>]+(src|href)=""", html),
           "the file loads something from elsewhere")
    data = json.loads(re.search(r'<script type="application/json" id="hgraph-view-data">(.*?)'
                                r"</script>", html, re.S).group(1))
    result = json.loads((env.work / "result.json").read_text())
    expect(data["merged"]["length"] == result["quality"]["length"], "merged length differs")
    expect([p["name"] for p in data["inputs"]] == [i["name"] for i in result["inputs"]],
           "the inputs are not the result's")
    expect(len(data["merged"]["segment_sources"]) == len(result["path"]["waypoints"]) - 1,
           "one source per stretch of the merged path")
    expect(len(data["rounds"]) == len(optimize_events(result)), "chart rounds differ")
    expect(data["planar"], "a 2D point robot's scene is planar")
    # Without a result the inputs are checked here for the legend.
    proc = env.run("view", "--scene", env.scene, "--paths", env.paths, "--out", "inputs.html")
    expect(proc.returncode == 0, "view --paths alone failed")
    proc = env.run("view", "--scene", env.scene, "--out", "none.html")
    env.expect_bad_input(proc, "--paths")
    # A --best-so-far result holds its path, objective and measure only: the legend measures the
    # path, and there is no best input to compare with.
    env.write("best.json", {k: result[k] for k in ("path", "objective", "measure")})
    proc = env.run("view", "--scene", env.scene, "--result", "best.json", "--out", "best.html")
    expect(proc.returncode == 0, "view of a best-so-far result failed")
    best = json.loads(re.search(r'id="hgraph-view-data">(.*?)</script>',
                                (env.work / "best.html").read_text(), re.S).group(1))
    expect(abs(best["merged"]["length"] - result["quality"]["length"]) <= 1e-9,
           "the merged path's length is not measured")
    expect("best_input_objective" not in best["measure"], "a best input where there is none")


@case
def view_server_equals_in_process(env):
    # The inputs' legend numbers come from a check: in process, or by the service's CheckPaths.
    with env.server() as server:
        local = env.run("view", "--scene", env.scene, "--paths", through_disc(env), "--out",
                        "local.html")
        remote = env.run("view", "--server", server.target, "--scene", env.scene, "--paths",
                         through_disc(env), "--out", "remote.html")
    expect(local.returncode == 0 and remote.returncode == 0, "view failed")
    html = (env.work / "local.html").read_text()
    expect((env.work / "remote.html").read_text() == html, "the views differ")
    expect('"name":"through (invalid)"' in html, "the invalid path is not marked")


@case
def view_errors_name_file_and_field(env):
    paths = env.circle_paths()
    paths[0][1] = paths[0][1] + [0.0]
    bad = env.write("p.json", env.path_set(paths))
    proc = env.run("view", "--scene", env.scene, "--paths", bad, "--out", "v.html")
    env.expect_bad_input(proc, "p.json: paths[0].waypoints[1]")
    expect("expected 2 coordinates" in proc.stderr, "the dimension is not named")
    # A result of another scene: another dimension, or outside this scene's bounds.
    env.run("merge", "--scene", env.scene, "--paths", env.paths, "--out", "result.json", "-q")
    grid = str(env.data.parent.parent / "scenes" / "grid" / "scene.json")
    proc = env.run("view", "--scene", grid, "--result", "result.json", "--out", "v.html")
    env.expect_bad_input(proc, "result.json: path.waypoints[0]")
    result = json.loads((env.work / "result.json").read_text())
    for w in result["path"]["waypoints"][1:-1]:
        w["values"] = [v + 500 for v in w["values"]]
    env.write("far.json", result)
    proc = env.run("view", "--scene", env.scene, "--result", "far.json", "--out", "v.html")
    env.expect_bad_input(proc, "far.json: path.waypoints[1]")
    expect("another scene" in proc.stderr, "the message does not say why")
    result = json.loads((env.work / "result.json").read_text())
    result["source_path"] = result["source_path"][:2]
    env.write("short.json", result)
    proc = env.run("view", "--scene", env.scene, "--result", "short.json", "--out", "v.html")
    env.expect_bad_input(proc, "short.json: source_path")
    # A mesh above the limit names the scene file, the obstacle, the mesh and the flag.
    shutil.copy(env.data.parent.parent / "scenes" / "wrench" / "wrench.obj", env.work)
    scene = scene_with_mesh(env, "wrench.obj")
    proc = env.run("view", "--scene", scene, "--paths", env.paths, "--out", "v.html",
                   "--max-mesh-triangles", "10")
    env.expect_bad_input(proc, "scene.json: obstacles[70]")
    expect("188 triangles" in proc.stderr, "the mesh's size is not named: %r" % proc.stderr)
    expect("wrench.obj" in proc.stderr and "--max-mesh-triangles" in proc.stderr,
           "the mesh or the flag is not named: %r" % proc.stderr)
    proc = env.run("view", "--scene", scene, "--paths", env.paths, "--out", "v.html")
    expect(proc.returncode == 0, "the mesh scene under the default limit failed")
    proc = env.run("view", "--scene", scene, "--paths", env.paths, "--out", "v.html", "--frames",
                   "1")
    env.expect_bad_input(proc, "--frames: must be in [2, 100000]")


@case
def import_cfg_server_then_merge_in_session(env):
    problem = env.work / "ompl_app"
    shutil.copytree(env.data / "ompl_app", problem)
    cfg = problem / "wall_planar.cfg"
    proc = env.run("import-cfg", cfg)
    env.expect_bad_input(proc, "--out")
    with env.server() as server:
        imported = env.run("import-cfg", cfg, "--server", server.target, "--out", "scene.json")
        expect(imported.returncode == 0, "import-cfg --server failed: exit %d" % imported.returncode)
        expect((env.work / "scene.json").exists(), "--out not written")
        expect(re.search(r"^scene sha256 [0-9a-f]{64} \(\d+ bytes\)", imported.stdout, re.M),
               "no scene digest")
        session = re.search(r"^session (sessions/[0-9a-f]{32})$", imported.stdout, re.M).group(1)
        # The session holds the scene the JSON file describes: every later call reuses it.
        planned = env.run("plan", "--server", server.target, "--session", session, "--scene",
                          "scene.json", "--count", 3, "--planner", "prm", "--time", 1, "--seed", 7,
                          "--out", "inputs.json")
        expect(planned.returncode == 0, "plan --server --session failed")
        expect("[plan" in planned.stderr, "plan --server printed no progress")
        merged = env.run("merge", "--server", server.target, "--session", session, "--scene",
                         "scene.json", "--paths", "inputs.json", "--out-path", "merged.path",
                         "--svg", "merged.svg", "-q")
        expect(merged.returncode == 0, "merge --server --session failed: exit %d"
               % merged.returncode)
        expect("session " + session in merged.stderr, "the session was not reused")
        expect("<svg" in (env.work / "merged.svg").read_text(), "no SVG")
        checked = env.run("check", "--server", server.target, "--session", session, "--scene",
                          cfg, "--paths", "merged.path")
        expect(checked.returncode == 0, "the merged path fails check in the session")
        # Without --out the scene is only stored.
        again = env.run("import-cfg", cfg, "--server", server.target)
        expect(again.returncode == 0 and "session sessions/" in again.stdout,
               "import-cfg --server without --out failed")


def same_lines(local, remote, what):
    """A subcommand run in process and with --server: the same exit code, and the same stdout
    once numbers of milliseconds and the counts of checks are masked (mask_check_counts), and the
    remote-only "hgraph <name>" line is dropped."""
    def norm(text):
        lines = [l for l in text.splitlines() if not l.startswith("hgraph sessions/")]
        out = []
        for line in lines:
            if line.startswith("timing (ms):"):
                line = "timing (ms): <masked>"
            out.append(mask_check_counts(line))
        return out
    expect(local.returncode == remote.returncode,
           "%s: exit %d in process, %d with --server" % (what, local.returncode, remote.returncode))
    a, b = norm(local.stdout), norm(remote.stdout)
    expect(a == b, "%s: --server printed other lines:\n%s\nvs in process\n%s"
           % (what, "\n".join(b), "\n".join(a)))


def plan_lines(proc):
    """`hgraph plan`'s table with the time column masked."""
    out = []
    for line in proc.stdout.splitlines():
        cols = line.split()
        if len(cols) >= 6 and re.match(r"^[a-z-]+-\d+$", cols[0]):
            time_at = 2 if cols[1] == "found" else 3
            cols[time_at] = "<ms>"
        out.append(re.sub(r"; wrote \S+", "; wrote <out>", " ".join(cols)))
    return out


def circles_scene(env):
    return env.data.parent.parent / "scenes" / "circles" / "scene.json"


def walled_scene(env):
    """The circles scene with a wall across the whole space between start and goal: no planner
    can find a path."""
    scene = json.loads(circles_scene(env).read_text())
    y = (scene["start"]["values"][1] + scene["goal"]["values"][1]) / 2
    scene["obstacles"] = [{"name": "wall", "shape": {"box": {"size": [400, 2, 2]}},
                           "pose": {"position": [40, y, 0]}}]
    return env.write("walled.json", scene)


@case
def solve_in_process_and_through_the_server(env):
    """`hgraph solve` on the circles scene: a certified path that `check` accepts, every run
    listed, the H-Graph kept by the server and re-queried by name; a walled scene ends with exit 1
    and "no path"; bad flags exit 2 naming the flag."""
    scene = str(circles_scene(env))
    flags = ("--budget", "1", "--planner", "prm:2", "--planner", "rrtconnect:2", "--seed", "3")
    local = env.run("solve", "-q", "--scene", scene, *flags, "--out", "solve.json",
                    "--out-path", "solved.json")
    expect(local.returncode == 0, "solve failed: exit %d" % local.returncode)
    result = json.loads((env.work / "solve.json").read_text())
    expect(result.get("found") is True, "solve found no path: %r" % result.get("message"))
    expect(len(result["runs"]) == 4, "expected 4 runs, got %d" % len(result["runs"]))
    expect(re.search(r"^solved in \d+ ms", local.stdout, re.M), "no summary line")
    proc = env.run("check", "--scene", scene, "--paths", "solved.json")
    expect(proc.returncode == 0, "check rejected the solved path: exit %d" % proc.returncode)
    with env.server() as server:
        remote = env.run("solve", "-q", "--server", server.target, "--scene", scene, *flags)
        expect(remote.returncode == 0, "solve --server failed: exit %d" % remote.returncode)
        expect("bitstar" not in remote.stdout, "a run of a planner not asked for")
        hgraph = re.search(r"^hgraph (sessions/[0-9a-f]+/hgraphs/\S+)", remote.stdout, re.M)
        expect(hgraph, "solve --server names no H-Graph")
        again = env.run("requery", "--server", server.target, "--hgraph", hgraph.group(1),
                        "--measure", "length")
        expect(again.returncode == 0, "requery of the solved H-Graph failed")
        walled = env.run("solve", "-q", "--server", server.target, "--scene", walled_scene(env),
                         "--budget", "0.3", "--planner", "rrtconnect:2")
        expect(walled.returncode == 1, "walled scene: exit %d, expected 1" % walled.returncode)
        expect("no path" in walled.stdout, "walled scene: no 'no path' line")
        bad = env.run("solve", "--server", server.target, "--scene", scene, "--planner", "none")
        env.expect_bad_input(bad, "--planner")
    env.expect_bad_input(env.run("solve", "--scene", scene, "--budget", "0"), "--budget")
    env.expect_bad_input(env.run("solve", "--scene", scene, "--planner", "prm:0"), "--planner")
    env.expect_bad_input(env.run("solve", "--scene", scene, "--plan-fraction", "2"),
                         "plan_fraction (--plan-fraction)")


@case
def merge_server_same_lines_and_exit_codes(env):
    with env.server() as server:
        for extra in ((), ("--measure", "inverse-clearance", "--k", "2"),
                      ("--variant", "knn", "--phi", "3")):
            local = env.run("merge", "-q", "--scene", env.scene, "--paths", env.paths, *extra)
            remote = env.run("merge", "-q", "--server", server.target, "--scene", env.scene,
                             "--paths", env.paths, *extra)
            expect(local.returncode == 0, "merge %s failed" % (extra,))
            same_lines(local, remote, "merge %s" % " ".join(extra))
            expect("hgraph sessions/" in remote.stdout, "--server names no H-Graph")
        bad = ("--k", "-1")
        local = env.run("merge", "--scene", env.scene, "--paths", env.paths, *bad)
        remote = env.run("merge", "--server", server.target, "--scene", env.scene, "--paths",
                         env.paths, *bad)
        env.expect_bad_input(local, "--k")
        env.expect_bad_input(remote, "--k")


@case
def merge_check_sampled_says_not_certified(env):
    """--check sampled: the result says how its path was checked (check_mode, certified false),
    the printout says it is not certified, its path passes `check --sampled`, and no distance
    query was asked; the same lines with --server. The default says certified. An unknown mode
    exits 2 naming the flag."""
    results = {}
    for mode in ("certified", "sampled"):
        out = "check_%s.json" % mode
        proc = env.run("merge", "-q", "--scene", env.scene, "--paths", env.paths, "--check", mode,
                       "--out", out)
        expect(proc.returncode == 0, "merge --check %s failed: exit %d" % (mode, proc.returncode))
        results[mode] = (proc, json.loads((env.work / out).read_text()))
    proc, certified = results["certified"]
    expect(certified.get("certified") is True, "the default result is not marked certified")
    expect(certified.get("check_mode") == "CHECK_MODE_CERTIFIED", "default check_mode %r" %
           certified.get("check_mode"))
    expect("NOT certified" not in proc.stdout, "the default printout says not certified")
    proc, sampled = results["sampled"]
    expect(sampled.get("certified") is False, "a sampled result is not marked uncertified")
    expect(sampled.get("check_mode") == "CHECK_MODE_SAMPLED", "sampled check_mode %r" %
           sampled.get("check_mode"))
    expect(int(sampled["stats"]["distance_queries"]) == 0, "a sampled length merge asked "
           "distance queries")
    expect("NOT certified" in proc.stdout, "the printout does not say the path is not certified")
    path = check_result(env, sampled)
    pathset = env.write("sampled_path.json", {"paths": [
        {"name": "merged", "waypoints": [{"values": w["values"]} for w in path]}]})
    proc = env.run("check", "--sampled", "--scene", env.scene, "--paths", pathset)
    expect(proc.returncode == 0, "check --sampled rejected the sampled merge's path")
    with env.server() as server:
        local = env.run("merge", "-q", "--scene", env.scene, "--paths", env.paths, "--check",
                        "sampled")
        remote = env.run("merge", "-q", "--server", server.target, "--scene", env.scene,
                         "--paths", env.paths, "--check", "sampled")
        same_lines(local, remote, "merge --check sampled")
    env.merge_bad("--check", "--check", "approximate")


@case
def merge_partial_shortcuts_on_a_mesh_scene(env):
    """--partial-shortcuts on the rod through the holed wall (SE(3)): a certified path no longer
    than the best input and other than the defaults' (the flag reaches the post-optimization),
    the same lines with --server (it reaches the service); on the circles (R^2, one part) it
    changes nothing."""
    scene = str(env.data.parent / "bench" / "scenes" / "hole_wall" / "scene.json")
    paths = str(env.data / "hole_wall" / "prm4_seed1.json")
    results = {}
    for extra in ((), ("--partial-shortcuts",)):
        out = "partial.json" if extra else "plain.json"
        proc = env.run("merge", "-q", "--scene", scene, "--paths", paths, "--out", out, *extra)
        expect(proc.returncode == 0, "merge %s failed: exit %d" % (extra, proc.returncode))
        results[extra] = json.loads((env.work / out).read_text())
    plain, partial = results[()], results[("--partial-shortcuts",)]
    best_input = min(i["quality"]["length"] for i in partial["inputs"] if i["valid"])
    expect(partial["quality"]["length"] <= best_input, "longer than the best input")
    expect(partial["path"]["waypoints"] != plain["path"]["waypoints"],
           "--partial-shortcuts gave the defaults' path")
    pathset = env.write("partial_path.json", {"paths": [
        {"name": "merged", "waypoints": partial["path"]["waypoints"]}]})
    proc = env.run("check", "--scene", scene, "--paths", pathset)
    expect(proc.returncode == 0 and "certified" in proc.stdout,
           "check does not certify the path: exit %d" % proc.returncode)
    with env.server() as server:
        local = env.run("merge", "-q", "--scene", scene, "--paths", paths, "--partial-shortcuts")
        remote = env.run("merge", "-q", "--server", server.target, "--scene", scene, "--paths",
                         paths, "--partial-shortcuts")
        same_lines(local, remote, "merge --partial-shortcuts")
    plain = env.run("merge", "-q", "--scene", env.scene, "--paths", env.paths)
    partial = env.run("merge", "-q", "--scene", env.scene, "--paths", env.paths,
                      "--partial-shortcuts")
    same_lines(plain, partial, "merge --partial-shortcuts on R^2")


@case
def merge_best_so_far_keeps_the_last_streamed_path(env):
    """--best-so-far: refused without --server and --timeout (exit 2 naming the flag); through
    the server, deadlines from 5 ms up on the rod through the holed wall (the session reused, so
    that only the merge runs under them). Whatever a deadline cuts, the outcome is one of three,
    each checked: no path yet (exit 3, DEADLINE_EXCEEDED), the best path so far (exit 0; the
    path `hgraph check` certifies, of the objective printed, from start to goal, no longer than
    the H-Graph optimum), or the whole result (exit 0, its table)."""
    scene = str(env.data.parent / "bench" / "scenes" / "hole_wall" / "scene.json")
    paths = str(env.data / "hole_wall" / "prm4_seed1.json")
    env.expect_bad_input(env.run("merge", "-q", "--scene", scene, "--paths", paths,
                                 "--best-so-far"), "--best-so-far")
    inputs = json.loads(pathlib.Path(paths).read_text())["paths"]
    with env.server() as server:
        env.expect_bad_input(env.run("merge", "-q", "--server", server.target, "--scene", scene,
                                     "--paths", paths, "--best-so-far"), "--best-so-far")
        full = env.run("merge", "-q", "--server", server.target, "--scene", scene, "--paths",
                       paths, "--out", "full.json")
        expect(full.returncode == 0, "merge failed: exit %d" % full.returncode)
        session = re.search(r"^hgraph (sessions/[0-9a-f]+)/hgraphs/", full.stdout, re.M).group(1)
        result = json.loads((env.work / "full.json").read_text())
        outcomes = set()
        for timeout in ("0.005", "0.01", "0.02", "0.04", "0.08", "0.16", "30"):
            for name in ("bsf.json", "bsf_path.json"):
                (env.work / name).unlink(missing_ok=True)
            proc = env.run("merge", "-q", "--server", server.target, "--session", session,
                           "--timeout", timeout, "--best-so-far", "--scene", scene, "--paths",
                           paths, "--out", "bsf.json", "--out-path", "bsf_path.json")
            if proc.returncode == 3:
                expect("DEADLINE_EXCEEDED" in proc.stderr, "exit 3 without DEADLINE_EXCEEDED")
                outcomes.add("none")
                continue
            expect(proc.returncode == 0, "exit %d at timeout %s" % (proc.returncode, timeout))
            cut = re.search(r"the best path so far, certified, \d+ waypoints, length objective "
                            r"([0-9.e+-]+)", proc.stdout)
            if cut is None:
                expect(re.search(r"^merged\s", proc.stdout, re.M), "neither a table nor a cut")
                outcomes.add("complete")
                continue
            outcomes.add("cut")
            partial = json.loads((env.work / "bsf.json").read_text())
            objective = float(cut.group(1))
            expect(abs(partial["objective"] - objective) <= 1e-5 * objective,
                   "--out's objective is not the one printed")
            expect(partial["objective"] <= result["hgraph_objective"] + 1e-9,
                   "worse than the H-Graph optimum")
            expect(partial["objective"] >= result["objective"] - 1e-9,
                   "better than the whole merge's result")
            waypoints = partial["path"]["waypoints"]
            for end in (0, -1):
                expect(close(waypoints[end]["values"], inputs[0]["waypoints"][end]["values"]),
                       "the path does not keep the endpoints")
            check = env.run("check", "--scene", scene, "--paths", "bsf_path.json")
            expect(check.returncode == 0 and "certified" in check.stdout,
                   "check does not certify the path: exit %d" % check.returncode)
            length = float(re.search(r"length ([0-9.e+-]+)", check.stdout).group(1))
            expect(abs(length - objective) <= 1e-5 * objective, "the path is not of its objective")
        expect("complete" in outcomes, "no deadline let the merge finish: %s" % outcomes)


def close(a, b, rel=1e-9):
    """Two configurations equal within a relative tolerance."""
    return len(a) == len(b) and all(abs(x - y) <= rel * max(1.0, abs(y)) for x, y in zip(a, b))


@case
def plan_server_same_lines_and_exit_codes(env):
    scene = circles_scene(env)
    with env.server() as server:
        flags = ("--count", "2", "--time", "60", "--seed", "5", "--resolution", "0.02")
        local = env.run("plan", "--scene", scene, *flags, "--out", "local.json")
        remote = env.run("plan", "--server", server.target, "--scene", scene, *flags,
                         "--out", "remote.json")
        expect(local.returncode == 0, "plan failed: exit %d" % local.returncode)
        expect(remote.returncode == local.returncode,
               "plan --server: exit %d, in process %d" % (remote.returncode, local.returncode))
        expect(plan_lines(local) == plan_lines(remote),
               "plan --server printed other lines:\n%s\nvs\n%s" % (remote.stdout, local.stdout))
        # The planner is the same (the paper's PRM by default), so are the paths.
        expect("with prm in" in remote.stdout, "plan --server did not default to prm")
        expect((env.work / "local.json").read_text() == (env.work / "remote.json").read_text(),
               "plan --server wrote other paths than plan in process")


@case
def plan_server_exits_1_when_paths_are_missing(env):
    scene = walled_scene(env)
    with env.server() as server:
        flags = ("--count", "2", "--time", "0.2", "--out", "none.json")
        local = env.run("plan", "--scene", scene, *flags)
        remote = env.run("plan", "--server", server.target, "--scene", scene, *flags)
        expect(local.returncode == 1, "plan: exit %d, expected 1" % local.returncode)
        expect(remote.returncode == 1, "plan --server: exit %d, expected 1" % remote.returncode)
        expect(plan_lines(local) == plan_lines(remote),
               "plan --server printed other lines:\n%s\nvs\n%s" % (remote.stdout, local.stdout))
        expect("found 0 of 2" in remote.stdout, "no summary")
        expect(not (env.work / "none.json").exists(), "a file was written with nothing found")


@case
def plan_server_forwards_resolution(env):
    # A resolution the planner rejects must reach it: the server would otherwise plan at the
    # scene's own resolution and succeed.
    scene = circles_scene(env)
    with env.server() as server:
        local = env.run("plan", "--scene", scene, "--resolution", "-1")
        remote = env.run("plan", "--server", server.target, "--scene", scene, "--resolution", "-1")
        env.expect_bad_input(local, "resolution")
        env.expect_bad_input(remote, "resolution")


@case
def server_unreachable_exits_3(env):
    # Port 1 on loopback: nothing listens there, the channel fails with UNAVAILABLE.
    for args in (("check", "--scene", env.scene, "--paths", env.paths),
                 ("merge", "--scene", env.scene, "--paths", env.paths),
                 ("plan", "--scene", circles_scene(env))):
        proc = env.run(*args, "--server", "127.0.0.1:1", "--timeout", "20")
        expect(proc.returncode == 3, "%s: exit %d, expected 3" % (args[0], proc.returncode))
        expect("UNAVAILABLE" in proc.stderr or "DEADLINE_EXCEEDED" in proc.stderr,
               "%s: no status on stderr: %r" % (args[0], proc.stderr))


@case
def mesh_without_extension_server(env):
    shutil.copy(env.data.parent.parent / "scenes" / "wrench" / "wrench.obj", env.work / "wrench")
    scene = scene_with_mesh(env, "wrench")
    with env.server() as server:
        local = env.run("check", "--scene", scene, "--paths", env.paths)
        remote = env.run("check", "--server", server.target, "--scene", scene, "--paths",
                         env.paths)
        for proc in (local, remote):
            expect("out_of_range" not in proc.stderr and "basic_string" not in proc.stderr,
                   "an exception escaped: %r" % proc.stderr)
        # In process assimp tells the format from the bytes; a blob on the server needs it named
        # (the server's rule), and the message says which field.
        expect(local.returncode == 0, "in process: exit %d" % local.returncode)
        env.expect_bad_input(remote, "scene.obstacles[70].shape.mesh.format")


def plan_merge_check(env, name):
    """`hgraph plan` (the paper's PRM) then `hgraph merge` on a built-in scene: the merged path
    passes `hgraph check`, keeps the endpoints and is no longer than the shorter input."""
    scene = env.data.parent.parent / "scenes" / name / "scene.json"
    # PRM stops at its first solution; the budget only matters on a starved machine.
    plan = env.run("plan", "--scene", scene, "--planner", "prm", "--count", "2", "--time", "120",
                   "--seed", "3", "--out", "inputs.json")
    expect(plan.returncode == 0, "plan failed on %s" % name)
    inputs = json.loads((env.work / "inputs.json").read_text())["paths"]
    expect(len(inputs) == 2, "expected 2 planned paths, got %d" % len(inputs))
    check_inputs = env.run("check", "--scene", scene, "--paths", "inputs.json")
    expect(check_inputs.returncode == 0, "planned inputs fail hgraph check on %s" % name)
    merge = env.run("merge", "-q", "--scene", scene, "--paths", "inputs.json", "--out",
                    "result.json", "--out-path", "merged.json")
    expect(merge.returncode == 0, "merge failed on %s" % name)
    result = json.loads((env.work / "result.json").read_text())
    check = env.run("check", "--scene", scene, "--paths", "merged.json")
    expect(check.returncode == 0, "the merged path fails hgraph check on %s" % name)
    merged = result["path"]["waypoints"]
    for end in (0, -1):
        expect(all(abs(a - b) < 1e-9 for a, b in
                   zip(merged[end]["values"], inputs[0]["waypoints"][end]["values"])),
               "the merged path does not keep the endpoints on %s" % name)
    shortest = min(i["quality"]["length"] for i in result["inputs"] if i["valid"])
    expect(result["quality"]["length"] <= shortest + 1e-9,
           "merged %g longer than the shorter input %g on %s"
           % (result["quality"]["length"], shortest, name))


for _scene in ("maze", "grid", "wrench", "double_wrench", "circles"):
    CASES["plan_merge_check_" + _scene] = (lambda name: lambda env: plan_merge_check(env, name))(
        _scene)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--list", action="store_true")
    parser.add_argument("--hgraph")
    parser.add_argument("--server-bin")
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
    env = Env(str(pathlib.Path(args.hgraph).resolve()), pathlib.Path(args.data).resolve(), work,
              str(pathlib.Path(args.server_bin).resolve()) if args.server_bin else None)
    try:
        CASES[args.case](env)
    except Failure as e:
        print("FAIL %s: %s" % (args.case, e), file=sys.stderr)
        return 1
    except Skip as e:
        print("SKIP %s: %s" % (args.case, e))
        return SKIP_RETURN_CODE
    print("PASS", args.case)
    return 0


if __name__ == "__main__":
    sys.exit(main())
