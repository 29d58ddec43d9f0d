#!/usr/bin/env python3
"""The command-line reference of docs/cli.md: the --help of hgraph-server and of every hgraph
subcommand, between the markers below. Regenerate it after changing a flag:

    scripts/cli_reference.py --hgraph build/hgraph --server build/hgraph-server --write

Without --write it checks (the docs.cli_reference test): exit 1 and a diff when the page
differs from what the binaries print.
"""
import argparse
import difflib
import pathlib
import subprocess
import sys

BEGIN = "<!-- BEGIN CLI REFERENCE (scripts/cli_reference.py --write) -->"
END = "<!-- END CLI REFERENCE -->"
SUBCOMMANDS = ["merge", "check", "plan", "solve", "render", "view", "import-cfg", "requery", "add-paths"]


def help_text(*cmd):
    proc = subprocess.run(list(cmd), capture_output=True, text=True, timeout=60)
    if proc.returncode != 0:
        sys.exit("%s exited %d: %s" % (" ".join(cmd), proc.returncode, proc.stderr))
    return proc.stdout.rstrip() + "\n"


def reference(hgraph, server):
    parts = ["### hgraph-server\n\n```\n" + help_text(server, "--help") + "```\n"]
    for sub in SUBCOMMANDS:
        parts.append("### hgraph %s\n\n```\n%s```\n" % (sub, help_text(hgraph, sub, "--help")))
    return "\n".join(parts)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--hgraph", required=True)
    parser.add_argument("--server", required=True)
    parser.add_argument("--readme", default=str(pathlib.Path(__file__).parent.parent / "docs" /
                                                "cli.md"))
    parser.add_argument("--write", action="store_true")
    args = parser.parse_args()
    readme = pathlib.Path(args.readme)
    text = readme.read_text()
    if BEGIN not in text or END not in text:
        sys.exit("%s has no %r ... %r section" % (readme, BEGIN, END))
    head, rest = text.split(BEGIN, 1)
    current, tail = rest.split(END, 1)
    wanted = "\n" + reference(args.hgraph, args.server) + "\n"
    if args.write:
        readme.write_text(head + BEGIN + wanted + END + tail)
        return 0
    if current != wanted:
        sys.stdout.writelines(difflib.unified_diff(
            current.splitlines(True), wanted.splitlines(True), readme.name, "--help"))
        print("%s: the command-line reference differs" % readme +
              " from --help; regenerate it with "
              "scripts/cli_reference.py --write", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
