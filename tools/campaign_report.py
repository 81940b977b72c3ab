#!/usr/bin/env python3
"""Self-contained HTML report of a landing campaign.

Usage: python3 tools/campaign_report.py DIR

Reads DIR/campaign.json, DIR/campaign.csv, every run's DIR/runs/<id>/summary.json
(for the moving-deck figures) and, for runs that did not land and a few deck runs,
DIR/runs/<id>/trace.csv and DIR/runs/<id>/run.json; writes DIR/report.html
atomically (DIR/report.html.tmp, then rename). Every plot is a base64 PNG data
URI and the page has no external resources and no script, so it opens from
disk anywhere.

Exit codes: 0 report written; 2 bad input (the message names the file);
1 anything else (a missing dependency, an unwritable directory).
Needs only Debian 12's python3-matplotlib and python3-numpy.
"""

import os
import sys

USAGE = "usage: campaign_report.py DIR   (reads DIR/campaign.json, DIR/campaign.csv; writes DIR/report.html)"


def _import_plotting():
    """matplotlib with the Agg backend, and numpy. If this interpreter lacks them (a pyenv or
    venv python3 ahead of Debian's in PATH), re-executes once under /usr/bin/python3."""
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot  # noqa: F401
        import numpy  # noqa: F401
        return
    except ImportError as e:
        err = e
    system_python = "/usr/bin/python3"
    if (os.environ.get("CAMPAIGN_REPORT_REEXEC") != "1" and os.path.exists(system_python)
            and os.path.realpath(sys.executable) != os.path.realpath(system_python)):
        os.environ["CAMPAIGN_REPORT_REEXEC"] = "1"
        os.execv(system_python, [system_python, os.path.abspath(__file__)] + sys.argv[1:])
    sys.stderr.write("campaign_report: %s (install python3-matplotlib and python3-numpy)\n" % err)
    sys.exit(1)


_import_plotting()

import base64  # noqa: E402
import csv  # noqa: E402
import html  # noqa: E402
import io  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import re  # noqa: E402
import struct  # noqa: E402

import matplotlib  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.patches import Circle, Rectangle  # noqa: E402

csv.field_size_limit(1 << 26)

DPI = 90
MAX_TRACE_POINTS = 2000
MAX_FAILED_PLOTS = 12
MAX_LISTED_MISSING = 200
DEFAULT_OFFSET_LIMIT_M = 0.10
PLATFORM_SIDE_M = 1.8
RING_OUTER_RADIUS_M = 0.38
SIMULATOR_FAILURES = ("crashed", "error", "hung", "diverged")
# Rank of "how bad" an outcome is, used to order the failed runs (lower = shown first).
OUTCOME_RANK = {"crashed": 0, "error": 1, "hung": 2, "diverged": 3, "tipped_over": 4,
                "touched_ground": 5, "aborted": 6, "timeout": 7, "route_end": 8}
MODE_COLOURS = {"search": "#1f77b4", "observe": "#17becf", "approach": "#2ca02c",
                "recovery": "#ff7f0e", "touchdown": "#9467bd", "landed": "#000000",
                "go_around": "#d62728", "aborted": "#7f7f7f", "follow_path": "#bcbd22"}
OTHER_MODE_COLOUR = "#8c564b"
WILSON_Z = 1.959963984540054
# Moving deck. The criterion for a soft contact: |vehicle minus deck vertical speed| at
# first contact at most this.
DECK_REL_VZ_LIMIT_MPS = 0.5
# CoM height above the surface when standing (models/flight.yaml controller.landing.gear_height_m): the
# trace's z_WB_m minus this is where a level vehicle's skids are.
GEAR_HEIGHT_M = 0.25
DECK_PLOT_BEFORE_S = 15.0      # the time plots show this much before the contact (or the run's end)
DECK_PLOT_AFTER_S = 2.0        # and this much after it
DECK_WINDOW_FALLBACK_S = 1.0   # a deck_window whose reason has no "a-b s" is taken as [t_s, t_s + this]
MAX_DECK_RUN_PLOTS = 3
# Legend entries of the deck time plots other than the vehicle's modes.
DECK_LABELS = ("deck window (predicted quiescent)", "deck top (z_WP)", "deck_cut (motors cut)", "first contact")
DECK_WINDOW_RE = re.compile(r"quiescent\s+([0-9]+(?:\.[0-9]*)?)\s*-\s*([0-9]+(?:\.[0-9]*)?)\s*s\b")


class BadInput(Exception):
    def __init__(self, path, problem):
        super().__init__("%s: %s" % (path, problem))
        self.path = path
        self.problem = problem


# ---------------------------------------------------------------------------------------------
# small helpers

def esc(s):
    return html.escape("" if s is None else str(s), quote=True)


def num(x):
    """A finite float, or None (None, '', 'nan', non-numbers, booleans)."""
    if x is None or isinstance(x, bool):
        return None
    if isinstance(x, (int, float)):
        v = float(x)
    else:
        s = str(x).strip()
        if not s:
            return None
        try:
            v = float(s)
        except ValueError:
            return None
    return v if math.isfinite(v) else None


def fmt(x, scale=1.0, digits=2):
    v = num(x)
    if v is None:
        return "&ndash;"
    return "%.*f" % (digits, v * scale)


def getd(d, *keys):
    """Nested lookup that tolerates missing keys and non-dict values."""
    for k in keys:
        if not isinstance(d, dict):
            return None
        d = d.get(k)
    return d


def mpl_text(s, limit=40):
    """A string made safe for matplotlib labels: no mathtext, no '_'-prefixed legend labels."""
    s = "" if s is None else str(s)
    s = "".join(c if c.isprintable() else "?" for c in s)
    if len(s) > limit:
        s = s[:limit - 1] + "\u2026"
    s = s.replace("\\", "\\\\").replace("$", r"\$")
    if s.startswith("_") or not s:
        s = " " + s
    return s


def wilson(k, n):
    if not n:
        return None, None, None
    p = k / n
    z2 = WILSON_Z * WILSON_Z
    den = 1.0 + z2 / n
    centre = (p + z2 / (2 * n)) / den
    half = WILSON_Z * math.sqrt(p * (1 - p) / n + z2 / (4 * n * n)) / den
    return p, max(0.0, centre - half), min(1.0, centre + half)


def is_true(x):
    return str(x).strip().lower() in ("1", "true", "yes")


def fig_to_img(fig, name, alt):
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=DPI, bbox_inches="tight", metadata={"Software": None})
    plt.close(fig)
    png = buf.getvalue()
    width, height = struct.unpack(">II", png[16:24])  # IHDR: reserves the space before decoding
    data = base64.b64encode(png).decode("ascii")
    return ('<img class="plot" data-plot="%s" alt="%s" width="%d" height="%d" src="data:image/png;base64,%s">'
            % (esc(name), esc(alt), width, height, data))


def placeholder(text):
    return '<p class="none">%s</p>' % esc(text)


# ---------------------------------------------------------------------------------------------
# input

