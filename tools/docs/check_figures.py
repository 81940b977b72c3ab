#!/usr/bin/python3
"""Lists the figures of an old README that the documentation no longer holds.

Usage: /usr/bin/python3 tools/docs/check_figures.py OLD_README.md [--context]
       (e.g. git show b7acab1:README.md > /tmp/old.md; the README before issue 51)

A figure is a number with at least two significant characters (12, 0.5, 2.54, 98.5, 1e-6;
single digits are too common to mean anything); each must occur, as the same token, in
README.md, CHANGELOG.md or a page under docs/. Exit 1 listing the ones missing, with the
line of the old README they stood on when --context is given.
"""
import os
import re
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.normpath(os.path.join(HERE, "..", ".."))
NUM = re.compile(r"(?<![\w.])(\d+(?:\.\d+)?(?:e-?\d+)?)(?![\w])")


def tokens(text):
    return set(m.group(1) for m in NUM.finditer(text) if len(m.group(1).replace(".", "")) >= 2)


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    old = open(sys.argv[1], encoding="utf-8").read()
    new = ""
    for f in ("README.md", "CHANGELOG.md"):
        p = os.path.join(REPO, f)
        if os.path.exists(p):
            new += open(p, encoding="utf-8").read()
    for root, dirs, files in os.walk(os.path.join(REPO, "docs")):
        for fn in files:
            if fn.endswith(".md"):
                new += open(os.path.join(root, fn), encoding="utf-8").read()
    have = tokens(new)
    missing = sorted(tokens(old) - have, key=lambda x: float(x))
    if "--context" in sys.argv:
        for n, line in enumerate(old.split("\n"), 1):
            miss = [t for t in tokens(line) if t in missing]
            if miss:
                print("%d: %s: %s" % (n, ", ".join(miss), line.strip()[:140]))
    print("check_figures: %d distinct figures in the old README, %d not found in the docs%s"
          % (len(tokens(old)), len(missing), (": " + " ".join(missing)) if missing else ""))
    return 1 if missing else 0


if __name__ == "__main__":
    sys.exit(main())
