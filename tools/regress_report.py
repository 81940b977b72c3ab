#!/usr/bin/env python3
"""Self-contained HTML page of a regression-gate comparison (`lander regress ... --html FILE`).

Usage: python3 tools/regress_report.py REGRESS_JSON OUT_HTML

Reads REGRESS_JSON (written by `lander regress`) and the campaign.csv of the two campaigns it
names (current.dir, baseline.dir); writes OUT_HTML atomically: the gate's verdict and checks,
the paired statistics per group, the two touchdown-offset CDFs overlaid, the two touchdown
scatters overlaid (pairs joined), the runs whose landing changed with their rerun commands, and
the simulator failures. Plots are base64 PNG data URIs; the page has no external resource and
no script. The drawing helpers come from campaign_report.py (same folder).

Exit codes: 0 page written; 2 bad input (the message names the file); 1 anything else.
Needs only Debian 12's python3-matplotlib and python3-numpy.
"""

import os
import sys

USAGE = "usage: regress_report.py REGRESS_JSON OUT_HTML"


def _import_plotting():
    """matplotlib (Agg) and numpy; re-executes once under /usr/bin/python3 when this interpreter
    lacks them (campaign_report.py does the same, but it would re-execute itself, not us)."""
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot  # noqa: F401
        import numpy  # noqa: F401
        return
    except ImportError as e:
        err = e
    system_python = "/usr/bin/python3"
    if (os.environ.get("REGRESS_REPORT_REEXEC") != "1" and os.path.exists(system_python)
            and os.path.realpath(sys.executable) != os.path.realpath(system_python)):
        os.environ["REGRESS_REPORT_REEXEC"] = "1"
        os.execv(system_python, [system_python, os.path.abspath(__file__)] + sys.argv[1:])
    sys.stderr.write("regress_report: %s (install python3-matplotlib and python3-numpy)\n" % err)
    sys.exit(1)


_import_plotting()
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import json  # noqa: E402

import matplotlib  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import campaign_report as cr  # noqa: E402
from campaign_report import esc, fmt, num  # noqa: E402

BASELINE_COLOUR = "#1f77b4"
CURRENT_COLOUR = "#ff7f0e"
ZOOM_M = 0.15
MAX_CDF_PANELS = 7
STATUS_CLASS = {"fail": "fail", "pass": "pass", "not_evaluable": "na"}


# ---------------------------------------------------------------------------------------------
# input

def load_report(path):
    """regress.json as a dict; BadInput naming the file when it is not one."""
    try:
        with open(path, "rb") as f:
            doc = json.loads(f.read().decode("utf-8"))
    except OSError as e:
        raise cr.BadInput(path, "cannot read: %s" % (e.strerror or e))
    except (UnicodeDecodeError, ValueError) as e:
        raise cr.BadInput(path, "not valid JSON: %s" % e)
    if not isinstance(doc, dict) or not isinstance(doc.get("current"), dict) \
            or not isinstance(doc.get("baseline"), dict):
        raise cr.BadInput(path, "not a regress.json (no 'current' and 'baseline' objects)")
    return doc


def load_side(report, side):
    """({id: row} of one campaign's campaign.csv, its campaign.json) for the directory
    regress.json names."""
    d = cr.getd(report, side, "dir")
    if not isinstance(d, str) or not d:
        raise cr.BadInput("regress.json", "no %s.dir" % side)
    doc = cr.load_campaign(d)
    return {r["id"]: r for r in cr.load_rows(d, doc)}, doc


def paired_ids(base, cur):
    return [i for i in cur if i in base]


# ---------------------------------------------------------------------------------------------
# sections

