#!/usr/bin/python3
"""Draws the landing mode machine (docs/design/landing-modes.md) as a PNG with matplotlib.

Usage: /usr/bin/python3 tools/docs/mode_diagram.py --lander build/lander docs/assets/mode_machine.png

The arrows are the transition table the machine enforces, read from `lander docs transitions`
(ctl::mode_transitions(), controller/src/modes/transitions.cpp): every rule of the table is
drawn, and the script fails if the table has a mode or a rule it has no place or label for.
"""
import argparse
import json
import subprocess
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.patches import FancyArrowPatch, FancyBboxPatch  # noqa: E402

NODES = {  # name: (x, y)
    "search": (1.0, 4.0), "follow_path": (1.0, 1.6), "observe": (4.0, 4.0),
    "approach": (7.0, 4.0), "recovery": (10.0, 4.0), "touchdown": (10.0, 1.6),
    "landed": (13.0, 1.6), "go_around": (7.0, 6.6), "aborted": (4.0, 1.0),
}
LAYOUT = [  # (from, to, label, curvature): how each rule of the table is drawn
    ("search", "observe", "3 keyframes", 0.0),
    ("search", "follow_path", "route in view", 0.6),
    ("follow_path", "search", "route lost 2 s", 0.6),
    ("follow_path", "observe", "3 keyframes", -0.15),
    ("observe", "search", "lost 1 s", -0.35),
    ("observe", "approach", "80 keyframes, close", 0.0),
    ("approach", "recovery", "|Diff| < 5 cm at t_d", 0.0),
    ("approach", "go_around", "lost, low", 0.0),
    ("approach", "search", "lost, high", -0.3),
    ("recovery", "go_around", "lost / error / gate", 0.2),
    ("recovery", "touchdown", "cut", 0.0),
    ("touchdown", "landed", "contact", 0.0),
    ("touchdown", "go_around", "no contact 2 s", 0.3),
    ("go_around", "observe", "height, in view", 0.0),
    ("go_around", "search", "height, not in view", 0.25),
    ("search", "aborted", "30 s, nothing", -0.1),
    ("approach", "aborted", "", 0.0),
    ("recovery", "aborted", "", 0.0),
]
# Drawn as the footnote instead of arrows across the figure.
FOOTNOTE = {("approach", "aborted"), ("recovery", "aborted")}


def edges_of(table):
    """The table's rules with their drawing: every rule must have one."""
    layout = {(a, b): (label, rad) for a, b, label, rad in LAYOUT}
    edges = []
    for row in table:
        pair = (row["from"], row["to"])
        if row["from"] not in NODES or row["to"] not in NODES:
            sys.exit("mode_diagram: mode of %s -> %s has no place in NODES" % pair)
        if pair not in layout:
            sys.exit("mode_diagram: rule %s -> %s has no drawing in LAYOUT" % pair)
        if pair not in FOOTNOTE:
            edges.append((pair[0], pair[1]) + layout[pair])
    return edges


def draw(edges, out):
    fig, ax = plt.subplots(figsize=(12, 6.2), dpi=100)
    ax.set_xlim(-0.3, 14.3)
    ax.set_ylim(0.2, 7.4)
    ax.axis("off")
    w, h = 1.9, 0.8
    for name, (x, y) in NODES.items():
        colour = {"landed": "#cdeccd", "aborted": "#f3d0d0"}.get(name, "#dde7f5")
        ax.add_patch(FancyBboxPatch((x - w / 2, y - h / 2), w, h, boxstyle="round,pad=0.05",
                                    fc=colour, ec="#334", lw=1.4))
        ax.text(x, y, name, ha="center", va="center", fontsize=12, family="monospace")
    for a, b, label, rad in edges:
        (x0, y0), (x1, y1) = NODES[a], NODES[b]
        arrow = FancyArrowPatch((x0, y0), (x1, y1), connectionstyle="arc3,rad=%.2f" % rad,
                                arrowstyle="-|>", mutation_scale=14, lw=1.2, color="#445",
                                shrinkA=30, shrinkB=30)
        ax.add_patch(arrow)
        mx, my = (x0 + x1) / 2, (y0 + y1) / 2
        dx, dy = x1 - x0, y1 - y0
        mx, my = mx + rad * dy * 0.5, my - rad * dx * 0.5  # the arc3 curve's midpoint
        ax.text(mx, my + 0.12, label, ha="center", va="bottom", fontsize=8.5, color="#223",
                bbox=dict(fc="white", ec="none", alpha=0.8, pad=0.5))
    ax.text(7.0, 0.35, "any failed attempt after max_landing_attempts (3) -> aborted",
            ha="center", fontsize=9, color="#822")
    fig.tight_layout()
    fig.savefig(out, facecolor="white")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--lander", required=True, help="the lander binary (build/lander)")
    parser.add_argument("out", help="the PNG to write")
    a = parser.parse_args()
    table = json.loads(subprocess.run([a.lander, "docs", "transitions"], check=True, capture_output=True,
                                      text=True).stdout)
    draw(edges_of(table), a.out)


if __name__ == "__main__":
    main()