def load_campaign(d):
    path = os.path.join(d, "campaign.json")
    try:
        with open(path, "rb") as f:
            raw = f.read()
    except OSError as e:
        raise BadInput(path, "cannot read: %s" % (e.strerror or e))
    try:
        doc = json.loads(raw.decode("utf-8"))
    except UnicodeDecodeError as e:
        raise BadInput(path, "not UTF-8: %s" % e)
    except ValueError as e:
        raise BadInput(path, "not valid JSON: %s" % e)
    if not isinstance(doc, dict):
        raise BadInput(path, "not a JSON object")
    return doc


def load_rows(d, doc):
    """campaign.csv rows as dicts (missing cells are ''); [] if the campaign has no runs yet."""
    path = os.path.join(d, "campaign.csv")
    try:
        with open(path, "r", encoding="utf-8", errors="replace", newline="") as f:
            text = f.read().replace("\0", "")
    except FileNotFoundError:
        if not num(doc.get("runs_complete")):
            return []
        raise BadInput(path, "cannot read: no such file (campaign.json says %s runs are complete)"
                       % doc.get("runs_complete"))
    except OSError as e:
        raise BadInput(path, "cannot read: %s" % (e.strerror or e))
    try:
        reader = csv.DictReader(io.StringIO(text))
        rows = []
        for r in reader:
            row = {k: ("" if v is None else v) for k, v in r.items() if k is not None}
            if row.get("id", "").strip():
                rows.append(row)
    except csv.Error as e:
        raise BadInput(path, "not valid CSV: %s" % e)
    if text.strip() and reader.fieldnames is not None and "id" not in reader.fieldnames:
        raise BadInput(path, "no 'id' column in the header")
    return rows


def read_trace(path):
    """Columns of a trace.csv as {name: np.array} (floats; 'mode' stays strings). Rows that are
    cut short (a truncated last line) or unparsable are dropped; missing columns are absent."""
    try:
        with open(path, "r", encoding="utf-8", errors="replace", newline="") as f:
            text = f.read().replace("\0", "")
    except OSError:
        return None
    reader = csv.DictReader(io.StringIO(text))
    fields = [c for c in (reader.fieldnames or []) if c]
    if not fields:
        return {}  # empty, or a blank first line: no header
    numeric = [c for c in fields if c != "mode"]
    cols = {c: [] for c in fields}
    try:
        for r in reader:
            if r.get(fields[-1]) is None and len(fields) > 1:
                continue  # row shorter than the header: a truncated line
            t = num(r.get("t_s")) if "t_s" in r else 0.0
            if t is None:
                continue
            for c in numeric:
                v = num(r.get(c))
                cols[c].append(np.nan if v is None else v)
            if "mode" in cols:
                cols["mode"].append((r.get("mode") or "").strip())
    except csv.Error:
        pass  # keep what was read before the damage
    out = {}
    for c, v in cols.items():
        out[c] = np.array(v, dtype=object) if c == "mode" else np.array(v, dtype=float)
    return out


def read_run_json(d, run_id):
    try:
        with open(os.path.join(d, "runs", run_id, "run.json"), "rb") as f:
            doc = json.loads(f.read().decode("utf-8", errors="replace"))
        return doc if isinstance(doc, dict) else {}
    except (OSError, ValueError):
        return {}


def read_run_summary(d, run_id):
    """(DIR/runs/<id>/summary.json as a dict, None) or (None, why it could not be read)."""
    run_dir = safe_run_dir(d, run_id)
    if run_dir is None:
        return None, "run id not usable as a directory name"
    path = os.path.join(run_dir, "summary.json")
    try:
        with open(path, "rb") as f:
            doc = json.loads(f.read().decode("utf-8", errors="replace"))
    except FileNotFoundError:
        return None, "no summary.json"
    except OSError as e:
        return None, "summary.json unreadable: %s" % (e.strerror or e)
    except ValueError as e:
        return None, "summary.json not valid JSON: %s" % e
    if not isinstance(doc, dict):
        return None, "summary.json not a JSON object"
    return doc, None


def safe_run_dir(d, run_id):
    """DIR/runs/<id>, or None if the id would leave DIR/runs (it comes from a file)."""
    if not run_id or run_id in (".", "..") or "/" in run_id or "\\" in run_id or "\0" in run_id:
        return None
    return os.path.join(d, "runs", run_id)


# ---------------------------------------------------------------------------------------------
# sections

def scenario_order(doc, rows):
    names = []
    sc = doc.get("scenarios")
    if isinstance(sc, dict):
        names.extend(str(k) for k in sc.keys())
    extra = sorted({r.get("scenario", "") for r in rows} - set(names))
    return names + extra


def scenario_colours(names):
    cmap = plt.get_cmap("tab10")
    return {n: cmap(i % 10) for i, n in enumerate(names)}


def section_header(doc, d):
    name = doc.get("name")
    planned, complete = doc.get("runs_planned"), doc.get("runs_complete")
    missing = doc.get("missing") if isinstance(doc.get("missing"), list) else []
    out = ["<h1>Campaign report: %s</h1>" % esc(name if name is not None else "(unnamed)")]
    out.append('<table class="kv">')
    out.append("<tr><th>master seed</th><td>%s</td></tr>" % esc(doc.get("master_seed")))
    out.append("<tr><th>runs complete / planned</th><td>%s / %s</td></tr>"
               % (esc(complete), esc(planned)))
    if doc.get("campaign_file") is not None:
        out.append("<tr><th>campaign file</th><td><code>%s</code></td></tr>" % esc(doc.get("campaign_file")))
    lim = num(doc.get("offset_limit_m"))
    out.append("<tr><th>touchdown offset limit</th><td>%s cm%s</td></tr>"
               % (fmt(lim if lim is not None else DEFAULT_OFFSET_LIMIT_M, 100, 1),
                  "" if lim is not None else " (default; not in campaign.json)"))
    keys = doc.get("dispersion_keys")
    if isinstance(keys, list) and keys:
        out.append("<tr><th>dispersed inputs</th><td>%s</td></tr>"
                   % ", ".join("<code>%s</code>" % esc(k) for k in keys))
    out.append("<tr><th>directory</th><td><code>%s</code></td></tr>" % esc(os.path.abspath(d)))
    out.append("</table>")
    if missing:
        shown = ", ".join("<code>%s</code>" % esc(m) for m in missing[:MAX_LISTED_MISSING])
        more = (" &hellip; and %d more" % (len(missing) - MAX_LISTED_MISSING)
                if len(missing) > MAX_LISTED_MISSING else "")
        out.append('<p class="warn">%d run(s) missing (not complete): %s%s</p>'
                   % (len(missing), shown, more))
    return "\n".join(out)


