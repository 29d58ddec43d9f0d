#!/usr/bin/env python3
"""Integration tests of pictures and OMPL.app problems through the real `hgraph` binary:
SVGs written by `merge --svg` and `render` must render with librsvg (rsvg-convert) to a PNG of
the expected size showing the merged path's colour; an OMPL.app .cfg problem must import, plan,
merge and check end to end. Usage: picture_test.py --hgraph BIN --data tests/data --work DIR CASE,
or --list.
"""
import argparse
import json
import pathlib
import re
import shutil
import struct
import subprocess
import sys
import zlib

CASES = {}
MERGED_RGB = (0xD6, 0x27, 0x28)  # core/render's merged-path colour


def case(fn):
    CASES[fn.__name__] = fn
    return fn


class Failure(Exception):
    pass


def expect(condition, message):
    if not condition:
        raise Failure(message)


def read_png(path):
    """(width, height, rows of (r, g, b)) of an 8-bit RGB or RGBA non-interlaced PNG."""
    data = pathlib.Path(path).read_bytes()
    expect(data[:8] == b"\x89PNG\r\n\x1a\n", "%s is not a PNG" % path)
    pos, idat, header = 8, b"", None
    while pos < len(data):
        (length,) = struct.unpack(">I", data[pos:pos + 4])
        kind, body = data[pos + 4:pos + 8], data[pos + 8:pos + 8 + length]
        pos += 12 + length
        if kind == b"IHDR":
            header = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat += body
    width, height, depth, colour, _, _, interlace = header
    expect(depth == 8 and colour in (2, 6) and interlace == 0,
           "unexpected PNG format depth=%d colour=%d interlace=%d" % (depth, colour, interlace))
    bpp = 3 if colour == 2 else 4
    raw = zlib.decompress(idat)
    stride = width * bpp
    rows, prev = [], bytearray(stride)
    for y in range(height):
        filt = raw[y * (stride + 1)]
        line = bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - bpp] if i >= bpp else 0
            b = prev[i]
            c = prev[i - bpp] if i >= bpp else 0
            if filt == 1:
                line[i] = (line[i] + a) & 255
            elif filt == 2:
                line[i] = (line[i] + b) & 255
            elif filt == 3:
                line[i] = (line[i] + (a + b) // 2) & 255
            elif filt == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                pred = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
                line[i] = (line[i] + pred) & 255
        rows.append([tuple(line[i:i + 3]) for i in range(0, stride, bpp)])
        prev = line
    return width, height, rows


def count_colour(rows, rgb, tolerance=12):
    return sum(1 for row in rows for p in row
               if all(abs(p[k] - rgb[k]) <= tolerance for k in range(3)))


class Env:
    def __init__(self, hgraph, data, work):
        self.hgraph = hgraph
        self.data = data
        self.work = work

    def run(self, *args, expect_ok=True):
        cmd = [self.hgraph, *[str(a) for a in args]]
        proc = subprocess.run(cmd, cwd=self.work, capture_output=True, text=True, timeout=240)
        print("$", " ".join(cmd), "->", proc.returncode)
        print(proc.stdout, end="")
        print(proc.stderr, end="", file=sys.stderr)
        if expect_ok:
            expect(proc.returncode == 0, "exit %d: %s" % (proc.returncode, proc.stderr.strip()))
        return proc

    def png_of(self, svg, width=900):
        """Renders the SVG with librsvg; checks the PNG's size against the SVG's."""
        rsvg = shutil.which("rsvg-convert")
        expect(rsvg is not None, "rsvg-convert not found (scripts/install-deps.sh installs it)")
        text = pathlib.Path(svg).read_text()
        height = float(re.search(r'<svg [^>]*height="([0-9.]+)"', text).group(1))
        png = str(svg) + ".png"
        subprocess.run([rsvg, str(svg), "-o", png], check=True, timeout=120)
        w, h, rows = read_png(png)
        expect(w == width, "PNG width %d, expected %d" % (w, width))
        expect(abs(h - height) <= 1, "PNG height %d, expected %.0f" % (h, height))
        return rows


def expect_layers(rows, merged, inputs, obstacles):
    """More than the given numbers of pixels in the merged path's red, the inputs' grey and the
    obstacles' grey (core/render's colours)."""
    red = count_colour(rows, MERGED_RGB)
    expect(red > merged, "only %d pixels of the merged path's colour" % red)
    grey = count_colour(rows, (0xA0, 0xA0, 0xA0), tolerance=6)
    expect(grey > inputs, "only %d pixels of the inputs' grey" % grey)
    obstacle = count_colour(rows, (0x5F, 0x5F, 0x5F), tolerance=4)
    expect(obstacle > obstacles, "only %d obstacle pixels" % obstacle)


@case
def merge_svg_renders(env):
    scene = env.data / "circles" / "scene.json"
    svg = env.work / "circles.svg"
    env.run("merge", "--scene", scene, "--paths", env.data / "circles" / "paths.txt",
            "--out", env.work / "circles_result.json", "--svg", svg, "-q")
    expect_layers(env.png_of(svg), merged=500, inputs=100, obstacles=10000)


@case
def grid_merge_svg_shows_scene_inputs_and_merged_path(env):
    # The paper's Figure 1 setting: PRM inputs through the grid, merged; the rotating rectangle
    # is drawn along the merged path.
    scene = env.data.parent.parent / "scenes" / "grid" / "scene.json"
    paths = env.work / "grid_inputs.json"
    env.run("plan", "--scene", scene, "--planner", "prm", "--count", 3, "--time", 120, "--seed", 2,
            "--out", paths)
    svg = env.work / "grid.svg"
    env.run("merge", "--scene", scene, "--paths", paths, "--svg", svg, "-q")
    text = svg.read_text()
    expect(text.count("<polyline") >= 4, "expected 3 input polylines and the merged one")
    rows = env.png_of(svg)
    expect_layers(rows, merged=800, inputs=1000, obstacles=50000)
    blue = sum(1 for row in rows for p in row if p[2] > 150 and p[2] - p[0] > 40)
    expect(blue > 300, "only %d pixels of the robot's footprints" % blue)


@case
def render_with_result_and_planes(env):
    scene = env.data / "circles" / "scene.json"
    paths = env.data / "circles" / "paths.txt"
    result = env.work / "r.json"
    env.run("merge", "--scene", scene, "--paths", paths, "--out", result, "-q")
    svg = env.work / "render.svg"
    out = env.run("render", "--scene", scene, "--paths", paths, "--result", result, "--svg", svg,
                  "--width", 640)
    expect("and the merged path" in out.stdout, "render did not draw the merged path")
    merged_length = json.loads(result.read_text())["quality"]["length"]
    expect("length %.4g" % merged_length in svg.read_text(), "legend lacks the merged length")
    rows = env.png_of(svg, width=640)
    expect(count_colour(rows, MERGED_RGB) > 200, "merged path not visible")
    # Inputs only, seen from the side: still a valid picture.
    side = env.work / "side.svg"
    env.run("render", "--scene", scene, "--paths", paths, "--svg", side, "--plane", "xz")
    env.png_of(side)


@case
def render_bad_plane(env):
    proc = env.run("render", "--scene", env.data / "circles" / "scene.json", "--paths",
                   env.data / "circles" / "paths.txt", "--svg", env.work / "x.svg", "--plane",
                   "top", expect_ok=False)
    expect(proc.returncode == 2, "expected exit 2, got %d" % proc.returncode)
    expect("--plane" in proc.stderr, "error does not name --plane: %r" % proc.stderr)


def has_subcommand(env, name):
    proc = env.run("--help", expect_ok=False)
    return re.search(r"^\s+%s\b" % re.escape(name), proc.stdout, re.M) is not None


def valid_line(x0, y0, x1, y1):
    """Waypoints of a hand-made path through the gap, used when `hgraph plan` is absent."""
    return [[x0, y0, 0.0], [-1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [x1, y1, 1.5707963267949]]


@case
def ompl_app_problem_end_to_end(env):
    # A copy, so that the scene written next to it references the meshes relatively.
    problem = env.work / "ompl_app"
    shutil.rmtree(problem, ignore_errors=True)
    shutil.copytree(env.data / "ompl_app", problem)
    cfg = problem / "wall_planar.cfg"
    scene_json = env.work / "imported" / "scene.json"
    scene_json.parent.mkdir(exist_ok=True)
    env.run("import-cfg", cfg, "--out", scene_json)
    scene = json.loads(scene_json.read_text())
    robot_mesh = scene["robot"][0]["shape"]["mesh"]["path"]
    expect(robot_mesh == "../ompl_app/box_robot.dae", "robot mesh path %r" % robot_mesh)
    expect(scene["space"]["components"][0]["type"] == "TYPE_SE2", "not SE(2)")
    offset = scene["robot"][0]["offset"]["position"]
    expect(abs(offset[0] + 1.0) < 1e-5 and abs(offset[1] + 0.45) < 1e-5,
           "robot not shifted by its centroid: %r" % offset)

    paths = env.work / "ompl_inputs.json"
    if has_subcommand(env, "plan"):
        env.run("plan", "--scene", cfg, "--count", 3, "--planner", "prm", "--time", 1,
                "--seed", 7, "--out", paths)
    else:
        inputs = [valid_line(-3, 2, 3, -2), [[-3, 2, 0], [-2, -1, 0.3], [-1, 0, 0], [1, 0, 0],
                                             [2, -3, 1.0], [3, -2, 1.5707963267949]]]
        paths.write_text(json.dumps({"paths": [
            {"name": "in%d" % i, "waypoints": [{"values": q} for q in p]}
            for i, p in enumerate(inputs)]}))
    env.run("check", "--scene", scene_json, "--paths", paths)

    merged = env.work / "merged.path"
    svg = env.work / "ompl_app.svg"
    env.run("merge", "--scene", cfg, "--paths", paths, "--out-path", merged, "--svg", svg, "-q")
    # OMPL's PathGeometric printout, as OMPL.app's .path files: per state, "RealVectorState [x y]"
    # then "SO2State [theta]".
    text = merged.read_text()
    xy = re.findall(r"RealVectorState \[([^\]]*)\]", text)
    theta = re.findall(r"SO2State \[([^\]]*)\]", text)
    expect(text.startswith("Geometric path with %d states" % len(xy)), "not a .path printout")
    expect(len(xy) >= 2 and len(theta) == len(xy) and all(len(v.split()) == 2 for v in xy),
           "not an SE(2) .path file")
    expect([float(v) for v in xy[0].split()] == [-3.0, 2.0], "merged path does not start at start")
    env.run("check", "--scene", scene_json, "--paths", merged)
    env.run("check", "--scene", cfg, "--paths", merged)
    rows = env.png_of(svg)
    expect(count_colour(rows, MERGED_RGB) > 300, "merged path not visible")
    robot = count_colour(rows, (206, 225, 238), tolerance=12)  # #1f77b4 at 0.22 on white
    expect(robot > 200, "robot footprints not visible (%d pixels)" % robot)


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
    work = pathlib.Path(args.work) / args.case
    work.mkdir(parents=True, exist_ok=True)
    env = Env(args.hgraph, pathlib.Path(args.data), work)
    try:
        CASES[args.case](env)
    except Failure as e:
        print("FAIL:", e, file=sys.stderr)
        return 1
    print("PASS")
    return 0


if __name__ == "__main__":
    sys.exit(main())