def section_header(report):
    verdict = report.get("verdict")
    failed = report.get("failed_checks") if isinstance(report.get("failed_checks"), list) else []
    cls = "fail" if verdict == "fail" else "pass"
    out = ["<h1>Regression gate: %s</h1>" % esc(cr.getd(report, "current", "name") or "(unnamed)"),
           '<p class="verdict %s">%s</p>' % (cls, "FAIL: " + esc("; ".join(failed)) if verdict == "fail"
                                              else "PASS: no threshold crossed with confidence")]
    out.append('<table class="kv">')
    for side in ("current", "baseline"):
        s = report.get(side) if isinstance(report.get(side), dict) else {}
        out.append("<tr><th>%s</th><td><code>%s</code> &mdash; %s runs, %s simulator failure(s), master seed %s</td></tr>"
                   % (side, esc(s.get("dir")), esc(s.get("runs")), esc(s.get("simulator_failures")),
                      esc(s.get("master_seed"))))
    out.append("<tr><th>thresholds</th><td><code>%s</code></td></tr>" % esc(cr.getd(report, "thresholds", "file")))
    p = report.get("pairing") if isinstance(report.get("pairing"), dict) else {}
    out.append("<tr><th>paired runs</th><td>%s</td></tr>" % esc(p.get("paired")))
    for key, label in (("only_in_current", "only in the current campaign (left out)"),
                       ("only_in_baseline", "only in the baseline (left out)"),
                       ("inputs_only_in_current", "sampled inputs only in the current campaign"),
                       ("inputs_only_in_baseline", "sampled inputs only in the baseline")):
        v = p.get(key) if isinstance(p.get(key), list) else []
        if v:
            out.append("<tr><th>%s</th><td>%s</td></tr>" % (esc(label), ", ".join("<code>%s</code>" % esc(x) for x in v)))
    out.append("</table>")
    return "\n".join(out)


def section_checks(report):
    out = ['<h2 id="checks">Checks</h2>',
           '<p class="note">A check fails only with confidence: a growth when the difference (current &minus; '
           "baseline) is above its limit and its 95% interval lies wholly above 0; the landing rate when the "
           "interval of its difference lies wholly below &minus;limit points.</p>"]
    checks = report.get("checks") if isinstance(report.get("checks"), list) else []
    if not checks:
        out.append(cr.placeholder("no thresholds configured"))
        return "\n".join(out)
    out.append('<table class="stats checks"><thead><tr><th>status</th><th>group</th><th>check</th><th>value</th>'
               "<th>95% interval</th><th>limit</th><th>unit</th><th>n</th><th>result</th><th>reason</th>"
               "</tr></thead><tbody>")
    for c in checks:
        if not isinstance(c, dict):
            continue
        ci = c.get("ci95") if isinstance(c.get("ci95"), list) and len(c.get("ci95")) == 2 else None
        status = str(c.get("status"))
        out.append('<tr class="%s"><td>%s</td><td>%s</td><td><code>%s</code></td><td>%s</td><td>%s</td>'
                   '<td>%s</td><td>%s</td><td>%s</td><td class="left">%s</td><td class="left">%s</td></tr>' % (
                       STATUS_CLASS.get(status, "na"), esc(status), esc(c.get("group")), esc(c.get("check")),
                       fmt(c.get("value"), 1, 4), "[%s, %s]" % (fmt(ci[0], 1, 4), fmt(ci[1], 1, 4)) if ci else "&ndash;",
                       esc(c.get("limit")), esc(c.get("unit")), esc(c.get("n")), esc(c.get("message")),
                       esc(c.get("reason"))))
    out.append("</tbody></table>")
    return "\n".join(out)


def change_cells(s, scale, digits):
    """baseline, current, difference [interval] cells of a {baseline, current, difference, ci95}."""
    s = s if isinstance(s, dict) else {}
    ci = s.get("ci95") if isinstance(s.get("ci95"), list) and len(s.get("ci95")) == 2 else None
    diff = fmt(s.get("difference"), scale, digits)
    if ci:
        diff += ' <span class="ci">[%s, %s]</span>' % (fmt(ci[0], scale, digits), fmt(ci[1], scale, digits))
    return "<td>%s</td><td>%s</td><td>%s</td>" % (fmt(s.get("baseline"), scale, digits),
                                                  fmt(s.get("current"), scale, digits), diff)