def stats_row(label, st, overall=False):
    if not isinstance(st, dict):
        st = {}
    runs, landed = num(st.get("runs")), num(st.get("landed"))
    rate = num(getd(st, "landing_rate", "value"))
    ci = getd(st, "landing_rate", "ci95")
    if (rate is None or not isinstance(ci, list) or len(ci) != 2) and runs and landed is not None:
        p, lo, hi = wilson(landed, runs)
        rate = rate if rate is not None else p
        ci = [lo, hi]
    if not isinstance(ci, list) or len(ci) != 2:
        ci = [None, None]
    off = st.get("touchdown_offset_m") if isinstance(st.get("touchdown_offset_m"), dict) else {}
    p95ci = off.get("p95_ci95") if isinstance(off.get("p95_ci95"), list) and len(off.get("p95_ci95")) == 2 else None
    p95 = fmt(off.get("p95"), 100, 1)
    if p95ci:
        p95 += ' <span class="ci">[%s, %s]</span>' % (fmt(p95ci[0], 100, 1), fmt(p95ci[1], 100, 1))
    rate_s = "&ndash;" if rate is None else "%.1f%%" % (100 * rate)
    if num(ci[0]) is not None and num(ci[1]) is not None:
        rate_s += ' <span class="ci">[%.1f, %.1f]</span>' % (100 * num(ci[0]), 100 * num(ci[1]))
    outcomes = st.get("outcomes") if isinstance(st.get("outcomes"), dict) else {}
    oc = ", ".join("%s:&nbsp;%s" % (esc(k), esc(v)) for k, v in outcomes.items()) or "&ndash;"
    cells = [
        ("<th>%s</th>" % esc(label)),
        "<td>%s</td>" % esc(st.get("runs", "")),
        "<td>%s</td>" % esc(st.get("landed", "")),
        "<td>%s</td>" % rate_s,
        "<td>%s</td>" % fmt(off.get("mean"), 100, 1),
        "<td>%s</td>" % fmt(off.get("median"), 100, 1),
        "<td>%s</td>" % p95,
        "<td>%s</td>" % fmt(off.get("max"), 100, 1),
        "<td>%s</td>" % fmt(getd(st, "touchdown_rel_speed_mps", "median"), 1, 2),
        "<td>%s</td>" % fmt(getd(st, "touchdown_rel_speed_mps", "max"), 1, 2),
        "<td>%s</td>" % fmt(getd(st, "touchdown_tilt_deg", "median"), 1, 1),
        "<td>%s</td>" % fmt(getd(st, "touchdown_tilt_deg", "max"), 1, 1),
        "<td>%s</td>" % fmt(getd(st, "time_to_land_s", "median"), 1, 1),
        "<td>%s</td>" % esc(st.get("landing_failures", "")),
        "<td>%s</td>" % esc(st.get("simulator_failures", "")),
        '<td class="left">%s</td>' % oc,
    ]
    return '<tr%s>%s</tr>' % (' class="overall"' if overall else "", "".join(cells))


def section_stats(doc, names):
    out = ['<h2 id="stats">Statistics</h2>',
           '<p class="note">Offsets, speeds, tilts and times are over the landed runs; '
           "intervals in brackets are 95%: Wilson for the landing rate, bootstrap for the p95 offset.</p>",
           '<table class="stats"><thead>',
           '<tr><th rowspan="2">scenario</th><th rowspan="2">runs</th><th rowspan="2">landed</th>'
           '<th rowspan="2">landing rate [95% CI]</th><th colspan="4">touchdown offset (cm)</th>'
           '<th colspan="2">rel. speed (m/s)</th><th colspan="2">tilt (deg)</th>'
           '<th rowspan="2">time to land median (s)</th><th rowspan="2">landing failures</th>'
           '<th rowspan="2">simulator failures</th><th rowspan="2">outcomes</th></tr>',
           "<tr><th>mean</th><th>median</th><th>p95 [95% CI]</th><th>max</th>"
           "<th>median</th><th>max</th><th>median</th><th>max</th></tr></thead><tbody>"]
    sc = doc.get("scenarios") if isinstance(doc.get("scenarios"), dict) else {}
    for n in names:
        if n in sc:
            out.append(stats_row(n, sc[n]))
    out.append(stats_row("overall", doc.get("overall"), overall=True))
    out.append("</tbody></table>")
    return "\n".join(out)


def landed_rows(rows):
    return [r for r in rows if is_true(r.get("landed"))]


def draw_platform(ax, limit):
    h = PLATFORM_SIDE_M / 2
    ax.add_patch(Rectangle((-h, -h), PLATFORM_SIDE_M, PLATFORM_SIDE_M, fill=False, ec="0.3", lw=1.2,
                           label="platform 1.8 m"))
    ax.add_patch(Circle((0, 0), RING_OUTER_RADIUS_M, fill=False, ec="0.55", lw=1.0, ls="--",
                        label="centre ring r = %.2f m" % RING_OUTER_RADIUS_M))
    ax.add_patch(Circle((0, 0), limit, fill=False, ec="#d62728", lw=1.2,
                        label="offset limit %.0f cm" % (limit * 100)))
    ax.axhline(0, color="0.85", lw=0.6, zorder=0)
    ax.axvline(0, color="0.85", lw=0.6, zorder=0)


def section_touchdown(rows, names, colours, limit):
    out = ['<h2 id="touchdown">Touchdown points (platform frame)</h2>']
    pts = {}
    for r in landed_rows(rows):
        x, y = num(r.get("touchdown_x_P_m")), num(r.get("touchdown_y_P_m"))
        if x is not None and y is not None:
            pts.setdefault(r.get("scenario", ""), []).append((x, y))
    if not pts:
        out.append(placeholder("no landed runs" if not landed_rows(rows)
                               else "no touchdown points recorded for the landed runs"))
        return "\n".join(out)
    fig, axes = plt.subplots(1, 2, figsize=(11, 5.4))
    all_xy = np.array([p for v in pts.values() for p in v])
    span = max(1.05, float(np.max(np.abs(all_xy))) * 1.05)
    zoom = 0.15
    for ax, lim, title in ((axes[0], span, "whole platform"), (axes[1], zoom, "zoom \u00b115 cm")):
        draw_platform(ax, limit)
        for n in names:
            if n in pts:
                a = np.array(pts[n])
                ax.scatter(a[:, 0], a[:, 1], s=18 if lim == zoom else 12, color=colours[n],
                           edgecolors="k", linewidths=0.3, label=mpl_text(n), zorder=3)
        ax.set_xlim(-lim, lim)
        ax.set_ylim(-lim, lim)
        ax.set_aspect("equal")
        ax.set_xlabel("x_P (m)")
        ax.set_ylabel("y_P (m)")
        ax.set_title(title)
        ax.grid(True, lw=0.3, alpha=0.5)
    outside = int(np.sum(np.max(np.abs(all_xy), axis=1) > zoom))
    if outside:
        axes[1].text(0.02, 0.02, "%d point(s) outside this view" % outside, transform=axes[1].transAxes,
                     fontsize=8, color="0.3")
    axes[0].legend(loc="upper left", bbox_to_anchor=(0.0, -0.12), ncol=3, fontsize=8, frameon=False)
    out.append(fig_to_img(fig, "touchdown", "touchdown points in the platform frame"))
    return "\n".join(out)


# ---------------------------------------------------------------------------------------------
# moving deck

def deck_events(events):
    """([(start, end)] of the deck_window events, [t_s] of the deck_cut events) from
    landing_decision.events. A window's span comes from its reason ("deck quiescent a-b s ..."),
    else it is [t_s, t_s + DECK_WINDOW_FALLBACK_S]."""
    windows, cuts = [], []
    for e in events if isinstance(events, list) else []:
        if not isinstance(e, dict):
            continue
        t = num(e.get("t_s"))
        if e.get("what") == "deck_cut" and t is not None:
            cuts.append(t)
        elif e.get("what") == "deck_window":
            m = DECK_WINDOW_RE.search(str(e.get("reason") or ""))
            a, b = (num(m.group(1)), num(m.group(2))) if m else (None, None)
            if a is None or b is None or b <= a:
                if t is None:
                    continue
                a, b = t, t + DECK_WINDOW_FALLBACK_S
            windows.append((a, b))
    return windows, cuts


