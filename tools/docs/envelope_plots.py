#!/usr/bin/python3
"""Draws the landing envelope's plots for docs/results/landing-envelope.md from the committed
baseline, with the campaign report's own code (tools/campaign_report.py).

Usage: /usr/bin/python3 tools/docs/envelope_plots.py [--baseline regression/envelope] [--out docs/assets]

Copies the baseline's merged files (campaign.json, campaign.csv, ...) to a temporary
directory, runs campaign_report.py there (it draws the touchdown points, the offset CDF, the
landing rate per scenario and the time to land; failed runs have no trace.csv in a baseline,
so their per-run plots are left out), and writes each plot of report.html as
OUT/envelope_<plot>.png.
"""
import argparse
import base64
import os
import re
import shutil
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.normpath(os.path.join(HERE, "..", ".."))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--baseline", default=os.path.join(REPO, "regression", "envelope"))
    ap.add_argument("--out", default=os.path.join(REPO, "docs", "assets"))
    a = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="envelope-plots-") as tmp:
        d = os.path.join(tmp, "envelope")
        shutil.copytree(a.baseline, d)
        subprocess.run(["/usr/bin/python3", os.path.join(REPO, "tools", "campaign_report.py"), d],
                       check=True)
        with open(os.path.join(d, "report.html"), encoding="utf-8") as f:
            page = f.read()
    plots = re.findall(r'<img[^>]*data-plot="([^"]+)"[^>]*src="data:image/png;base64,([^"]+)"', page)
    plots += [(n, s) for s, n in re.findall(r'<img[^>]*src="data:image/png;base64,([^"]+)"[^>]*data-plot="([^"]+)"', page)]
    if not plots:
        sys.exit("envelope_plots: no plot found in the report")
    os.makedirs(a.out, exist_ok=True)
    for name, b64 in plots:
        path = os.path.join(a.out, "envelope_%s.png" % name)
        with open(path, "wb") as f:
            f.write(base64.b64decode(b64))
        print(path)


if __name__ == "__main__":
    main()
