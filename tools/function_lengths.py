#!/usr/bin/env python3
"""Function lengths in the project's C++ and Python, checked against per-directory limits.

Counting method (C++): comments, string and character literals are blanked (newlines kept);
a function is a brace block opened in namespace, class or `extern "C"` scope whose header
(the text since the previous `;`, `{` or `}`) has a parameter list and no `=` before it;
member-initialiser braces (`: a_{1}, b_{2} {`) are skipped. Its length is the number of
lines from the header's first line to the closing brace, both included. Lambdas and local
classes count toward the function that holds them. Python: `def` from its first decorator
or `def` line to its `end_lineno` (ast), nested functions counted on their own.

    tools/function_lengths.py [--check] [--allow FILE] [--top N] [ROOT]

prints the longest N functions (default 10) with their limits; `--check` exits 1 when a
function exceeds the limit of its directory (LIMITS below) and lists each one. With `--allow
FILE` (lines "PATH NAME LINES"; tools/function_lengths.allow, the functions still being split)
a listed function may exceed the limit up to its listed length, so the list is a ratchet: it
fails when such a function grows, and when a listed one is under the limit (drop it from the
list).
"""
from __future__ import annotations

import argparse
import ast
import bisect
import re
import sys
from dataclasses import dataclass
from pathlib import Path

# Directory -> the longest function allowed there (lines). The flight software and the
# campaign code tell their story in steps of at most ~100 lines; the simulator and tools
# have 150.
LIMITS = {
    "estimator": 100,
    "controller": 100,
    "flight": 100,
    "campaign": 100,
    "core": 100,
    "sim": 150,
    "tools": 150,
}
CXX_SUFFIXES = {".cpp", ".cc", ".h", ".hpp"}
TRANSPARENT = re.compile(r"(?:^|\W)(namespace|class|struct|union|extern\s*\"C\")(?:\W|$)")


@dataclass
class Function:
    path: Path
    name: str
    first_line: int
    lines: int


def blank_comments_and_literals(text: str) -> str:
    """Comments, strings and chars replaced by spaces, newlines kept, so offsets hold."""
    out = []
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        if text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            out.append(" " * (j - i))
            i = j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
        elif text.startswith('R"', i) and (i == 0 or not (text[i - 1].isalnum() or text[i - 1] == "_")):
            m = re.match(r'R"([^(\s]*)\(', text[i:])
            if not m:
                out.append(c)
                i += 1
                continue
            end = text.find(")" + m.group(1) + '"', i)
            j = n if end < 0 else end + len(m.group(1)) + 2
            out.append('"' + re.sub(r"[^\n]", " ", text[i + 1:j - 1]) + '"')
            i = j
        elif c in "\"'":
            if c == "'" and i > 0 and text[i - 1].isalnum():  # digit separator 1'000
                out.append(" ")
                i += 1
                continue
            j = i + 1
            while j < n and text[j] != c and text[j] != "\n":
                j += 2 if text[j] == "\\" else 1
            j = min(j + 1, n)
            out.append(c + " " * (j - i - 2) + c if j - i >= 2 else c)
            i = j
        else:
            out.append(c)
            i += 1
    return "".join(out)


def blank_preprocessor(text: str) -> str:
    """Preprocessor lines (with their continuations) blanked."""
    lines = text.split("\n")
    cont = False
    for k, line in enumerate(lines):
        if cont or line.lstrip().startswith("#"):
            cont = line.rstrip().endswith("\\")
            lines[k] = ""
    return "\n".join(lines)


def function_name(header: str) -> str | None:
    """The qualified name before the parameter list, or None when it is not a function."""
    depth = 0
    for k, c in enumerate(header):
        if c in "<":
            depth += 1
        elif c == ">" and depth > 0:
            depth -= 1
        elif c == "(" and depth == 0:
            before = header[:k]
            if "=" in before.replace("operator=", "").replace("==", ""):
                return None
            m = re.search(r"((?:[A-Za-z_~][\w]*(?:<[^()]*>)?::)*(?:operator\s*\S+|~?[A-Za-z_]\w*))\s*$",
                          before)
            return m.group(1) if m else None
    return None


