#!/usr/bin/python3
"""Checks that every repository path the documentation names exists.

Usage: /usr/bin/python3 tools/docs/check_paths.py [--repo DIR] [--list] [FILE.md ...]
       (default files: README.md, CHANGELOG.md and every docs/**/*.md)

What counts as a path (the rule, so that a reader can predict it):
- the words of every inline code span (`...`) and of every fenced code block marked sh,
  bash, shell or console (yaml, text and unmarked blocks hold no repository paths by
  convention: file trees, campaign files whose paths are relative to the campaign), and the
  target of every Markdown link or image in README.md and CHANGELOG.md (MkDocs checks the
  ones in docs/ itself);
- a word is a path when, after stripping the punctuation around it, its first component is a
  top-level entry of the repository (`scenarios/...`, `README.md`), or it has at least two
  components and ends with '/' or a file extension (`.md`, `.h`, `.cpp`, `.py`, `.sh`,
  `.yaml`, `.yml`, `.xml`, `.png`, `.mp4`, `.csv`, `.json`, `.txt`, `.cmake`, `.html`);
- skipped, with the reason listed by --list: outputs (under `out/`, `build/`, `build-*/`,
  `site/`, `fuzz-artifacts/`, `/tmp`, or any absolute path), paths outside the repository
  (starting with `../` or `~`), URLs, and placeholders (a component with `<`, `>`, `*`, `?`,
  `{`, `}`, `$`, `...`, or written in capitals like `DIR`, `F`, `X.yaml`, `CAMPAIGN.yaml`);
- a path is taken relative to the repository's root; a Markdown link target in a file is
  taken relative to that file. A trailing `:LINE` is dropped.

Exit 0 when every path exists, 1 naming each missing one as FILE:LINE: PATH, 2 on bad usage.
"""

import argparse
import os
import re
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
EXTENSIONS = (".md", ".h", ".cpp", ".py", ".sh", ".yaml", ".yml", ".xml", ".png", ".mp4", ".csv",
              ".json", ".txt", ".cmake", ".html")
OUTPUT_DIRS = ("out", "build", "site", "fuzz-artifacts")
SHELL_FENCES = ("sh", "bash", "shell", "console")
STRIP = "()[],;:'\"!?"
PLACEHOLDER_CHARS = set("<>*?{}$")
CAPS_RE = re.compile(r"^[A-Z][A-Z0-9_]*(?:\.[A-Za-z0-9]+)?$")


def top_level(repo):
    """Names at the repository's root: tracked by git when it is a git work tree, else on disk."""
    try:
        out = subprocess.run(["git", "-C", repo, "ls-files"], capture_output=True, text=True, check=True).stdout
        names = {p.split("/")[0] for p in out.split("\n") if p}
        if names:
            return names | set(os.listdir(repo))
    except (OSError, subprocess.CalledProcessError):
        pass
    return set(os.listdir(repo))


def doc_files(repo):
    files = [os.path.join(repo, f) for f in ("README.md", "CHANGELOG.md") if os.path.exists(os.path.join(repo, f))]
    for root, dirs, names in os.walk(os.path.join(repo, "docs")):
        dirs[:] = sorted(d for d in dirs if not os.path.islink(os.path.join(root, d)))
        files += [os.path.join(root, n) for n in sorted(names) if n.endswith(".md")]
    return files


def spans(text):
    """(line number, word, kind) of every candidate word: inline code and shell fences."""
    out = []
    fence = None
    for n, line in enumerate(text.split("\n"), 1):
        m = re.match(r"^\s*(```+|~~~+)\s*([\w-]*)", line)
        if m:
            if fence is None:
                fence = m.group(2).lower() or "-"
            else:
                fence = None
            continue
        if fence is not None:
            if fence in SHELL_FENCES:
                code = line.split(" #")[0]
                out += [(n, w, "fence") for w in code.split()]
            continue
        for c in re.findall(r"(?<!`)`([^`]+)`(?!`)", line):
            out += [(n, w, "code") for w in c.split()]
    return out


def links(text):
    out = []
    for n, line in enumerate(text.split("\n"), 1):
        for target in re.findall(r"\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)", line):
            out.append((n, target))
    return out


def classify(word, tops):
    """(path or None, reason it is not checked or None)."""
    w = word.strip(STRIP)
    w = re.sub(r":\d+(?:-\d+)?$", "", w)
    if not w or "/" not in w and w not in tops:
        return None, None
    if re.match(r"^[a-z]+://", w) or w.startswith("mailto:"):
        return None, "url"
    if w.startswith(("../", "~")):
        return None, "outside the repository"
    if w.startswith("/"):
        return None, "absolute path (an output or outside the repository)"
    if w.startswith("./"):
        w = w[2:]
    comps = [c for c in w.split("/") if c]
    if not comps:
        return None, None
    first = comps[0]
    looks_like_path = first in tops or (
        len(comps) >= 2 and (w.endswith("/") or comps[-1].lower().endswith(EXTENSIONS)))
    if not looks_like_path:
        return None, None
    if first in OUTPUT_DIRS or first.startswith("build-") or first.startswith("build."):
        return None, "output"
    for c in comps:
        if PLACEHOLDER_CHARS & set(c) or "..." in c or CAPS_RE.match(c):
            return None, "placeholder"
    return w, None


def check(repo, files, listing=False):
    tops = top_level(repo)
    missing = []
    for path in files:
        rel = os.path.relpath(path, repo)
        with open(path, encoding="utf-8") as f:
            text = f.read()
        for n, word, _ in spans(text):
            p, why = classify(word, tops)
            if listing and (p or why):
                print("%s:%d: %s %s" % (rel, n, word, "checked" if p else "skipped: " + why))
            if p and not os.path.lexists(os.path.join(repo, p)):
                missing.append("%s:%d: %s" % (rel, n, p))
        if not rel.startswith("docs" + os.sep):
            for n, target in links(text):
                t = target.split("#")[0]
                if not t or re.match(r"^[a-z]+://", t) or t.startswith("mailto:"):
                    continue
                full = os.path.normpath(os.path.join(os.path.dirname(path), t))
                if listing:
                    print("%s:%d: link %s checked" % (rel, n, target))
                if not os.path.lexists(full):
                    missing.append("%s:%d: link %s" % (rel, n, target))
    return missing


def main():
    ap = argparse.ArgumentParser(description="Every repository path named in the docs exists.")
    ap.add_argument("--repo", default=os.path.normpath(os.path.join(HERE, "..", "..")))
    ap.add_argument("--list", action="store_true", help="print every candidate and what was done with it")
    ap.add_argument("files", nargs="*")
    a = ap.parse_args()
    repo = os.path.abspath(a.repo)
    files = [os.path.abspath(f) for f in a.files] or doc_files(repo)
    if not files:
        sys.stderr.write("check_paths: no documentation files under %s\n" % repo)
        return 2
    missing = check(repo, files, a.list)
    for m in missing:
        print("check_paths: missing: " + m)
    n = len(files)
    if missing:
        print("check_paths: %d path(s) named in %d file(s) do not exist" % (len(missing), n))
        return 1
    print("check_paths: every path named in %d file(s) exists" % n)
    return 0


if __name__ == "__main__":
    sys.exit(main())