def group_row(name, g, overall=False):
    g = g if isinstance(g, dict) else {}
    cells = ["<th>%s</th>" % esc(name), "<td>%s</td>" % esc(g.get("runs")),
             change_cells(g.get("landing_rate"), 100, 1),
             change_cells(cr.getd(g, "touchdown_offset_m", "median"), 100, 2),
             change_cells(cr.getd(g, "touchdown_offset_m", "p95"), 100, 2),
             "<td>%s</td>" % esc(cr.getd(g, "touchdown_offset_m", "n")),
             change_cells(cr.getd(g, "touchdown_rel_speed_mps", "median"), 1, 3),
             change_cells(cr.getd(g, "time_to_land_s", "median"), 1, 2),
             "<td>%s / %s</td>" % (esc(g.get("landed_to_not_landed")), esc(g.get("not_landed_to_landed"))),
             "<td>%s &rarr; %s</td>" % (esc(cr.getd(g, "simulator_failures", "baseline")),
                                        esc(cr.getd(g, "simulator_failures", "current")))]
    return '<tr%s>%s</tr>' % (' class="overall"' if overall else "", "".join(cells))


def section_groups(report):
    out = ['<h2 id="groups">Paired statistics</h2>',
           '<p class="note">Baseline, current, and difference with its 95% interval: Newcombe (paired) for the '
           "landing rate, paired bootstrap for the touchdown figures, which are over the runs landed in both.</p>",
           '<table class="stats"><thead><tr><th rowspan="2">group</th><th rowspan="2">pairs</th>'
           '<th colspan="3">landing rate (%)</th><th colspan="3">offset median (cm)</th>'
           '<th colspan="3">offset p95 (cm)</th><th rowspan="2">landed in both</th>'
           '<th colspan="3">rel. speed median (m/s)</th><th colspan="3">time to land median (s)</th>'
           '<th rowspan="2">lost / gained landings</th><th rowspan="2">simulator failures</th></tr><tr>'
           + "<th>base</th><th>cur</th><th>diff [95%]</th>" * 5 + "</tr></thead><tbody>"]
    sc = report.get("scenarios") if isinstance(report.get("scenarios"), dict) else {}
    if len(sc) > 1:
        for name, g in sc.items():
            out.append(group_row(name, g))
    out.append(group_row("overall", report.get("overall"), overall=True))
    out.append("</tbody></table>")
    return "\n".join(out)


def offsets_cm(rows, ids, scenario=None):
    v = []
    for i in ids:
        r = rows[i]
        if cr.is_true(r.get("landed")) and (scenario is None or r.get("scenario") == scenario):
            x = num(r.get("touchdown_offset_m"))
            if x is not None:
                v.append(100 * x)
    return np.sort(np.array(v))


def draw_cdf(ax, values, colour, label, style="-"):
    if not len(values):
        return
    x = np.concatenate([[0.0], values])
    y = np.concatenate([[0.0], np.arange(1, len(values) + 1) / len(values)])
    ax.step(x, y, where="post", color=colour, lw=1.6, ls=style, label="%s (n=%d)" % (label, len(values)))


def section_cdf(report, base, cur, ids):
    out = ['<h2 id="cdf">Touchdown offset: empirical CDFs</h2>',
           '<p class="note">Landed runs among the paired ids, each campaign its own; the fraction reaches 1 at '
           "the largest offset of the runs that landed.</p>"]
    groups = [None]
    sc = report.get("scenarios") if isinstance(report.get("scenarios"), dict) else {}
    if len(sc) > 1:
        groups += list(sc.keys())[:MAX_CDF_PANELS - 1]
    if not any(len(offsets_cm(rows, ids)) for rows in (base, cur)):
        out.append(cr.placeholder("no landed runs in either campaign"))
        return "\n".join(out)
    fig, axes = plt.subplots(1, len(groups), figsize=(5.2 * len(groups), 4.2), squeeze=False)
    for ax, g in zip(axes[0], groups):
        b, c = offsets_cm(base, ids, g), offsets_cm(cur, ids, g)
        draw_cdf(ax, b, BASELINE_COLOUR, "baseline")
        draw_cdf(ax, c, CURRENT_COLOUR, "current")
        top = max([10.0] + [float(v[-1]) for v in (b, c) if len(v)])
        ax.set_xlim(0, top * 1.05)
        ax.set_ylim(0, 1.02)
        ax.set_title(cr.mpl_text("overall" if g is None else g))
        ax.set_xlabel("touchdown offset (cm)")
        ax.set_ylabel("fraction of landed runs \u2264 offset")
        ax.grid(True, lw=0.3, alpha=0.5)
        ax.legend(fontsize=8, loc="lower right")
    out.append(cr.fig_to_img(fig, "offset_cdf", "touchdown offset CDFs of the baseline and the current campaign"))
    return "\n".join(out)