def cxx_functions(path: Path) -> list[Function]:
    text = blank_preprocessor(blank_comments_and_literals(path.read_text(errors="replace")))
    line_of = _line_index(text)
    found: list[Function] = []
    scopes: list[bool] = []  # True: transparent (namespace/class), False: a function body
    header_start = 0
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        if c == ";":
            header_start = i + 1
        elif c == "}":
            if scopes:
                scopes.pop()
            header_start = i + 1
        elif c == "{":
            header = text[header_start:i]
            # `template <class V>` before a function is not a class scope
            scope = TRANSPARENT.search(re.sub(r"\btemplate\s*<[^{};]*>", " ", header))
            if scope and "(" not in header.split(scope.group(1))[0]:
                scopes.append(True)
                header_start = i + 1
            elif (name := function_name(header)) is not None:
                end = _skip_initialiser_braces(text, header, i)
                close = _matching_brace(text, end)
                first = line_of(header_start + len(header) - len(header.lstrip()))
                found.append(Function(path, name, first, line_of(close) - first + 1))
                i = close
                header_start = close + 1
            else:  # an initialiser or enum body at namespace scope
                i = _matching_brace(text, i)
                header_start = i + 1
        i += 1
    return found


def _skip_initialiser_braces(text: str, header: str, i: int) -> int:
    """From a `{` after `) :`, the position of the body's `{` past `a_{x}` initialisers."""
    if not re.search(r"\)\s*(?:noexcept\s*)?:[^:]", header):
        return i
    while True:
        prev = text[:i].rstrip()
        if not prev or not (prev[-1].isalnum() or prev[-1] in "_>"):
            return i
        i = _matching_brace(text, i) + 1
        while i < len(text) and text[i] != "{":
            i += 1


def _matching_brace(text: str, i: int) -> int:
    depth = 0
    for j in range(i, len(text)):
        if text[j] == "{":
            depth += 1
        elif text[j] == "}":
            depth -= 1
            if depth == 0:
                return j
    return len(text) - 1


def _line_index(text: str):
    starts = [0] + [m.end() for m in re.finditer("\n", text)]
    return lambda pos: bisect.bisect_right(starts, pos)


def python_functions(path: Path) -> list[Function]:
    try:
        tree = ast.parse(path.read_text(errors="replace"))
    except SyntaxError:
        return []
    found = []
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            first = min([node.lineno] + [d.lineno for d in node.decorator_list])
            found.append(Function(path, node.name, first, node.end_lineno - first + 1))
    return found


def scan(root: Path) -> list[tuple[Function, int]]:
    rows = []
    for top, limit in LIMITS.items():
        base = root / top
        if not base.is_dir():
            continue
        for path in sorted(base.rglob("*")):
            if path.suffix in CXX_SUFFIXES:
                functions = cxx_functions(path)
            elif path.suffix == ".py":
                functions = python_functions(path)
            else:
                continue
            rows += [(f, limit) for f in functions]
    return rows


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("root", nargs="?", default=Path(__file__).resolve().parent.parent, type=Path)
    parser.add_argument("--top", type=int, default=10)
    parser.add_argument("--check", action="store_true")
    parser.add_argument("--allow", type=Path, help="functions allowed over the limit, up to a length")
    args = parser.parse_args()
    allowed = read_allow(args.allow) if args.allow else {}
    rows = scan(args.root)
    rows.sort(key=lambda r: -r[0].lines)
    print(f"{len(rows)} functions; the longest {args.top}:")
    for f, limit in rows[: args.top]:
        print(f"  {f.lines:5d} (limit {limit})  {f.path.relative_to(args.root)}:{f.first_line}  {f.name}")
    over = [(f, limit) for f, limit in rows if f.lines > limit]
    failing = []
    if over:
        print(f"{len(over)} over their directory's limit:")
        for f, limit in over:
            key = (str(f.path.relative_to(args.root)), f.name)
            ceiling = allowed.get(key)
            ok = ceiling is not None and f.lines <= ceiling
            note = f" (allowed up to {ceiling})" if ceiling is not None else ""
            print(f"  {f.lines:5d} > {limit}  {key[0]}:{f.first_line}  {f.name}{note}")
            if not ok:
                failing.append(f"{key[0]} {f.name}: {f.lines} lines > {ceiling or limit}")
    present = {(str(f.path.relative_to(args.root)), f.name) for f, limit in over}
    for key in sorted(set(allowed) - present):
        failing.append(f"{key[0]} {key[1]} is listed in {args.allow} but no longer over its limit: drop it")
    for line in failing:
        print("FAIL: " + line)
    return 1 if args.check and failing else 0


def read_allow(path: Path) -> dict[tuple[str, str], int]:
    allowed = {}
    for n, line in enumerate(path.read_text().splitlines(), 1):
        line = line.split("#")[0].strip()
        if not line:
            continue
        parts = line.split()
        if len(parts) != 3 or not parts[2].isdigit():
            sys.exit(f"{path}:{n}: expected 'PATH NAME LINES', got {line!r}")
        allowed[(parts[0], parts[1])] = int(parts[2])
    return allowed


if __name__ == "__main__":
    sys.exit(main())
