#!/usr/bin/env python3
"""The words in the program's string literals, checked against lintian's own
list of misspellings (/usr/share/lintian/data/spelling/corrections).

lintian's spelling-error-in-binary reads the binaries' strings, where the
compiler leaves pieces of literals ("defaul", "ofthe") whose set changes
with how the sources are compiled (one file or a unity unit a time); the
package overrides that tag for the binaries, and this check reads the
literals themselves, every one of them, in the sources the binaries are
built from.
usage: spelling_in_strings.py FILE...   exit 1 on a misspelling."""
import re
import sys

CORRECTIONS = "/usr/share/lintian/data/spelling/corrections"
LITERAL = re.compile(r'"((?:[^"\\\n]|\\.)*)"')
WORD = re.compile(r"[A-Za-z]+")


def load():
    table = {}
    with open(CORRECTIONS, encoding="utf-8") as f:
        for line in f:
            if line.startswith("#") or "||" not in line:
                continue
            wrong, right = line.rstrip("\n").split("||", 1)
            table[wrong.lower()] = right
    return table


def main():
    table, found = load(), 0
    for path in sys.argv[1:]:
        with open(path, encoding="utf-8") as f:
            for number, line in enumerate(f, 1):
                for literal in LITERAL.findall(line):
                    for word in WORD.findall(re.sub(r"\\.", " ", literal)):
                        if word.lower() in table:
                            found += 1
                            print(f"{path}:{number}: '{word}' in a string: {table[word.lower()]}?")
    print(f"spelling: {len(sys.argv) - 1} files' string literals read, {found} misspellings")
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