def touchdown_point(r):
    if not cr.is_true(r.get("landed")):
        return None
    x, y = num(r.get("touchdown_x_P_m")), num(r.get("touchdown_y_P_m"))
    return None if x is None or y is None else (x, y)


def section_touchdown(base, cur, ids, limit):
    out = ['<h2 id="touchdown">Touchdown points (platform frame)</h2>',
           '<p class="note">Baseline hollow, current filled; a grey segment joins the two touchdowns of a run '
           "that landed in both.</p>"]
    pb = {i: touchdown_point(base[i]) for i in ids}
    pc = {i: touchdown_point(cur[i]) for i in ids}
    bpts = np.array([p for p in pb.values() if p is not None]).reshape(-1, 2)
    cpts = np.array([p for p in pc.values() if p is not None]).reshape(-1, 2)
    if not len(bpts) and not len(cpts):
        out.append(cr.placeholder("no touchdown points in either campaign"))
        return "\n".join(out)
    allp = np.vstack([bpts, cpts])
    span = max(1.05, float(np.max(np.abs(allp))) * 1.05)
    fig, axes = plt.subplots(1, 2, figsize=(11, 5.4))
    for ax, lim, title in ((axes[0], span, "whole platform"), (axes[1], ZOOM_M, "zoom \u00b115 cm")):
        cr.draw_platform(ax, limit)
        for i in ids:
            if pb[i] is not None and pc[i] is not None:
                ax.plot([pb[i][0], pc[i][0]], [pb[i][1], pc[i][1]], color="0.6", lw=0.6, zorder=2)
        if len(bpts):
            ax.scatter(bpts[:, 0], bpts[:, 1], s=18, facecolors="none", edgecolors=BASELINE_COLOUR, linewidths=0.9,
                       label="baseline (n=%d)" % len(bpts), zorder=3)
        if len(cpts):
            ax.scatter(cpts[:, 0], cpts[:, 1], s=10, color=CURRENT_COLOUR, edgecolors="k", linewidths=0.2,
                       label="current (n=%d)" % len(cpts), zorder=4)
        ax.set_xlim(-lim, lim)
        ax.set_ylim(-lim, lim)
        ax.set_aspect("equal")
        ax.set_xlabel("x_P (m)")
        ax.set_ylabel("y_P (m)")
        ax.set_title(title)
        ax.grid(True, lw=0.3, alpha=0.5)
    axes[0].legend(loc="upper left", bbox_to_anchor=(0.0, -0.12), ncol=3, fontsize=8, frameon=False)
    out.append(cr.fig_to_img(fig, "touchdown", "touchdown points of the baseline and the current campaign"))
    return "\n".join(out)


def section_transitions(report):
    out = ['<h2 id="transitions">Runs whose landing changed</h2>']
    for key, title in (("landed_to_not_landed", "landed in the baseline, not now"),
                       ("not_landed_to_landed", "not landed in the baseline, landed now")):
        runs = cr.getd(report, "transitions", key)
        runs = runs if isinstance(runs, list) else []
        out.append("<h3>%s (%d)</h3>" % (esc(title), len(runs)))
        if not runs:
            out.append(cr.placeholder("none"))
            continue
        out.append('<table class="stats worst"><thead><tr><th>id</th><th>scenario</th><th>baseline</th>'
                   "<th>offset (cm)</th><th>current</th><th>offset (cm)</th><th>detail</th><th>rerun</th>"
                   "</tr></thead><tbody>")
        for t in runs:
            if not isinstance(t, dict):
                continue
            out.append('<tr><td><code>%s</code></td><td>%s</td><td>%s</td><td>%s</td><td>%s</td><td>%s</td>'
                       '<td class="left">%s</td><td class="left"><code class="cmd">%s</code></td></tr>' % (
                           esc(t.get("id")), esc(t.get("scenario")), esc(cr.getd(t, "baseline", "outcome")),
                           fmt(cr.getd(t, "baseline", "touchdown_offset_m"), 100, 1),
                           esc(cr.getd(t, "current", "outcome")),
                           fmt(cr.getd(t, "current", "touchdown_offset_m"), 100, 1),
                           esc(cr.getd(t, "current", "detail")), esc(t.get("rerun"))))
        out.append("</tbody></table>")
    return "\n".join(out)


