#!/usr/bin/env python3
"""Writes the C++ source that carries the 3D view's scripts (core/render/view_assets.h):
three.js and its OrbitControls as one classic script that defines the global THREE, the page's
own script and its style sheet.

three ships ES modules (three.core.min.js, three.module.min.js importing it, OrbitControls.js
importing 'three'). A page opened from file:// cannot import modules from other files and an
inline module cannot be imported by another script, so each module becomes a function whose body
is the module's code, its imports read from the object the earlier modules returned and its
export list turned into the object it returns. The rewrite is strict: a module that does not have
the one import and one export shape expected fails the build rather than a page at run time.

Usage: embed_assets.py --three DIR --page view.js --style view.css --out view_assets.cc
"""
import argparse
import json
import pathlib
import re
import sys

IDENT = r"[A-Za-z_$][\w$]*"
# An import statement at the start of a line or after a statement, import.meta or import():
# anything a function body cannot hold. Comments that mention imports do not match.
LEFTOVER_IMPORT = re.compile(r"""(^|[;}])\s*import\s*[{*\w"']|import\.meta|\bimport\(""", re.M)


def fail(message):
    sys.exit("embed_assets.py: " + message)


def parse_specifiers(text, what):
    """[(local, exported)] of an import or export list 'a as b,c'."""
    pairs = []
    for item in text.split(","):
        item = item.strip()
        if not item:
            continue
        m = re.fullmatch(r"(%s)(?:\s+as\s+(%s))?" % (IDENT, IDENT), item)
        if not m:
            fail("%s: unexpected specifier %r" % (what, item))
        pairs.append((m.group(1), m.group(2) or m.group(1)))
    return pairs


def take_export(source, what):
    """The module without its final `export{...};` and the returned object literal."""
    matches = list(re.finditer(r"export\s*\{([^}]*)\}\s*;?", source))
    own = [m for m in matches if not source[m.end():].lstrip().startswith("from")]
    if len(own) != 1:
        fail("%s: expected one export list, found %d" % (what, len(own)))
    m = own[0]
    returned = ",".join("%s:%s" % (exported, local)
                        for local, exported in parse_specifiers(m.group(1), what))
    return source[:m.start()] + source[m.end():], "{" + returned + "}"


def take_imports(source, specifier, what):
    """The module without its `import{...}from"specifier"` statements, as destructurings of
    the object `lib`; `export{...}from` re-exports are dropped (the caller merges the objects)."""
    quoted = r"""["']%s["']""" % re.escape(specifier)
    source = re.sub(r"export\s*\{[^}]*\}\s*from\s*%s\s*;?" % quoted, "", source)
    bindings = []

    def replace(m):
        for imported, local in parse_specifiers(m.group(1), what):
            bindings.append("%s:%s" % (imported, local))
        return ""

    source = re.sub(r"import\s*\{([^}]*)\}\s*from\s*%s\s*;?" % quoted, replace, source)
    if not bindings:
        fail("%s: no import from %s" % (what, specifier))
    if LEFTOVER_IMPORT.search(source):
        fail("%s: imports other than from %s" % (what, specifier))
    return "const {" + ",".join(bindings) + "}=__hgraph_lib;\n" + source


def module_function(source, what, specifier=None):
    if specifier is not None:
        source = take_imports(source, specifier, what)
    elif LEFTOVER_IMPORT.search(source):
        fail("%s: unexpected import" % what)
    body, returned = take_export(source, what)
    return '(function(__hgraph_lib){"use strict";\n%s\nreturn %s;\n})' % (body, returned)


def three_bundle(three_dir):
    build = three_dir / "build"
    core_path = build / "three.core.min.js"
    module_path = build / "three.module.min.js"
    controls_path = three_dir / "examples" / "jsm" / "controls" / "OrbitControls.js"
    for p in (core_path, module_path, controls_path):
        if not p.is_file():
            fail("missing %s (is the pinned three installed?)" % p)
    version = json.loads((three_dir / "package.json").read_text())["version"]
    core = module_function(core_path.read_text(), core_path.name)
    module = module_function(module_path.read_text(), module_path.name, "./three.core.min.js")
    controls = module_function(controls_path.read_text(), controls_path.name, "three")
    license_text = (three_dir / "LICENSE").read_text().strip()
    return version, (
        "/* three.js %s (MIT license):\n%s\n*/\n"
        "var THREE=(function(){\"use strict\";\n"
        "const core=%s({});\n"
        "const lib=Object.assign({},core,%s(core));\n"
        "Object.assign(lib,%s(lib));\n"
        "return Object.freeze(lib);\n"
        "})();\n" % (version, license_text.replace("*/", "* /"), core, module, controls))


def cxx_chunks(text, what):
    """A brace list of raw string literals of at most 32 KiB each, then nullptr: one literal of the
    whole text would exceed the 65,536 characters C++ compilers must support (clang warns)."""
    delimiter = "hgv"
    if ")" + delimiter + '"' in text:
        fail("%s contains the raw string delimiter" % what)
    chunks = [text[i:i + 32768] for i in range(0, len(text), 32768)]
    return "{\n" + "".join('R"%s(%s)%s",\n' % (delimiter, c, delimiter) for c in chunks) + \
        "nullptr}"


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--three", required=True, type=pathlib.Path)
    parser.add_argument("--page", required=True, type=pathlib.Path)
    parser.add_argument("--style", required=True, type=pathlib.Path)
    parser.add_argument("--out", required=True, type=pathlib.Path)
    args = parser.parse_args()
    version, three = three_bundle(args.three)
    page = args.page.read_text()
    style = args.style.read_text()
    for name, text in (("three", three), ("page", page)):
        if "</script" in text.lower():
            # Inside a <script> element this would end it; three has none today.
            fail("%s contains '</script'" % name)
    if "</style" in style.lower():
        fail("style contains '</style'")
    out = ("// Generated by core/render/view/embed_assets.py from three %s and core/render/view/; "
           "do not edit.\n#include \"core/render/view_assets.h\"\n\nnamespace hgraph::view_assets "
           "{\n\nconst char kThreeVersion[] = \"%s\";\n\nconst char* const kThreeJs[] = %s;\n\n"
           "const char* const kPageJs[] = %s;\n\nconst char* const kPageCss[] = %s;\n\n}  "
           "// namespace hgraph::view_assets\n"
           % (version, version, cxx_chunks(three, "three"), cxx_chunks(page, "view.js"),
              cxx_chunks(style, "view.css")))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    tmp = args.out.with_suffix(".tmp")
    tmp.write_text(out)
    tmp.replace(args.out)


if __name__ == "__main__":
    main()
