#!/usr/bin/env python3
"""The README's quick start, run as written: the shell block between the QUICK START markers,
line by line from a work folder where `build` and `scenes` are the build tree and the built-in
scenes, as they are at the repository's root. Each command must exit 0 and the files the block
names must exist afterwards. With --links-only, checks instead that every relative Markdown link
of README.md and docs/*.md names a file of the repository.
Usage: quick_start_test.py --root REPO --build BUILD --work DIR | --root REPO --links-only
"""
import argparse
import os
import pathlib
import re
import shutil
import subprocess
import sys

BEGIN = "<!-- BEGIN QUICK START -->"
END = "<!-- END QUICK START -->"


def commands(readme):
    text = readme.read_text()
    if BEGIN not in text or END not in text:
        sys.exit("%s has no quick start between %r and %r" % (readme, BEGIN, END))
    block = text.split(BEGIN, 1)[1].split(END, 1)[0]
    body = re.search(r"```sh\n(.*?)```", block, re.S)
    if not body:
        sys.exit("the quick start has no ```sh block")
    return [l for l in body.group(1).splitlines() if l.strip() and not l.lstrip().startswith("#")]


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
    return 0


if __name__ == "__main__":
    sys.exit(main())