def section_simulator_failures(report):
    f = report.get("simulator_failures") if isinstance(report.get("simulator_failures"), dict) else {}
    out = ['<h2 id="failures">Simulator failures</h2>',
           '<p class="note">Over the paired runs: %s in the baseline, %s in the current campaign.</p>'
           % (esc(f.get("paired_baseline")), esc(f.get("paired_current")))]
    runs = f.get("current_runs") if isinstance(f.get("current_runs"), list) else []
    if not runs:
        out.append(cr.placeholder("none in the current campaign"))
        return "\n".join(out)
    out.append('<table class="stats worst"><thead><tr><th>id</th><th>scenario</th><th>status</th>'
               "<th>baseline status</th><th>detail</th><th>rerun</th></tr></thead><tbody>")
    for r in runs:
        if isinstance(r, dict):
            out.append('<tr><td><code>%s</code></td><td>%s</td><td>%s</td><td>%s</td><td class="left">%s</td>'
                       '<td class="left"><code class="cmd">%s</code></td></tr>' % (
                           esc(r.get("id")), esc(r.get("scenario")), esc(r.get("status")),
                           esc(r.get("baseline_status")), esc(r.get("detail")), esc(r.get("rerun"))))
    out.append("</tbody></table>")
    return "\n".join(out)


def section_methods(report):
    m = report.get("methods") if isinstance(report.get("methods"), dict) else {}
    out = ['<h2 id="methods">Methods</h2>', '<table class="kv">']
    for k, v in m.items():
        out.append("<tr><th>%s</th><td>%s</td></tr>" % (esc(k), esc(v)))
    out.append("</table>")
    return "\n".join(out)


CSS = cr.CSS + """
.verdict{font-size:16px;font-weight:bold;padding:6px 10px;display:inline-block}
.verdict.fail{background:#fde0dc;color:#a00}.verdict.pass{background:#e3f4e1;color:#165c12}
table.checks tr.fail td{background:#fde0dc}table.checks tr.na td{color:#777}
"""


def build_page(report, base, cur, limit):
    ids = paired_ids(base, cur)
    title = "Regression gate: %s" % (cr.getd(report, "current", "name") or "(unnamed)")
    return "\n".join([
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        '<meta name="viewport" content="width=device-width, initial-scale=1">',
        "<title>%s</title>" % esc(title),
        "<style>%s</style></head><body>" % CSS,
        section_header(report),
        '<nav><a href="#checks">checks</a><a href="#groups">paired statistics</a><a href="#cdf">offset CDFs</a>'
        '<a href="#touchdown">touchdown points</a><a href="#transitions">changed landings</a>'
        '<a href="#failures">simulator failures</a><a href="#methods">methods</a></nav>',
        section_checks(report),
        section_groups(report),
        section_cdf(report, base, cur, ids),
        section_touchdown(base, cur, ids, limit),
        section_transitions(report),
        section_simulator_failures(report),
        section_methods(report),
        "</body></html>",
    ]) + "\n"


def main(argv):
    if len(argv) != 3 or argv[1] in ("-h", "--help"):
        sys.stderr.write(USAGE + "\n")
        return 0 if len(argv) == 2 and argv[1] in ("-h", "--help") else 2
    try:
        report = load_report(argv[1])
        base, _ = load_side(report, "baseline")
        cur, cur_doc = load_side(report, "current")
    except cr.BadInput as e:
        sys.stderr.write("regress_report: %s: %s\n" % (e.path, e.problem))
        return 2
    matplotlib.rcParams.update({"font.size": 9, "axes.titlesize": 10, "svg.hashsalt": "lander"})
    limit = num(cur_doc.get("offset_limit_m"))
    page = build_page(report, base, cur, limit if limit and limit > 0 else cr.DEFAULT_OFFSET_LIMIT_M)
    try:
        cr.write_atomic(argv[2], page)
    except OSError as e:
        sys.stderr.write("regress_report: %s: cannot write: %s\n" % (argv[2], e.strerror or e))
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