def deck_record(row, summ):
    """The deck figures of one run (row of campaign.csv, its summary.json), or None if its
    touchdown has none (no contact, or not a moving deck)."""
    td = summ.get("touchdown")
    if not isinstance(td, dict) or "deck_tilt_deg" not in td:
        return None
    windows, cuts = deck_events(getd(summ, "landing_decision", "events"))
    rel = num(td.get("rel_vertical_speed_mps"))
    landed = (is_true(row.get("landed")) if str(row.get("landed", "")).strip()
              else summ.get("landed") is True)
    return {"id": row.get("id", ""), "scenario": row.get("scenario", ""), "landed": landed,
            "outcome": row.get("outcome") or summ.get("outcome") or "",
            "t_contact": num(td.get("t_s")), "rel_vz": rel, "abs_rel_vz": None if rel is None else abs(rel),
            "deck_vz": num(td.get("deck_vz_mps")), "deck_tilt": num(td.get("deck_tilt_deg")),
            "mode": str(td.get("mode_at_contact") or ""), "windows": windows, "cuts": cuts}


def collect_deck_runs(d, rows):
    """(deck records, [(run id, why its summary.json was not read)])."""
    recs, skipped = [], []
    for r in rows:
        summ, why = read_run_summary(d, r.get("id", ""))
        if summ is None:
            skipped.append((r.get("id", ""), why))
            continue
        rec = deck_record(r, summ)
        if rec is not None:
            recs.append(rec)
    return recs, skipped


def deck_stats_row(label, recs, overall=False):
    speeds = [r["abs_rel_vz"] for r in recs if r["abs_rel_vz"] is not None]
    soft = sum(1 for v in speeds if v <= DECK_REL_VZ_LIMIT_MPS)
    tilts = [r["deck_tilt"] for r in recs if r["deck_tilt"] is not None]
    share = ("&ndash;" if not speeds
             else "%d / %d (%.1f%%)" % (soft, len(speeds), 100.0 * soft / len(speeds)))
    cells = [
        "<th>%s</th>" % esc(label),
        "<td>%d</td>" % len(recs),
        "<td>%d</td>" % sum(1 for r in recs if r["landed"]),
        "<td>%s</td>" % share,
        "<td>%s</td>" % fmt(float(np.median(speeds)) if speeds else None, 1, 2),
        "<td>%s</td>" % fmt(max(speeds) if speeds else None, 1, 2),
        "<td>%s</td>" % fmt(max(tilts) if tilts else None, 1, 1),
        "<td>%d</td>" % sum(1 for r in recs if r["mode"] == "recovery"),
        "<td>%d</td>" % sum(1 for r in recs if r["cuts"]),
    ]
    return '<tr%s>%s</tr>' % (' class="overall"' if overall else "", "".join(cells))


def deck_table(recs, names):
    per = {}
    for r in recs:
        per.setdefault(r["scenario"], []).append(r)
    out = ['<table class="stats deck"><thead>',
           '<tr><th rowspan="2">scenario</th><th rowspan="2">runs with deck figures</th>'
           '<th rowspan="2">landed</th><th rowspan="2">|rel. vertical speed| &le; %.1f m/s</th>'
           '<th colspan="2">|rel. vertical speed| (m/s)</th><th rowspan="2">deck tilt max (deg)</th>'
           '<th rowspan="2">contacts before the cut</th><th rowspan="2">runs with a deck_cut</th></tr>'
           % DECK_REL_VZ_LIMIT_MPS,
           "<tr><th>median</th><th>max</th></tr></thead><tbody>"]
    used = [n for n in names if n in per] + sorted(set(per) - set(names))
    for n in used:
        out.append(deck_stats_row(n, per[n]))
    if len(used) > 1:
        out.append(deck_stats_row("all deck runs", recs, overall=True))
    out.append("</tbody></table>")
    return "\n".join(out)


def deck_scatter(recs, names, colours):
    pts = [r for r in recs if r["deck_vz"] is not None and r["rel_vz"] is not None]
    if not pts:
        return placeholder("no run has both the deck's and the relative vertical speed at contact")
    lim = DECK_REL_VZ_LIMIT_MPS
    fig, ax = plt.subplots(figsize=(8, 5))
    ax.axhspan(-lim, lim, color="#2ca02c", alpha=0.08, lw=0, zorder=0)
    ax.axhline(-lim, color="#d62728", lw=1.2, ls="--", label="|rel. vertical speed| = %.1f m/s" % lim)
    ax.axhline(lim, color="#d62728", lw=1.2, ls="--")
    ax.axhline(0, color="0.7", lw=0.6, zorder=0)
    ax.axvline(0, color="0.7", lw=0.6, zorder=0)
    for n in names + sorted({r["scenario"] for r in pts} - set(names)):
        sub = [r for r in pts if r["scenario"] == n]
        labelled = False
        for landed, marker in ((True, "o"), (False, "X")):
            s = [r for r in sub if r["landed"] == landed]
            if not s:
                continue
            ax.scatter([r["deck_vz"] for r in s], [r["rel_vz"] for r in s], s=30, marker=marker,
                       color=colours.get(n, OTHER_MODE_COLOUR), edgecolors="k", linewidths=0.3, zorder=3,
                       label=None if labelled else "%s (n=%d)" % (mpl_text(n), len(sub)))
            labelled = True
    if any(not r["landed"] for r in pts):
        ax.scatter([], [], s=30, marker="X", color="0.6", edgecolors="k", linewidths=0.3, label="did not land")
    ys = [r["rel_vz"] for r in pts]
    pad = 0.1 * max(lim, max(ys) - min(ys))
    ax.set_ylim(min(min(ys), -lim) - pad, max(max(ys), lim) + pad)
    ax.set_xlabel("deck vertical speed at contact (m/s)")
    ax.set_ylabel("relative vertical speed at contact (m/s)\nvehicle minus deck, < 0 closing")
    ax.grid(True, lw=0.3, alpha=0.5)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    return fig_to_img(fig, "deck_scatter", "deck vertical speed vs relative vertical speed at contact")


