#!/usr/bin/python3
"""Tests of tools/docs/check_paths.py on a small repository made in a temporary directory:
a missing path is reported with its file and line, existing ones pass, outputs, placeholders
and paths outside the repository are skipped, README links are checked.

Usage: /usr/bin/python3 tests/docs/check_paths_test.py
"""
import os
import subprocess
import sys
import tempfile
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
CHECK = os.path.normpath(os.path.join(HERE, "..", "..", "tools", "docs", "check_paths.py"))


class CheckPaths(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory(prefix="check-paths-")
        self.repo = self.tmp.name
        for d in ("docs/guide", "scenarios", "tools"):
            os.makedirs(os.path.join(self.repo, d))
        for f in ("scenarios/default.yaml", "tools/test.sh"):
            open(os.path.join(self.repo, f), "w").close()

    def tearDown(self):
        self.tmp.cleanup()

    def write(self, rel, text):
        with open(os.path.join(self.repo, rel), "w") as f:
            f.write(text)

    def check(self):
        p = subprocess.run([sys.executable, CHECK, "--repo", self.repo], capture_output=True, text=True)
        return p.returncode, p.stdout + p.stderr

    def test_existing_paths_pass(self):
        self.write("README.md", "Run `scenarios/default.yaml` with `bash tools/test.sh`; see [g](docs/guide/a.md).\n")
        self.write("docs/guide/a.md", "```sh\nbash tools/test.sh   # `scenarios/missing.yaml` in a comment\n```\n")
        rc, out = self.check()
        self.assertEqual(rc, 0, out)

    def test_missing_path_is_named_with_file_and_line(self):
        self.write("README.md", "ok\n")
        self.write("docs/guide/a.md", "line one\nthe file `scenarios/no_such.yaml` moved\n")
        rc, out = self.check()
        self.assertEqual(rc, 1, out)
        self.assertIn("docs/guide/a.md:2: scenarios/no_such.yaml", out)

    def test_moved_source_file_with_two_components_is_caught(self):
        # not under a top-level entry of this repository, but it looks like a file path
        self.write("README.md", "written once, in `sim/src/world.cpp`\n")
        rc, out = self.check()
        self.assertEqual(rc, 1, out)
        self.assertIn("README.md:1: sim/src/world.cpp", out)

    def test_shell_fences_are_checked_other_fences_are_not(self):
        self.write("README.md", "```sh\nbash tools/missing.sh\n```\n```\ntools/tree_only/\n```\n")
        rc, out = self.check()
        self.assertEqual(rc, 1, out)
        self.assertIn("tools/missing.sh", out)
        self.assertNotIn("tree_only", out)

    def test_outputs_placeholders_and_outside_paths_are_skipped(self):
        self.write("README.md", "`out/default/summary.json` `build/lander` `/tmp/env` `scenarios/X.yaml` "
                   "`runs/<id>/` `campaigns/*.yaml` `../shared/seeds/` `DIR/campaign.csv` "
                   "`https://example.org/a/b.md`\n")
        rc, out = self.check()
        self.assertEqual(rc, 0, out)

    def test_broken_readme_link_is_caught(self):
        self.write("README.md", "see [the guide](docs/guide/nowhere.md)\n")
        rc, out = self.check()
        self.assertEqual(rc, 1, out)
        self.assertIn("README.md:1: link docs/guide/nowhere.md", out)


if __name__ == "__main__":
    unittest.main(verbosity=2)
