#!/usr/bin/env python3
"""The README's quick start, run as written: the shell block between the QUICK START markers,
line by line from a work folder where `build` and `scenes` are the build tree and the built-in
scenes, as they are at the repository's root; then the block between the SERVER START markers
(the server, requery and the Python client) in one shell, on a free port. Each command must exit 0 and the files the block
names must exist afterwards. With --links-only, checks instead that every relative Markdown link
of README.md and docs/*.md names a file of the repository.
Usage: quick_start_test.py --root REPO --build BUILD --work DIR | --root REPO --links-only
"""
import argparse
import os
import pathlib
import re
import shutil
import socket
import subprocess
import sys

BEGIN = "<!-- BEGIN QUICK START -->"
END = "<!-- END QUICK START -->"
SERVER_BEGIN = "<!-- BEGIN SERVER START -->"
SERVER_END = "<!-- END SERVER START -->"


def block(readme, begin, end):
    """The shell block between the markers, without blank and comment lines."""
    text = readme.read_text()
    if begin not in text or end not in text:
        sys.exit("%s has no block between %r and %r" % (readme, begin, end))
    part = text.split(begin, 1)[1].split(end, 1)[0]
    body = re.search(r"```sh\n(.*?)```", part, re.S)
    if not body:
        sys.exit("the block after %r has no ```sh block" % begin)
    return [l for l in body.group(1).splitlines() if l.strip() and not l.lstrip().startswith("#")]


def commands(readme):
    return block(readme, BEGIN, END)


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def check_links(root):
    bad = []
    pages = [root / "README.md", *sorted((root / "docs").glob("*.md"))]
    for page in pages:
        for target in re.findall(r"\]\(([^)\s]+)\)", page.read_text()):
            if re.match(r"[a-z]+:", target) or target.startswith("#"):
                continue
            if not (page.parent / target.split("#", 1)[0]).exists():
                bad.append("%s: %s" % (page.relative_to(root), target))
    for b in bad:
        print("broken link:", b)
    print("%d pages, %d broken links" % (len(pages), len(bad)))
    return 1 if bad else 0


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--root", required=True, type=pathlib.Path)
    parser.add_argument("--build", type=pathlib.Path)
    parser.add_argument("--work", type=pathlib.Path)
    parser.add_argument("--links-only", action="store_true")
    args = parser.parse_args()
    root = args.root.resolve()
    if args.links_only:
        return check_links(root)
    work = args.work.resolve()
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir(parents=True)
    os.symlink(args.build.resolve(), work / "build")
    os.symlink(root / "scenes", work / "scenes")
    lines = commands(root / "README.md")
    if not lines:
        sys.exit("the quick start has no command")
    for line in lines:
        print("$", line, flush=True)
        proc = subprocess.run(["bash", "-c", line], cwd=work, timeout=240)
        if proc.returncode != 0:
            print("FAIL: exit %d: %s" % (proc.returncode, line))
            return 1
    # Every file the block writes (--out, --out-path, --svg) is there and not empty.
    written = re.findall(r"--(?:out|out-path|svg) (\S+)", "\n".join(lines))
    missing = [w for w in written if not (work / w).is_file() or (work / w).stat().st_size == 0]
    if missing:
        print("FAIL: not written: %s" % ", ".join(missing))
        return 1
    print("%d commands ran, %d files written" % (len(lines), len(written)))
    # The server block: one shell (its server runs in the background, a variable carries the
    # H-Graph's name), on a free port instead of 50051, with a copy of the client and proto
    # folders (pip builds in the folder it installs from) and the tests' data the example reads.
    for name in ("client", "proto"):
        shutil.copytree(root / name, work / name)
    os.symlink(root / "tests", work / "tests")
    server_lines = block(root / "README.md", SERVER_BEGIN, SERVER_END)
    script = "set -e\ntrap 'kill $(jobs -p) 2> /dev/null || true' EXIT\n" + "\n".join(
        server_lines).replace("127.0.0.1:50051", "127.0.0.1:%d" % free_port()) + "\n"
    print(script, flush=True)
    proc = subprocess.run(["bash", "-c", script], cwd=work, timeout=240, capture_output=True,
                          text=True)
    print(proc.stdout, proc.stderr, sep="\n")
    if proc.returncode != 0:
        print("FAIL: the server block exited %d" % proc.returncode)
        return 1
    # The requery answered (its table), and the Python example merged and re-queried.
    for expected in ("measure bottleneck-clearance", "merged: length", "requery bottleneck"):
        if expected not in proc.stdout:
            print("FAIL: the server block printed no %r" % expected)
            return 1
    print("the server block ran: %d commands" % len(server_lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
