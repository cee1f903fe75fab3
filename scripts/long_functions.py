#!/usr/bin/env python3
"""Lists function bodies longer than a limit (80 lines by default).

The project rule: no function outside tests/ and bench/ is over 80 lines,
except data tables (a function that only returns a table of entries).

A body is measured by brace matching, from the line of its opening brace to
the line of its closing one, both counted. The files are lexed, not parsed:
comments, string and character literals (raw strings too) and preprocessor
lines are blanked first; a brace opens a function body when it is not inside
one already and the text before it (since the last ';', '{' or '}') holds a
parameter list and is not a namespace, class, struct, union or enum head nor
an initialiser ('= ...', other than a lambda). Lambdas and local classes
count towards the function that holds them.

usage: scripts/long_functions.py [--max N] [--exclude DIR]... [FILE...]
Without files it reads `git ls-files '*.cpp' '*.hpp'` less tests/ and bench/.
Prints 'path:line: N lines' for each body over the limit, longest first, and
exits 1 if there is any.
"""
import argparse
import re
import subprocess
import sys


def blank(text):
    """Comments, literals and preprocessor lines as spaces, newlines kept."""
    out = []
    i, n = 0, len(text)
    line_start = True
    while i < n:
        c = text[i]
        if line_start and c == "#":
            # a directive, with its continuation lines
            while i < n and text[i] != "\n":
                if text[i] == "\\" and i + 1 < n and text[i + 1] == "\n":
                    out.append(" \n")
                    i += 2
                    continue
                out.append(" ")
                i += 1
            continue
        if c == "\n":
            out.append(c)
            line_start = True
            i += 1
            continue
        if not c.isspace():
            line_start = False
        if text.startswith("//", i):
            while i < n and text[i] != "\n":
                out.append(" ")
                i += 1
            continue
        if text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
            continue
        m = re.match(r'(?:u8|u|U|L)?R"([^()\\ \n]{0,16})\(', text[i:i + 24])
        if m and (i == 0 or not (text[i - 1].isalnum() or text[i - 1] == "_")):
            end = text.find(")" + m.group(1) + '"', i + m.end())
            j = n if end < 0 else end + len(m.group(1)) + 2
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
            continue
        if c == "'":
            k = i - 1
            while k >= 0 and (text[k].isalnum() or text[k] in "_.'"):
                k -= 1
            if k + 1 < i and text[k + 1].isdigit():  # a digit separator
                out.append(" ")
                i += 1
                continue
        if c in "\"'":
            j = i + 1
            while j < n and text[j] != c and text[j] != "\n":
                j += 2 if text[j] == "\\" else 1
            j = min(j + 1, n)
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
            continue
        out.append(c)
        i += 1
    return "".join(out)


def strip_template_heads(head):
    """'template <...>' prefixes removed, their angle brackets balanced."""
    while True:
        m = re.search(r"\btemplate\s*<", head)
        if not m:
            return head
        depth, j = 1, m.end()
        while j < len(head) and depth:
            depth += {"<": 1, ">": -1}.get(head[j], 0)
            j += 1
        head = head[:m.start()] + " " + head[j:]


def top_level_assignment(head):
    """The text after the last '=' outside brackets that is an assignment, or None."""
    depth, last = 0, None
    for j, c in enumerate(head):
        if c in "([":
            depth += 1
        elif c in ")]":
            depth -= 1
        elif c == "=" and depth == 0:
            before = head[j - 1] if j else ""
            after = head[j + 1] if j + 1 < len(head) else ""
            if before in "=!<>+-*/%&|^" or after == "=":
                continue
            if re.search(r"\boperator\s*$", head[:j]):
                continue
            last = j
    return None if last is None else head[last + 1:]


def classify(head):
    """'function', 'scope' (namespace, class, extern) or 'init' for a '{' after head."""
    head = " ".join(head.split())
    rhs = top_level_assignment(head)
    if rhs is not None:
        return "function" if rhs.lstrip().startswith("[") else "init"
    if re.search(r"\bnamespace\b", head) or re.fullmatch(r"\s*extern\s*", head):
        return "scope"
    bare = strip_template_heads(head)
    paren = bare.find("(")
    kind = re.search(r"\b(class|struct|union|enum)\b", bare)
    if kind and (paren < 0 or kind.start() < paren):
        return "scope"
    if paren >= 0:
        return "function"
    return "init"


def function_bodies(text):
    """(open line, close line) of every function body in text."""
    code = blank(text)
    bodies = []
    stack = []  # kinds of the open braces
    head = []
    line = 1
    open_line = 0
    for c in code:
        if c == "\n":
            line += 1
        in_function = any(k == "function" for k in stack)
        if c == "{":
            if in_function:
                stack.append("inner")
            elif stack and stack[-1] == "init":
                stack.append("init")
            else:
                kind = classify("".join(head))
                stack.append(kind)
                if kind == "function":
                    open_line = line
                if kind != "init":
                    head = []
            continue
        if c == "}":
            kind = stack.pop() if stack else "scope"
            if kind == "function":
                bodies.append((open_line, line))
                head = []
            elif kind == "init" and not (stack and stack[-1] == "init"):
                head.append("{}")  # an initialiser's braces: the head goes on
            elif kind == "scope":
                head = []
            continue
        if in_function or (stack and stack[-1] == "init"):
            continue
        if c == ";":
            head = []
        else:
            head.append(c)
    return bodies


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--max", type=int, default=80)
    parser.add_argument("--exclude", action="append", default=[], help="a folder to skip")
    parser.add_argument("files", nargs="*")
    args = parser.parse_args()
    files = args.files
    if not files:
        listed = subprocess.run(["git", "ls-files", "*.cpp", "*.hpp"], check=True, capture_output=True,
                                text=True).stdout.split()
        files = [f for f in listed if not f.startswith(("tests/", "bench/"))]
    skip = tuple(d.rstrip("/") + "/" for d in args.exclude)
    found = []
    for path in files:
        if skip and path.startswith(skip):
            continue
        with open(path, encoding="utf-8", errors="replace") as f:
            for first, last in function_bodies(f.read()):
                if last - first + 1 > args.max:
                    found.append((last - first + 1, path, first))
    for length, path, first in sorted(found, key=lambda x: (-x[0], x[1], x[2])):
        print(f"{path}:{first}: {length} lines")
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
