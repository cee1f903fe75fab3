#!/usr/bin/env python3
"""Each source given compiles by itself (clang -fsyntax-only with its own
command from a non-unity compile_commands.json): it includes what it uses.

The Release and sanitizer builds compile the libraries and programs as
unity units, where one source's includes can hide another's missing one;
this is the check a build of one file a unit used to make.
usage: compile_alone.py COMPILE_COMMANDS_JSON JOBS SOURCE...
Prints each failing source with the compiler's errors; exit 1 if any."""
import json
import shlex
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path


def syntax_only(entry):
    args = entry["arguments"] if "arguments" in entry else shlex.split(entry["command"])
    out, skip = [], False
    for a in args:
        if skip:
            skip = False
        elif a == "-o":
            skip = True
        elif a != "-c":
            out.append(a)
    return out + ["-fsyntax-only", "-w"]


def main():
    db_path, jobs, sources = sys.argv[1], int(sys.argv[2]), sys.argv[3:]
    db = {str(Path(e["directory"], e["file"]).resolve()): e for e in json.load(open(db_path))}
    missing = [s for s in sources if str(Path(s).resolve()) not in db]
    if missing:
        print("compile-alone: not in " + db_path + ": " + " ".join(missing))
        return 1

    def check(source):
        e = db[str(Path(source).resolve())]
        r = subprocess.run(syntax_only(e), cwd=e["directory"], capture_output=True, text=True, errors="replace")
        return source, r.returncode, r.stderr

    failed = 0
    with ThreadPoolExecutor(max_workers=jobs) as pool:
        for source, rc, err in pool.map(check, sources):
            if rc != 0:
                failed += 1
                print(f"compile-alone: {source} does not compile by itself:\n{err}")
    print(f"compile-alone: {len(sources) - failed} of {len(sources)} sources compile by themselves")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