def pick_deck_runs(recs):
    """[(record, why shown)]: the largest and the median |rel. vertical speed|, and a run that
    did not land (the one with the largest |rel. vertical speed|) unless one is shown already."""
    ranked = sorted((r for r in recs if r["abs_rel_vz"] is not None), key=lambda r: (r["abs_rel_vz"], r["id"]))
    picks = []
    if ranked:
        picks.append((ranked[-1], "largest |rel. vertical speed| at contact"))
        if len(ranked) > 1:
            picks.append((ranked[(len(ranked) - 1) // 2], "median |rel. vertical speed| at contact"))
    failed = [r for r in recs if not r["landed"]]
    if failed and all(r["landed"] for r, _ in picks):
        failed.sort(key=lambda r: (-(r["abs_rel_vz"] if r["abs_rel_vz"] is not None else -1.0), r["id"]))
        picks.append((failed[0], "did not land"))
    return picks[:MAX_DECK_RUN_PLOTS]


def plain(x, fmt_s, none="?"):
    """A number for a matplotlib label (fmt() writes HTML)."""
    v = num(x)
    return none if v is None else fmt_s % v


def deck_plot_span(t, rec):
    """(start, end) of a run's time plot: DECK_PLOT_BEFORE_S before the last of the first contact
    and the deck_cuts (or the run's end) to DECK_PLOT_AFTER_S after it, widened to the first
    contact if that came earlier."""
    t0, t1 = float(np.nanmin(t)), float(np.nanmax(t))
    marks = [x for x in [rec["t_contact"]] + rec["cuts"] if x is not None]
    end = min(t1, max(marks) + DECK_PLOT_AFTER_S) if marks else t1
    start = end - DECK_PLOT_BEFORE_S
    if rec["t_contact"] is not None and rec["t_contact"] - DECK_PLOT_AFTER_S < start:
        start = rec["t_contact"] - DECK_PLOT_AFTER_S
    return max(t0, start), end


def deck_time_plot(tr, rec):
    """The deck's top and the vehicle's gear over the end of a run: a figure, or (None, why)."""
    if not all(c in tr and len(tr[c]) > 0 for c in ("t_s", "z_WB_m", "z_WP_m")):
        return None, "trace.csv has no usable rows or lacks the columns t_s, z_WB_m, z_WP_m"
    t = tr["t_s"]
    if not np.isfinite(t).any():
        return None, "trace.csv has no finite times"
    start, end = deck_plot_span(t, rec)
    sel = np.flatnonzero((t >= start) & (t <= end))
    if len(sel) == 0:
        return None, "trace.csv has no rows between %.1f and %.1f s" % (start, end)
    idx = sel[downsample_index(len(sel))]
    tt, zp, zg = t[idx], tr["z_WP_m"][idx], tr["z_WB_m"][idx] - GEAR_HEIGHT_M
    modes = tr["mode"][idx] if "mode" in tr and len(tr["mode"]) == len(t) else None
    fig, ax = plt.subplots(figsize=(10, 4.2))
    shaded = False
    for a, b in rec["windows"]:
        if b >= start and a <= end:
            ax.axvspan(max(a, start), min(b, end), color="#2ca02c", alpha=0.18, lw=0, zorder=0,
                       label=None if shaded else DECK_LABELS[0])
            shaded = True
    ok = np.isfinite(tt) & np.isfinite(zp)
    ax.plot(tt[ok], zp[ok], color="0.45", lw=2.4, label=DECK_LABELS[1], zorder=1)
    ok = np.isfinite(tt) & np.isfinite(zg)
    plot_by_mode(ax, tt[ok], zg[ok], None if modes is None else modes[ok], set())
    cuts = [c for c in rec["cuts"] if start <= c <= end]
    for i, c in enumerate(cuts):
        ax.axvline(c, color="#d62728", lw=1.3, ls="--", label=None if i else DECK_LABELS[2])
    if rec["t_contact"] is not None:
        ax.axvline(rec["t_contact"], color="k", lw=1.1, ls=":", label=DECK_LABELS[3])
    ax.set_xlim(start, end)
    ax.set_xlabel("t (s)")
    ax.set_ylabel("z_W (m)")
    ax.grid(True, lw=0.3, alpha=0.5)
    handles, labels = ax.get_legend_handles_labels()
    legends = []
    for pick, where, title in ((lambda lab: lab not in DECK_LABELS, 1.0,
                                "vehicle z_WB - %.2f m, by mode" % GEAR_HEIGHT_M),
                               (lambda lab: lab in DECK_LABELS, 0.0, None)):
        hl = [(h, lab) for h, lab in zip(handles, labels) if pick(lab)]
        if hl:
            legends.append(ax.legend([h for h, _ in hl], [lab for _, lab in hl], fontsize=8, frameon=False,
                                     loc="upper left" if where else "lower left", bbox_to_anchor=(1.01, where),
                                     title=title, title_fontsize=8, alignment="left"))
    for leg in legends[:-1]:
        ax.add_artist(leg)
    ax.set_title(mpl_text("%s (%s): rel. vertical speed %s m/s, deck vertical speed %s m/s, deck tilt %s deg, "
                          "contact in %s" % (rec["id"], rec["outcome"] or "?", plain(rec["rel_vz"], "%+.2f"),
                                             plain(rec["deck_vz"], "%+.2f"), plain(rec["deck_tilt"], "%.1f"),
                                             rec["mode"] or "?"), 160), fontsize=9)
    return fig, None


def section_deck_runs(d, recs):
    out = ["<h3>The deck's motion and the chosen touchdown instant</h3>",
           '<p class="note">The last %.0f s before the first contact (or the run\'s end), widened to show '
           "the deck_cut: the deck's top, the vehicle's height less the gear height %.2f m (coloured by "
           "flight mode), the deck windows the flight software committed to (shaded), each deck_cut "
           "(dashed) and the first contact (dotted). The deck's height is its top's at the centre: on a tilted "
           "deck a skid's end meets it a few cm off that line.</p>" % (DECK_PLOT_BEFORE_S, GEAR_HEIGHT_M)]
    for rec, why in pick_deck_runs(recs):
        run_id = rec["id"]
        out.append('<div class="run"><h4><code>%s</code> &mdash; %s, %s: %s</h4>'
                   % (esc(run_id), esc(rec["scenario"]), esc(rec["outcome"]), esc(why)))
        run_dir = safe_run_dir(d, run_id)
        trace_path = os.path.join(run_dir, "trace.csv") if run_dir else None
        tr = read_trace(trace_path) if trace_path and os.path.isfile(trace_path) else None
        if tr is None:
            out.append('<p class="warn">no readable trace.csv: not plotted</p>')
        else:
            fig, why_not = deck_time_plot(tr, rec)
            out.append(placeholder(why_not) if fig is None
                       else fig_to_img(fig, "deck:" + run_id, "deck motion and touchdown of run " + run_id))
        out.append("</div>")
    return "\n".join(out)


def section_deck(d, rows, names, colours):
    """The moving-deck section, or None when no run's touchdown has the deck figures."""
    recs, skipped = collect_deck_runs(d, rows)
    if not recs:
        return None
    out = ['<h2 id="deck">Moving deck</h2>',
           '<p class="note">Runs whose first contact has the deck figures (summary.json touchdown). '
           "Relative vertical speed: vehicle minus deck at the first contact (negative: closing); the "
           "criterion is |rel. vertical speed| &le; %.1f m/s. Contacts before the cut: the skids met the "
           "deck before the flight software cut the motors (mode at contact: recovery).</p>"
           % DECK_REL_VZ_LIMIT_MPS,
           deck_table(recs, names)]
    if skipped:
        shown = ", ".join("<code>%s</code> (%s)" % (esc(i), esc(w)) for i, w in skipped[:MAX_LISTED_MISSING])
        more = " &hellip;" if len(skipped) > MAX_LISTED_MISSING else ""
        out.append('<p class="warn">%d run(s) skipped, no readable summary.json: %s%s</p>'
                   % (len(skipped), shown, more))
    out.append(deck_scatter(recs, names, colours))
    out.append(section_deck_runs(d, recs))
    return "\n".join(out)


def section_ecdf(rows, names, colours, limit):
    out = ['<h2 id="ecdf">Touchdown offset: empirical CDF</h2>']
    per = {}
    for r in landed_rows(rows):
        v = num(r.get("touchdown_offset_m"))
        if v is not None:
            per.setdefault(r.get("scenario", ""), []).append(v * 100)
    if not per:
        out.append(placeholder("no landed runs" if not landed_rows(rows)
                               else "no touchdown offsets recorded for the landed runs"))
        return "\n".join(out)
    fig, ax = plt.subplots(figsize=(8, 4.5))
    xmax = limit * 100
    for n in names:
        if n not in per:
            continue
        v = np.sort(np.array(per[n]))
        xmax = max(xmax, float(v[-1]))
        x = np.concatenate([[0.0], v])
        y = np.concatenate([[0.0], np.arange(1, len(v) + 1) / len(v)])
        ax.step(x, y, where="post", color=colours[n], lw=1.6, label="%s (n=%d)" % (mpl_text(n), len(v)))
    if len(per) > 1:
        allv = np.sort(np.concatenate([np.array(v) for v in per.values()]))
        ax.step(np.concatenate([[0.0], allv]), np.concatenate([[0.0], np.arange(1, len(allv) + 1) / len(allv)]),
                where="post", color="k", lw=1.0, ls=":", label="overall (n=%d)" % len(allv))
    ax.axvline(limit * 100, color="#d62728", lw=1.2, ls="--", label="limit %.0f cm" % (limit * 100))
    ax.set_xlim(0, xmax * 1.08)
    ax.set_ylim(0, 1.02)
    ax.set_xlabel("touchdown offset (cm)")
    ax.set_ylabel("fraction of landed runs \u2264 offset")
    ax.grid(True, lw=0.3, alpha=0.5)
    ax.legend(fontsize=8, loc="lower right")
    out.append(fig_to_img(fig, "ecdf", "empirical CDF of the touchdown offset per scenario"))
    return "\n".join(out)


def rate_of(st):
    """(rate, lo, hi, runs) from a STATS object, computing Wilson if the interval is missing."""
    if not isinstance(st, dict):
        return None
    runs, landed = num(st.get("runs")), num(st.get("landed"))
    rate = num(getd(st, "landing_rate", "value"))
    ci = getd(st, "landing_rate", "ci95")
    lo = hi = None
    if isinstance(ci, list) and len(ci) == 2:
        lo, hi = num(ci[0]), num(ci[1])
    if runs and landed is not None and (rate is None or lo is None or hi is None):
        p, wlo, whi = wilson(landed, runs)
        rate = p if rate is None else rate
        lo, hi = (wlo, whi) if lo is None or hi is None else (lo, hi)
    if rate is None or not runs:
        return None
    return rate, lo if lo is not None else rate, hi if hi is not None else rate, int(runs)


def section_rate(doc, names, colours):
    out = ['<h2 id="rate">Landing rate</h2>']
    sc = doc.get("scenarios") if isinstance(doc.get("scenarios"), dict) else {}
    items = [(n, rate_of(sc.get(n)), colours[n]) for n in names]
    items.append(("overall", rate_of(doc.get("overall")), "k"))
    if all(it[1] is None for it in items):
        out.append(placeholder("no completed runs"))
        return "\n".join(out)
    fig, ax = plt.subplots(figsize=(max(6.0, 1.0 + 0.9 * len(items)), 4.2))
    for i, (n, r, c) in enumerate(items):
        if r is None:
            ax.text(i, 0.5, "no runs", ha="center", fontsize=8, color="0.4", rotation=90)
            continue
        rate, lo, hi, runs = r
        ax.errorbar([i], [rate * 100], yerr=[[max(0.0, rate - lo) * 100], [max(0.0, hi - rate) * 100]],
                    fmt="o" if n != "overall" else "D", color=c, capsize=5, ms=7, lw=1.5)
        ax.text(i + 0.12, rate * 100, "%.0f%%\nn=%d" % (rate * 100, runs), fontsize=8, va="center")
    ax.set_xticks(range(len(items)))
    ax.set_xticklabels([mpl_text(n, 24) for n, _, _ in items], rotation=20, ha="right")
    ax.set_xlim(-0.6, len(items) - 0.2)
    ax.set_ylim(-3, 105)
    ax.set_ylabel("landing rate (%) with 95% Wilson interval")
    ax.grid(True, axis="y", lw=0.3, alpha=0.5)
    out.append(fig_to_img(fig, "rate", "landing rate per scenario with 95% Wilson intervals"))
    return "\n".join(out)


def section_time_to_land(rows, names, colours):
    out = ['<h2 id="time">Time to land</h2>']
    per = {}
    for r in landed_rows(rows):
        v = num(r.get("time_to_land_s"))
        if v is not None:
            per.setdefault(r.get("scenario", ""), []).append(v)
    if not per:
        out.append(placeholder("no landed runs" if not landed_rows(rows)
                               else "no times to land recorded for the landed runs"))
        return "\n".join(out)
    used = [n for n in names if n in per]
    fig, ax = plt.subplots(figsize=(max(6.0, 1.2 + 1.1 * len(used)), 4.2))
    data = [per[n] for n in used]
    ax.boxplot(data, positions=range(len(used)), widths=0.5, showfliers=False,
               medianprops={"color": "k"})
    rng = np.random.default_rng(0)  # fixed jitter: the page is reproducible
    for i, n in enumerate(used):
        v = np.array(per[n])
        ax.scatter(i + rng.uniform(-0.15, 0.15, len(v)), v, s=12, color=colours[n], alpha=0.8,
                   edgecolors="k", linewidths=0.3, zorder=3)
    ax.set_xticks(range(len(used)))
    ax.set_xticklabels(["%s\n(n=%d)" % (mpl_text(n, 24), len(per[n])) for n in used], fontsize=8)
    ax.set_ylabel("time to land (s)")
    ax.grid(True, axis="y", lw=0.3, alpha=0.5)
    out.append(fig_to_img(fig, "time_to_land", "time to land per scenario"))
    return "\n".join(out)


def section_sensitivity(doc):
    out = ['<h2 id="sensitivity">Input sensitivity</h2>']
    sens = doc.get("sensitivity")
    if not isinstance(sens, list) or not sens:
        out.append(placeholder("no dispersed inputs (or no sensitivity computed)"))
        return "\n".join(out)
    numeric = [s for s in sens if isinstance(s, dict) and s.get("kind") != "categorical"]
    categorical = [s for s in sens if isinstance(s, dict) and s.get("kind") == "categorical"]

    def rho_cells(o):
        if not isinstance(o, dict):
            return "<td>&ndash;</td><td>&ndash;</td><td>&ndash;</td>"
        p = num(o.get("p"))
        cls = ' class="sig"' if p is not None and p < 0.05 else ""
        return "<td%s>%s</td><td%s>%s</td><td>%s</td>" % (
            cls, fmt(o.get("rho"), 1, 2), cls, fmt(o.get("p"), 1, 3), esc(o.get("n", "")))

    if numeric:
        out.append('<p class="note">Spearman rank correlation of each numeric input with the touchdown '
                   "offset (landed runs) and with not landing (0/1, all runs); p &lt; 0.05 highlighted "
                   "(not corrected for the number of inputs).</p>")
        out.append('<table class="stats"><thead><tr><th rowspan="2">input</th><th rowspan="2">runs</th>'
                   '<th colspan="3">vs touchdown offset</th><th colspan="3">vs failure</th></tr>'
                   "<tr><th>&rho;</th><th>p</th><th>n</th><th>&rho;</th><th>p</th><th>n</th></tr>"
                   "</thead><tbody>")
        for s in numeric:
            out.append("<tr><th><code>%s</code></th><td>%s</td>%s%s</tr>" % (
                esc(s.get("input")), esc(s.get("n", "")),
                rho_cells(s.get("offset_spearman")), rho_cells(s.get("failure_spearman"))))
        out.append("</tbody></table>")
    if categorical:
        out.append('<table class="stats"><thead><tr><th>input</th><th>level</th><th>runs</th>'
                   "<th>landed</th><th>landing rate</th><th>offset median (cm)</th></tr></thead><tbody>")
        for s in categorical:
            levels = s.get("levels") if isinstance(s.get("levels"), dict) else {}
            first = True
            for lvl, v in levels.items():
                v = v if isinstance(v, dict) else {}
                rate = num(v.get("landing_rate"))
                out.append("<tr>%s<td>%s</td><td>%s</td><td>%s</td><td>%s</td><td>%s</td></tr>" % (
                    '<th rowspan="%d"><code>%s</code></th>' % (len(levels), esc(s.get("input"))) if first else "",
                    esc(lvl), esc(v.get("runs", "")), esc(v.get("landed", "")),
                    "&ndash;" if rate is None else "%.1f%%" % (100 * rate),
                    fmt(v.get("offset_median_m"), 100, 1)))
                first = False
            if not levels:
                out.append("<tr><th><code>%s</code></th><td colspan=\"5\">no levels</td></tr>"
                           % esc(s.get("input")))
        out.append("</tbody></table>")
    return "\n".join(out)


def section_worst(doc):
    out = ['<h2 id="worst">Worst runs</h2>']
    worst = doc.get("worst_runs")
    if not isinstance(worst, list) or not worst:
        out.append(placeholder("no runs listed"))
        return "\n".join(out)
    out.append('<table class="stats worst"><thead><tr><th>id</th><th>scenario</th><th>status</th>'
               "<th>outcome</th><th>offset (cm)</th><th>detail</th><th>rerun</th></tr></thead><tbody>")
    for w in worst:
        if not isinstance(w, dict):
            continue
        out.append('<tr><td><code>%s</code></td><td>%s</td><td>%s</td><td>%s</td><td>%s</td>'
                   '<td class="left">%s</td><td class="left"><code class="cmd">%s</code></td></tr>' % (
                       esc(w.get("id")), esc(w.get("scenario")), esc(w.get("status")), esc(w.get("outcome")),
                       fmt(w.get("touchdown_offset_m"), 100, 1), esc(w.get("detail")), esc(w.get("rerun"))))
    out.append("</tbody></table>")
    return "\n".join(out)


def downsample_index(n, cap=MAX_TRACE_POINTS):
    if n <= cap:
        return np.arange(n)
    idx = np.linspace(0, n - 1, cap).round().astype(int)
    return np.unique(idx)


def plot_by_mode(ax, x, y, modes, seen):
    """Line through (x, y) coloured by contiguous runs of the same mode."""
    n = len(x)
    if modes is None:
        ax.plot(x, y, color=OTHER_MODE_COLOUR, lw=1.3, label="vehicle" if "vehicle" not in seen else None)
        seen.add("vehicle")
        return
    start = 0
    for i in range(1, n + 1):
        if i == n or modes[i] != modes[start]:
            m = modes[start] or "?"
            end = min(i + 1, n)  # include the next point so the segments join
            label = None if m in seen else mpl_text(m)
            seen.add(m)
            ax.plot(x[start:end], y[start:end], color=MODE_COLOURS.get(m, OTHER_MODE_COLOUR), lw=1.4,
                    label=label)
            start = i


def failed_run_plot(tr, run_id):
    """One figure (top view | altitude) from a trace, or (None, reason)."""
    def has(*cs):
        return all(c in tr and len(tr[c]) > 0 for c in cs)

    can_top = has("x_WB_m", "y_WB_m")
    can_alt = has("t_s", "z_WB_m")
    if not can_top and not can_alt:
        return None, "trace.csv has no usable rows or lacks the columns x_WB_m, y_WB_m, t_s, z_WB_m"
    n = max(len(v) for v in tr.values())
    idx = downsample_index(n)
    modes = tr["mode"][idx] if "mode" in tr and len(tr["mode"]) == n else None
    panels = [p for p, ok in (("top", can_top), ("alt", can_alt)) if ok]
    fig, axes = plt.subplots(1, len(panels), figsize=(5.6 * len(panels), 4.6), squeeze=False)
    seen = set()
    notes = []
    for ax, p in zip(axes[0], panels):
        if p == "top":
            x, y = tr["x_WB_m"][idx], tr["y_WB_m"][idx]
            ok = np.isfinite(x) & np.isfinite(y)
            if has("x_WP_m", "y_WP_m"):
                cx, cy = tr["x_WP_m"][idx], tr["y_WP_m"][idx]
                okc = np.isfinite(cx) & np.isfinite(cy)
                ax.plot(cx[okc], cy[okc], color="0.6", lw=2.5, label="cart", zorder=1)
            else:
                notes.append("no cart path (x_WP_m, y_WP_m)")
            plot_by_mode(ax, x[ok], y[ok], None if modes is None else modes[ok], seen)
            if ok.any():
                ax.plot(x[ok][0], y[ok][0], "o", color="k", ms=5, mfc="w", label="start", zorder=4)
                ax.plot(x[ok][-1], y[ok][-1], "x", color="k", ms=7, label="end", zorder=4)
            ax.set_aspect("equal", adjustable="datalim")
            ax.set_xlabel("x_W (m)")
            ax.set_ylabel("y_W (m)")
            ax.set_title("top view")
        else:
            t, z = tr["t_s"][idx], tr["z_WB_m"][idx]
            ok = np.isfinite(t) & np.isfinite(z)
            if has("z_WP_m"):
                zp = tr["z_WP_m"][idx]
                okp = np.isfinite(t) & np.isfinite(zp)
                ax.plot(t[okp], zp[okp], color="0.6", lw=2.5, label="platform", zorder=1)
            else:
                notes.append("no platform height (z_WP_m)")
            plot_by_mode(ax, t[ok], z[ok], None if modes is None else modes[ok], seen)
            ax.set_xlabel("t (s)")
            ax.set_ylabel("z_W (m)")
            ax.set_title("altitude")
        ax.grid(True, lw=0.3, alpha=0.5)
    handles, labels = [], []
    for ax in axes[0]:
        for h, lab in zip(*ax.get_legend_handles_labels()):
            if lab not in labels:
                handles.append(h)
                labels.append(lab)
    fig.legend(handles, labels, loc="lower center", ncol=min(len(labels), 6), fontsize=8, frameon=False,
               bbox_to_anchor=(0.5, -0.08))
    fig.suptitle(mpl_text(run_id, 60), fontsize=10)
    if not can_top:
        notes.append("no top view (x_WB_m, y_WB_m missing)")
    if not can_alt:
        notes.append("no altitude plot (t_s, z_WB_m missing)")
    return fig, notes


def failure_sort_key(worst_pos):
    def key(r):
        status = (r.get("status") or "").strip()
        outcome = (r.get("outcome") or "").strip()
        sim = status in SIMULATOR_FAILURES or (status not in ("", "ok"))
        return (0 if sim else 1, worst_pos.get(r.get("id"), 1 << 30),
                OUTCOME_RANK.get(status if sim else outcome, 50), r.get("id", ""))
    return key


def section_failed(d, doc, rows):
    out = ['<h2 id="failed">Failed runs</h2>']
    failed = [r for r in rows if not is_true(r.get("landed"))]
    if not failed:
        out.append(placeholder("no failed runs" if rows else "no completed runs"))
        return "\n".join(out)
    worst = doc.get("worst_runs") if isinstance(doc.get("worst_runs"), list) else []
    worst_pos = {w.get("id"): i for i, w in enumerate(worst) if isinstance(w, dict)}
    failed.sort(key=failure_sort_key(worst_pos))
    shown, rest = failed[:MAX_FAILED_PLOTS], failed[MAX_FAILED_PLOTS:]
    out.append('<p class="note">%d run(s) did not land; %s, simulator failures first.</p>'
               % (len(failed), "all shown" if not rest else "the worst %d shown" % len(shown)))
    for r in shown:
        run_id = r.get("id", "")
        status = r.get("status", "")
        out.append('<div class="run"><h3><code>%s</code> &mdash; %s, %s: %s</h3>' % (
            esc(run_id), esc(r.get("scenario")), esc(status), esc(r.get("outcome"))))
        if r.get("detail"):
            out.append('<p class="detail">%s</p>' % esc(r.get("detail")))
        run_dir = safe_run_dir(d, run_id)
        info = read_run_json(d, run_id) if run_dir else {}
        trace_path = os.path.join(run_dir, "trace.csv") if run_dir else None
        tr = read_trace(trace_path) if trace_path and os.path.isfile(trace_path) else None
        if tr is not None:
            fig, notes = failed_run_plot(tr, run_id)
            if fig is None:
                out.append(placeholder(notes))
            else:
                out.append(fig_to_img(fig, "run:" + run_id, "trace of run " + run_id))
                if notes:
                    out.append('<p class="note">%s</p>' % esc("; ".join(notes)))
        else:
            out.append('<p class="warn">no trace.csv (status: %s; exit: %s; wall: %s s)</p>' % (
                esc(info.get("status", status)), esc(info.get("exit", "?")),
                fmt(info.get("wall_s", r.get("wall_s")), 1, 1)))
        tail = info.get("stderr_tail")
        if tail and (tr is None or status not in ("", "ok")):
            out.append('<p class="note">stderr (tail):</p><pre>%s</pre>' % esc(tail))
        elif tr is None:
            out.append(placeholder("no stderr recorded"))
        out.append("</div>")
    if rest:
        out.append('<p class="note">%d more failed run(s) not plotted: %s</p>' % (
            len(rest), ", ".join("<code>%s</code> (%s)" % (esc(r.get("id")), esc(r.get("outcome")))
                                 for r in rest[:MAX_LISTED_MISSING])
            + (" &hellip;" if len(rest) > MAX_LISTED_MISSING else "")))
    return "\n".join(out)


CSS = """
body{font-family:DejaVu Sans,Helvetica,Arial,sans-serif;margin:24px;color:#222;max-width:1400px}
h1{font-size:22px}h2{font-size:18px;border-bottom:1px solid #ccc;padding-bottom:3px;margin-top:32px}
h3{font-size:14px;margin:16px 0 4px}
table{border-collapse:collapse;font-size:12px;margin:8px 0}
th,td{border:1px solid #ccc;padding:3px 6px;text-align:right;vertical-align:top}
table.kv th,table.kv td,td.left{text-align:left}thead th{background:#f0f0f0;text-align:center}
tr.overall{font-weight:bold;background:#f7f7f7}.ci{color:#666;font-weight:normal}
td.sig{background:#fde0dc}table.worst td{text-align:left}.none{color:#777;font-style:italic}.warn{color:#a33}.note{color:#555;font-size:12px}
.detail{font-size:12px;color:#444}
code{font-family:DejaVu Sans Mono,monospace;font-size:11px}code.cmd{word-break:break-all}
td code{white-space:nowrap}td code.cmd{white-space:normal}
pre{background:#f6f6f6;border:1px solid #ddd;padding:6px;font-size:11px;max-height:300px;overflow:auto;
white-space:pre-wrap;word-break:break-all}
img.plot{display:block;max-width:100%;height:auto;margin:6px 0}
nav a{margin-right:12px;font-size:13px}
"""


def build_page(d, doc, rows):
    limit = num(doc.get("offset_limit_m"))
    if limit is None or limit <= 0:
        limit = DEFAULT_OFFSET_LIMIT_M
    names = scenario_order(doc, rows)
    colours = scenario_colours(names)
    title = "Campaign report: %s" % (doc.get("name") if doc.get("name") is not None else "(unnamed)")
    deck = section_deck(d, rows, names, colours)  # None unless a run has the deck figures
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        '<meta name="viewport" content="width=device-width, initial-scale=1">',
        "<title>%s</title>" % esc(title),
        "<style>%s</style></head><body>" % CSS,
        section_header(doc, d),
        '<nav><a href="#stats">statistics</a><a href="#touchdown">touchdown points</a>'
        + ('<a href="#deck">moving deck</a>' if deck is not None else "") +
        '<a href="#ecdf">offset CDF</a><a href="#rate">landing rate</a><a href="#time">time to land</a>'
        '<a href="#sensitivity">sensitivity</a><a href="#worst">worst runs</a>'
        '<a href="#failed">failed runs</a></nav>',
        section_stats(doc, names),
        section_touchdown(rows, names, colours, limit),
    ] + ([deck] if deck is not None else []) + [
        section_ecdf(rows, names, colours, limit),
        section_rate(doc, names, colours),
        section_time_to_land(rows, names, colours),
        section_sensitivity(doc),
        section_worst(doc),
        section_failed(d, doc, rows),
        "</body></html>",
    ]
    return "\n".join(parts) + "\n"


def write_atomic(path, text):
    tmp = path + ".tmp"
    try:
        with open(tmp, "w", encoding="utf-8") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


def main(argv):
    if len(argv) != 2 or argv[1] in ("-h", "--help"):
        sys.stderr.write(USAGE + "\n")
        return 0 if len(argv) == 2 else 2
    d = argv[1]
    try:
        doc = load_campaign(d)
        rows = load_rows(d, doc)
    except BadInput as e:
        sys.stderr.write("campaign_report: %s: %s\n" % (e.path, e.problem))
        return 2
    matplotlib.rcParams.update({"font.size": 9, "axes.titlesize": 10, "svg.hashsalt": "lander"})
    page = build_page(d, doc, rows)
    out = os.path.join(d, "report.html")
    try:
        write_atomic(out, page)
    except OSError as e:
        sys.stderr.write("campaign_report: %s: cannot write: %s\n" % (out, e.strerror or e))
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
