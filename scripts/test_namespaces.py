#!/usr/bin/env python3
"""Each test file's code lives in a namespace named after the file.

The test executables are unity builds (tests/CMakeLists.txt): several test
files are compiled as one translation unit, so two files' helpers of the same
name (period_s, wheel, quiet_options, ...) in their anonymous namespaces would
meet. `namespace <file stem> { ... }` around everything after the includes
keeps each file's names its own, in a unity build and out of one. A file
that opens the project's namespaces to test from inside them
(`namespace hapticd::world {`) names its own inside them instead:
`namespace hapticd::world::<file stem> {`, which still sees hapticd::world
(a declaration of the project's own, such as a driver's <kind>_driver(), goes
in a block of the project's namespace before it).

usage: scripts/test_namespaces.py [--fix] FILE...
Checks that every *_test.cpp given opens its namespace after its includes and
closes it at the end; --fix wraps a file that does not. A file that defines
C-linkage symbols (extern "C" ...{) is left out: such a file replaces a
global function and is excluded from the unity units (SKIP_UNITY_BUILD_INCLUSION).
"""
import pathlib
import re
import sys


def namespace_of(path):
    return pathlib.Path(path).stem


def exempt(text):
    return re.search(r'^extern "C"[^;]*\{', text, re.M) is not None


def opening_line(lines):
    last = max((i for i, l in enumerate(lines) if l.startswith("#include")), default=-1)
    i = last + 1
    while i < len(lines) and (not lines[i].strip() or lines[i].startswith("#")):
        i += 1
    return i


PROJECT = re.compile(r"^namespace (hapticd(?:::\w+)*) \{$", re.M)


def is_wrapped(text, name):
    opened = PROJECT.findall(text)
    if opened:  # declarations of the project's own may come first (a driver's <kind>_driver())
        own = [i for i, n in enumerate(opened) if n.endswith("::" + name)]
        return bool(own) and all(n.endswith("::" + name) for n in opened[own[0]:])
    return (re.search(rf"^namespace {name} {{$", text, re.M) is not None
            and text.rstrip().endswith(f"}}  // namespace {name}"))


def wrap(text, name):
    if PROJECT.search(text):
        text = PROJECT.sub(lambda m: f"namespace {m.group(1)}::{name} {{", text)
        return re.sub(r"^\}  // namespace (hapticd(?:::\w+)*)$", lambda m: f"}}  // namespace {m.group(1)}::{name}",
                      text, flags=re.M)
    lines = text.rstrip("\n").split("\n")
    at = opening_line(lines)
    body = lines[at:]
    return "\n".join(lines[:at] + [f"namespace {name} {{", ""] + body + ["", f"}}  // namespace {name}"]) + "\n"


def main(argv):
    fix = "--fix" in argv
    files = [a for a in argv if a != "--fix"]
    bad = []
    for f in files:
        text = pathlib.Path(f).read_text()
        name = namespace_of(f)
        if not f.endswith("_test.cpp") or exempt(text) or is_wrapped(text, name):
            continue
        if fix:
            pathlib.Path(f).write_text(wrap(text, name))
        else:
            bad.append(f"{f}: its code is not inside 'namespace {name} {{ ... }}  // namespace {name}' "
                       "after the includes (scripts/test_namespaces.py --fix wraps it)")
    print("\n".join(bad) if bad else f"test namespaces: {len(files)} files checked")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
