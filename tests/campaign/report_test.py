#!/usr/bin/env python3
"""Test of tools/campaign_report.py: synthetic campaigns in, self-contained HTML out, checked
with html.parser and then loaded for real in headless Chromium.

Usage: python3 tests/campaign/report_test.py [--lander-tools DIR] [--keep DIR] [unittest args]

  --lander-tools DIR   where campaign_report.py is (default: ../../tools from this file)
  --keep DIR           also copy the generated campaigns, reports and screenshots to DIR
  CHROMIUM=/path       the browser (default: chromium, chromium-browser, google-chrome in PATH)

Chromium is required: without it the browser tests FAIL (they do not skip).
"""

import os
import sys


def _ensure_plotting():
    """The checks read PNGs with matplotlib; re-exec under Debian's python3 if this one lacks it."""
    try:
        import matplotlib  # noqa: F401
        import numpy  # noqa: F401
        return
    except ImportError as e:
        err = e
    system_python = "/usr/bin/python3"
    if (os.environ.get("CAMPAIGN_REPORT_TEST_REEXEC") != "1" and os.path.exists(system_python)
            and os.path.realpath(sys.executable) != os.path.realpath(system_python)):
        os.environ["CAMPAIGN_REPORT_TEST_REEXEC"] = "1"
        os.execv(system_python, [system_python, os.path.abspath(__file__)] + sys.argv[1:])
    sys.stderr.write("report_test: %s (install python3-matplotlib and python3-numpy)\n" % err)
    sys.exit(1)


_ensure_plotting()

import argparse  # noqa: E402
import base64  # noqa: E402
import csv  # noqa: E402
import html.parser  # noqa: E402
import io  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import re  # noqa: E402
import shutil  # noqa: E402
import signal  # noqa: E402
import struct  # noqa: E402
import subprocess  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
import unittest  # noqa: E402

import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.image as mpimg  # noqa: E402
import numpy as np  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
TOOLS = os.path.normpath(os.path.join(HERE, "..", "..", "tools"))
KEEP = None
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
CHROMIUM_TIMEOUT_S = 60
SCRIPT_TIMEOUT_S = 300
WINDOW = (1280, 4000)

INJECTION = '<script>alert("x")</script> & \'single\' "double" $x$ \\n'
STDERR_TAIL = ("lander: segmentation fault <script>alert(2)</script>\n"
               "  at estimator/src/pnp.cpp:42 \u00fc\u00df \u2603 \u0001\n")
CAMPAIGN_NAME = "smoke & <mirrors>"
ODD_SCENARIO = 'gust<i>&"q"$x$'

TRACE_HEADER = ("t_s,mode,x_WB_m,y_WB_m,z_WB_m,roll_rad,pitch_rad,yaw_rad,vx_W_mps,vy_W_mps,vz_W_mps,"
                "x_WP_m,y_WP_m,z_WP_m,yaw_WP_rad,vx_cart_mps,vy_cart_mps,nav_x_m,nav_y_m,nav_z_m,"
                "nav_vx_mps,nav_vy_mps,nav_vz_mps,nav_roll_rad,nav_pitch_rad,nav_yaw_rad,fused_z_m,"
                "fused_h_surface_m,true_h_surface_m,ctl_platform_x_m,ctl_platform_y_m,ctl_platform_z_m,"
                "ctl_platform_vx_mps,ctl_platform_vy_mps,ctl_horizontal_error_m,true_horizontal_error_m,"
                "sp_x_m,sp_y_m,sp_z_m,vision_detected,w0_radps,w1_radps,w2_radps,w3_radps,w4_radps,"
                "w5_radps").split(",")


# ---------------------------------------------------------------------------------------------
# synthetic campaigns

def trace_rows(seed, n=300, dt=0.2):
    """A plausible closed-loop trace: cart driving along x, vehicle searching, approaching,
    going around once and failing to settle."""
    rng = np.random.default_rng(seed)
    modes = ["search"] * 25 + ["observe"] * 25 + ["approach"] * 120 + ["go_around"] * 30 + \
            ["approach"] * 50 + ["recovery"] * 30 + ["touchdown"] * 20
    rows = []
    for k in range(n):
        t = k * dt
        cx, cy = 0.5 * t, 0.02 * t * t / 10
        frac = min(1.0, t / 40.0)
        x = -5 + (cx + 5) * frac + 0.3 * math.sin(t) + rng.normal(0, 0.02)
        y = cy + 0.4 * math.cos(0.7 * t) * (1 - frac) + rng.normal(0, 0.02)
        z = max(1.2, 10 - 0.2 * t) + (2.0 if modes[k % len(modes)] == "go_around" else 0.0)
        r = {c: "%.4f" % rng.normal(0, 0.1) for c in TRACE_HEADER}
        r.update({"t_s": "%.3f" % t, "mode": modes[k % len(modes)], "x_WB_m": "%.4f" % x,
                  "y_WB_m": "%.4f" % y, "z_WB_m": "%.4f" % z, "x_WP_m": "%.4f" % cx, "y_WP_m": "%.4f" % cy,
                  "z_WP_m": "1.0000", "vision_detected": str(int(k % 3 != 0))})
        rows.append(r)
    return rows


def write_trace(path, rows, header=TRACE_HEADER, truncate_last=False):
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=header, extrasaction="ignore", lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow(r)
    text = buf.getvalue()
    if truncate_last:
        text = text[:-(len(text.rstrip("\n").split("\n")[-1]) // 2 + 1)]  # cut the last line in half
    with open(path, "w", encoding="utf-8", newline="") as f:
        f.write(text)


def wilson(k, n):
    z = 1.959963984540054
    p = k / n
    den = 1 + z * z / n
    c = (p + z * z / (2 * n)) / den
    h = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / den
    return [max(0.0, c - h), min(1.0, c + h)]


def summary(vals):
    if not vals:
        return {"n": 0, "mean": None, "median": None, "p95": None, "max": None}
    a = np.array(vals)
    return {"n": len(vals), "mean": float(a.mean()), "median": float(np.median(a)),
            "p95": float(np.percentile(a, 95)), "max": float(a.max())}


def stats(runs):
    landed = [r for r in runs if r["landed"]]
    outcomes = {}
    for r in runs:
        outcomes[r["outcome"]] = outcomes.get(r["outcome"], 0) + 1
    off = summary([r["offset"] for r in landed])
    if off["n"]:
        off["p95_ci95"] = [off["median"], off["max"]]
    n = len(runs)
    return {
        "runs": n, "landed": len(landed),
        "landing_rate": {"value": len(landed) / n if n else None, "ci95": wilson(len(landed), n) if n else None},
        "landing_failures": sum(1 for r in runs if not r["landed"] and r["status"] == "ok"),
        "simulator_failures": sum(1 for r in runs if r["status"] != "ok"),
        "outcomes": outcomes,
        "touchdown_offset_m": off,
        "touchdown_rel_speed_mps": summary([r["speed"] for r in landed]),
        "touchdown_tilt_deg": summary([r["tilt"] for r in landed]),
        "time_to_land_s": summary([r["ttl"] for r in landed]),
    }


CSV_COLUMNS = ["id", "scenario", "seed", "outcome", "landed", "touchdown_offset_m", "cart.speed_mps",
               "vehicle.start_m[0]", "vehicle.start_m[1]", "vehicle.start_m[2]", "cart.path",
               "touchdown_x_P_m", "touchdown_y_P_m", "touchdown_rel_speed_mps", "touchdown_tilt_deg",
               "time_to_land_s", "wall_s", "status", "detail"]


def make_campaign(d, plan, name=CAMPAIGN_NAME, planned=None, missing=(), special=None, worst_ids=()):
    """plan: {scenario: [outcome, ...]} (outcome 'landed' or a failure; simulator failures are
    crashed/error/hung/diverged). special: {run id: 'notrace' | 'header_only' | 'truncated' |
    'no_xy' | 'reordered'}. Returns the list of run records."""
    special = special or {}
    os.makedirs(os.path.join(d, "runs"), exist_ok=True)
    rng = np.random.default_rng(7)
    runs = []
    seed = 100
    for scen, outcomes in plan.items():
        for i, outcome in enumerate(outcomes):
            seed += 1
            rid = "%s-%04d" % (scen, i)
            status = outcome if outcome in ("crashed", "error", "hung", "diverged") else "ok"
            landed = outcome == "landed"
            r = {"id": rid, "scenario": scen, "seed": seed, "outcome": outcome, "landed": landed,
                 "status": status, "speed": float(rng.uniform(0.1, 0.5)), "tilt": float(rng.uniform(0, 6)),
                 "ttl": float(rng.uniform(20, 50)), "cart_speed": float(rng.uniform(0.3, 1.2)),
                 "path": ["straight", "arc"][i % 2]}
            if landed:
                x, y = rng.normal(0, 0.035, 2)
                if i == 0 and scen == "default":
                    x, y = 0.42, -0.3  # a wide landing, outside the zoomed panel
                r.update(x=float(x), y=float(y), offset=float(math.hypot(x, y)))
            r["detail"] = {"landed": "landed", "timeout": "no landing within duration_s = 60.0 s",
                           "touched_ground": "skid touched the ground at t = 31.2 s",
                           "tipped_over": "tilt 48 deg after contact",
                           "crashed": "signal 11 (SIGSEGV)",
                           "diverged": "state not finite at t = 12.3 s"}.get(outcome, outcome)
            runs.append(r)
    # the injection goes into a failure's detail (campaign.csv and worst_runs)
    for r in runs:
        if r["outcome"] == "touched_ground":
            r["detail"] = "skid hit the ground " + INJECTION
            break
    with open(os.path.join(d, "campaign.csv"), "w", encoding="utf-8", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(CSV_COLUMNS)
        for r in runs:
            L = r["landed"]
            w.writerow([r["id"], r["scenario"], r["seed"], r["outcome"], int(L),
                        "%.5f" % r["offset"] if L else "", "%.3f" % r["cart_speed"], "-5.0", "0.0", "10.0",
                        r["path"], "%.5f" % r["x"] if L else "", "%.5f" % r["y"] if L else "",
                        "%.3f" % r["speed"] if L else "", "%.2f" % r["tilt"] if L else "",
                        "%.2f" % r["ttl"] if L else "", "12.5", r["status"], r["detail"]])
    for r in runs:
        rd = os.path.join(d, "runs", r["id"])
        os.makedirs(rd, exist_ok=True)
        info = {"id": r["id"], "scenario": r["scenario"], "status": r["status"], "outcome": r["outcome"],
                "exit": -11 if r["status"] == "crashed" else (0 if r["landed"] else 1), "wall_s": 12.5,
                "stderr_tail": STDERR_TAIL if r["status"] == "crashed" else ""}
        with open(os.path.join(rd, "run.json"), "w", encoding="utf-8") as f:
            json.dump(info, f)
        kind = special.get(r["id"], "notrace" if r["status"] == "crashed" else "normal")
        if r["landed"] or kind == "notrace":
            continue
        tp = os.path.join(rd, "trace.csv")
        rows = trace_rows(r["seed"])
        if kind == "header_only":
            write_trace(tp, [])
        elif kind == "truncated":
            for row in rows[-5:]:
                row["x_WB_m"], row["z_WB_m"] = "nan", "inf"
            write_trace(tp, rows, truncate_last=True)
        elif kind == "no_xy":
            write_trace(tp, rows, header=[c for c in TRACE_HEADER if c not in ("x_WB_m", "y_WB_m")])
        elif kind == "reordered":
            hdr = list(reversed(TRACE_HEADER)) + ["extra_col"]
            for row in rows:
                row["extra_col"] = "zz"
            write_trace(tp, rows, header=hdr)
        else:
            write_trace(tp, rows)

    scen_stats = {s: stats([r for r in runs if r["scenario"] == s]) for s in plan}
    by_id = {r["id"]: r for r in runs}
    worst = []
    for wid in worst_ids:
        r = by_id[wid]
        worst.append({"id": wid, "scenario": r["scenario"], "outcome": r["outcome"], "status": r["status"],
                      "landed": r["landed"], "touchdown_offset_m": r.get("offset"), "detail": r["detail"],
                      "rerun": "lander run '%s/runs/%s/scenario.resolved.yaml' --out '%s/rerun/%s' --video"
                               % (d, wid, d, wid)})
    doc = {
        "schema_version": 1, "name": name, "master_seed": 1,
        "campaign_file": "/abs/path/campaigns/smoke.yaml", "offset_limit_m": 0.10,
        "runs_planned": planned if planned is not None else len(runs) + len(missing),
        "runs_complete": len(runs), "missing": list(missing),
        "dispersion_keys": ["cart.speed_mps", "vehicle.start_m", "cart.path"],
        "overall": stats(runs), "scenarios": scen_stats, "worst_runs": worst,
        "sensitivity": [
            {"input": "cart.speed_mps", "kind": "numeric", "n": len(runs),
             "offset_spearman": {"rho": 0.41, "p": 0.02, "n": 9},
             "failure_spearman": {"rho": -0.2, "p": None, "n": len(runs)}},
            {"input": "vehicle.start_m[0]", "kind": "numeric", "n": len(runs),
             "offset_spearman": None, "failure_spearman": {"rho": None, "p": None, "n": 0}},
            {"input": "cart.path", "kind": "categorical",
             "levels": {"straight": {"runs": 3, "landed": 3, "landing_rate": 1.0, "offset_median_m": 0.02},
                        "arc<b>": {"runs": 3, "landed": 2, "landing_rate": 0.667, "offset_median_m": None}}},
        ] if runs else [],
    }
    with open(os.path.join(d, "campaign.json"), "w", encoding="utf-8") as f:
        json.dump(doc, f, indent=1)
    return runs


# ---------------------------------------------------------------------------------------------
# helpers

class PageParser(html.parser.HTMLParser):
    def __init__(self):
        super().__init__(convert_charrefs=True)
        self.tags = []          # (tag, attrs dict) of every start tag
        self.text = []
        self.title = ""
        self.h1 = ""
        self._in = []

    def handle_starttag(self, tag, attrs):
        self.tags.append((tag, dict(attrs)))
        self._in.append(tag)

    def handle_startendtag(self, tag, attrs):
        self.tags.append((tag, dict(attrs)))

    def handle_endtag(self, tag):
        if tag in self._in:
            while self._in and self._in.pop() != tag:
                pass

    def handle_data(self, data):
        self.text.append(data)
        if "title" in self._in:
            self.title += data
        if "h1" in self._in:
            self.h1 += data

    def imgs(self):
        return [a for t, a in self.tags if t == "img"]


def parse(path):
    with open(path, "r", encoding="utf-8") as f:
        raw = f.read()
    p = PageParser()
    p.feed(raw)
    p.close()
    return raw, p


def png_size(data):
    """(width, height) from a PNG's IHDR; asserts the signature and chunk layout."""
    if data[:8] != PNG_SIGNATURE:
        raise AssertionError("not a PNG (signature %r)" % data[:8])
    length, ctype = struct.unpack(">I4s", data[8:16])
    if ctype != b"IHDR" or length != 13:
        raise AssertionError("PNG without IHDR first")
    return struct.unpack(">II", data[16:24])


def decode_data_uri(src):
    m = re.fullmatch(r"data:image/png;base64,([A-Za-z0-9+/=]+)", src or "")
    if not m:
        raise AssertionError("img src is not a base64 PNG data URI: %r" % (src or "")[:80])
    return base64.b64decode(m.group(1), validate=True)


def find_chromium():
    for c in [os.environ.get("CHROMIUM"), "chromium", "chromium-browser", "google-chrome"]:
        if c and shutil.which(c):
            return shutil.which(c)
    return None


def run_chromium(args, tmp):
    """Runs headless Chromium with a fresh profile; returns stdout (bytes). Kills the whole
    process group it started on timeout."""
    exe = find_chromium()
    if exe is None:
        raise AssertionError("chromium not found in PATH (apt-get install chromium, or set CHROMIUM=): "
                             "the report's browser test cannot run")
    profile = tempfile.mkdtemp(prefix="profile-", dir=tmp)
    cmd = [exe, "--headless", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
           "--no-first-run", "--no-default-browser-check", "--disable-extensions", "--hide-scrollbars",
           "--mute-audio", "--user-data-dir=" + profile] + args
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True)
    try:
        out, err = proc.communicate(timeout=CHROMIUM_TIMEOUT_S)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate()
        raise AssertionError("chromium did not finish within %d s: %s" % (CHROMIUM_TIMEOUT_S, cmd))
    if proc.returncode != 0:
        raise AssertionError("chromium exited with %d: %s\n%s" % (proc.returncode, cmd, err.decode(errors="replace")[-3000:]))
    return out


def screenshot(page, png, tmp):
    run_chromium(["--window-size=%d,%d" % WINDOW, "--screenshot=" + png, "file://" + page], tmp)
    if not os.path.isfile(png):
        raise AssertionError("chromium wrote no screenshot %s" % png)
    with open(png, "rb") as f:
        data = f.read()
    w, h = png_size(data)
    img = mpimg.imread(png)
    return data, (w, h), img


def non_white_fraction(img):
    rgb = img[..., :3]
    if rgb.dtype != np.float32 and rgb.dtype != np.float64:
        rgb = rgb / 255.0
    return float(np.mean(np.any(rgb < 0.94, axis=-1)))


def run_report(d):
    return subprocess.run([sys.executable, os.path.join(TOOLS, "campaign_report.py"), d],
                          stdout=subprocess.PIPE, stderr=subprocess.PIPE, timeout=SCRIPT_TIMEOUT_S)


def keep(name, src):
    if KEEP:
        dst = os.path.join(KEEP, name)
        if os.path.isdir(src):
            shutil.copytree(src, dst, dirs_exist_ok=True)
        else:
            os.makedirs(os.path.dirname(dst), exist_ok=True)
            shutil.copy(src, dst)


# ---------------------------------------------------------------------------------------------
# the full campaign: 3 scenarios, landed and failed runs, a crash, odd characters

FULL_PLAN = {
    "default": ["landed", "landed", "timeout", "landed", "touched_ground", "crashed", "landed", "landed"],
    "cart_1mps_turning": ["timeout", "landed", "tipped_over", "timeout", "landed", "diverged", "landed", "timeout"],
    ODD_SCENARIO: ["timeout", "landed", "timeout", "timeout", "timeout", "timeout"],
}
FULL_SPECIAL = {
    "cart_1mps_turning-0000": "header_only",   # trace with no rows: listed, no plot
    "cart_1mps_turning-0005": "truncated",     # diverged: inf/nan at the end, last line cut
    "cart_1mps_turning-0003": "reordered",     # columns in another order plus an extra one
    ODD_SCENARIO + "-0000": "no_xy",           # altitude only
}
FULL_WORST = ["default-0005", "cart_1mps_turning-0005", "cart_1mps_turning-0002", "default-0004",
              "default-0002"]
# 13 failed runs; worst first: simulator failures (crash, diverged), then by the worst_runs
# order (tipped_over, touched_ground, default-0002 timeout), then the other timeouts by id.
FULL_FAILED_ORDER = ["default-0005", "cart_1mps_turning-0005", "cart_1mps_turning-0002", "default-0004",
                     "default-0002", "cart_1mps_turning-0000", "cart_1mps_turning-0003",
                     "cart_1mps_turning-0007", ODD_SCENARIO + "-0000", ODD_SCENARIO + "-0002",
                     ODD_SCENARIO + "-0003", ODD_SCENARIO + "-0004", ODD_SCENARIO + "-0005"]
FULL_SHOWN = FULL_FAILED_ORDER[:12]
FULL_RUN_PLOTS = [r for r in FULL_SHOWN if r not in ("default-0005", "cart_1mps_turning-0000")]
SUMMARY_PLOTS = ["touchdown", "ecdf", "rate", "time_to_land"]


class ReportedCampaign(unittest.TestCase):
    """A campaign directory made once for the class (cls.tmp, cls.proc: the report's run);
    every test starts by checking that the report ran."""

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.tmp, ignore_errors=True)

    def setUp(self):
        self.assertEqual(self.proc.returncode, 0, "campaign_report.py failed:\n" +
                         self.proc.stderr.decode(errors="replace"))


class FullCampaign(ReportedCampaign):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.mkdtemp(prefix="campaign_report_test-")
        cls.dir = os.path.join(cls.tmp, "camp aign")  # a space in the path
        os.makedirs(cls.dir)
        make_campaign(cls.dir, FULL_PLAN, missing=["default-0008", "x<y>"], special=FULL_SPECIAL,
                      worst_ids=FULL_WORST)
        t0 = time.monotonic()
        cls.proc = run_report(cls.dir)
        cls.report_s = time.monotonic() - t0
        cls.report = os.path.join(cls.dir, "report.html")
        keep("full", cls.dir)

    def test_written_atomically(self):
        self.assertTrue(os.path.isfile(self.report))
        self.assertFalse(os.path.exists(self.report + ".tmp"))
        size = os.path.getsize(self.report)
        self.assertLess(size, 6 * 1024 * 1024, "report is %d bytes" % size)
        self.assertLess(self.report_s, 240)

    def test_title_and_header(self):
        raw, p = parse(self.report)
        self.assertEqual(p.title.strip(), "Campaign report: " + CAMPAIGN_NAME)
        self.assertEqual(p.h1.strip(), "Campaign report: " + CAMPAIGN_NAME)
        text = "".join(p.text)
        self.assertIn("22 / 24", text)  # runs complete / planned
        self.assertIn("default-0008", text)
        self.assertIn("x<y>", text)  # missing id, unescaped by the parser
        self.assertIn("x&lt;y&gt;", raw)

    def test_images_are_embedded_pngs(self):
        raw, p = parse(self.report)
        imgs = p.imgs()
        names = [a.get("data-plot") for a in imgs]
        self.assertEqual(names, SUMMARY_PLOTS + ["run:" + r for r in FULL_RUN_PLOTS])
        for a in imgs:
            data = decode_data_uri(a.get("src"))
            w, h = png_size(data)
            self.assertEqual((a.get("width"), a.get("height")), (str(w), str(h)))
            self.assertGreater(w, 200)
            self.assertGreater(h, 150)
            self.assertLess(max(w, h), 2000)
            img = mpimg.imread(io.BytesIO(data), format="png")  # decodes completely
            self.assertEqual(img.shape[:2], (h, w))
            self.assertGreater(non_white_fraction(img), 0.01, a.get("data-plot"))
        # nothing external: no links, scripts, iframes, remote URLs
        for tag, attrs in p.tags:
            self.assertNotIn(tag, ("script", "link", "iframe", "object", "embed"))
            for k in ("src", "href"):
                v = attrs.get(k)
                if v is not None:
                    self.assertTrue(v.startswith("data:") or v.startswith("#"), "%s %s=%r" % (tag, k, v[:80]))
        self.assertNotRegex(raw, r"(?i)https?://|url\(")

    def test_strings_from_files_are_escaped(self):
        raw, p = parse(self.report)
        self.assertNotIn("<script", raw.lower())
        self.assertIn("&lt;script&gt;alert(", raw)
        text = "".join(p.text)
        self.assertIn(INJECTION, text)            # the detail string survives intact
        self.assertIn("<script>alert(2)</script>", text)  # the crash's stderr tail
        self.assertIn(ODD_SCENARIO, text)
        self.assertNotIn("<i>", raw)
        self.assertIn(html_escape(ODD_SCENARIO), raw)

    def test_tables(self):
        raw, p = parse(self.report)
        text = "".join(p.text)
        # worst runs with the exact rerun command in <code>
        for wid in FULL_WORST:
            self.assertIn("lander run '%s/runs/%s/scenario.resolved.yaml' --out '%s/rerun/%s' --video"
                          % (self.dir, wid, self.dir, wid), text)
        self.assertGreaterEqual(sum(1 for t, _ in p.tags if t == "code"), len(FULL_WORST))
        # statistics: a row per scenario and overall; the overall landing rate 9/22
        self.assertIn("40.9%", text)
        lo, hi = wilson(9, 22)
        self.assertIn("[%.1f, %.1f]" % (100 * lo, 100 * hi), text)
        for s in list(FULL_PLAN) + ["overall"]:
            self.assertIn(s, text)
        # sensitivity
        self.assertIn("cart.speed_mps", text)
        self.assertIn("arc<b>", text)
        self.assertIn("0.41", text)

    def test_failed_runs_order_and_cap(self):
        raw, p = parse(self.report)
        h3 = []
        for m in re.finditer(r"<h3><code>(.*?)</code>", raw):
            h3.append(htmlunescape(m.group(1)))
        self.assertEqual(h3, FULL_SHOWN)
        text = "".join(p.text)
        self.assertIn("1 more failed run(s) not plotted", text)
        self.assertIn(FULL_FAILED_ORDER[12], text)
        self.assertIn("no trace.csv", text)
        self.assertIn("no top view", text)

    _probe = None

    @classmethod
    def probe(cls):
        """Loads a copy of the report with a probe script appended in Chromium (same window as the
        screenshots) and returns, per <img>: data-plot, complete, naturalWidth, naturalHeight and
        its box in page pixels (left, top, width, height), and, drawn on a canvas, the number of
        not fully opaque pixels and of ink pixels (any channel < 230). Cached: Chromium runs once for it."""
        if cls._probe is None:
            with open(cls.report, encoding="utf-8") as f:
                raw = f.read()
            script = ("<script>window.addEventListener('load',function(){var r=[];"
                      "document.querySelectorAll('img').forEach(function(i){var b=i.getBoundingClientRect();"
                      "var c=document.createElement('canvas');c.width=i.naturalWidth;c.height=i.naturalHeight;"
                      "var x=c.getContext('2d');var clear=-1,ink=-1;"
                      "if(i.naturalWidth>0){x.drawImage(i,0,0);var d=x.getImageData(0,0,c.width,c.height).data;"
                      "clear=0;ink=0;for(var k=0;k<d.length;k+=4){if(d[k+3]<255)clear++;"
                      "if(d[k]<230||d[k+1]<230||d[k+2]<230)ink++;}}"
                      "r.push([i.getAttribute('data-plot'),i.complete,i.naturalWidth,i.naturalHeight,"
                      "b.left+window.scrollX,b.top+window.scrollY,b.width,b.height,clear,ink]);});"
                      "var e=document.createElement('pre');e.id='probe-result';"
                      "e.textContent=JSON.stringify(r);document.body.appendChild(e);});</script>")
            probed = os.path.join(cls.tmp, "probed.html")
            with open(probed, "w", encoding="utf-8") as f:
                f.write(raw.replace("</body>", script + "</body>"))
            dom = run_chromium(["--window-size=%d,%d" % WINDOW, "--virtual-time-budget=5000", "--dump-dom",
                                "file://" + probed], cls.tmp).decode("utf-8", errors="replace")
            m = re.search(r'<pre id="probe-result">(.*?)</pre>', dom, re.S)
            if m is None:
                raise AssertionError("the probe script did not run in chromium")
            cls._probe = json.loads(htmlunescape(m.group(1)))
        return cls._probe

    def test_chromium_dom_and_image_decoding(self):
        raw, p = parse(self.report)
        expected = [decode_data_uri(a["src"]) for a in p.imgs()]
        # the DOM Chromium builds from the report (no script of its own) has every image
        dom = run_chromium(["--dump-dom", "file://" + self.report], self.tmp).decode("utf-8", errors="replace")
        dp = PageParser()
        dp.feed(dom)
        self.assertEqual([a.get("data-plot") for a in dp.imgs()], [a.get("data-plot") for a in p.imgs()])
        self.assertEqual([a.get("src") for a in dp.imgs()], [a.get("src") for a in p.imgs()])
        self.assertEqual([t for t, _ in dp.tags if t == "script"], [])
        # and Chromium decoded every one of them at the PNG's own size
        result = self.probe()
        self.assertEqual([r[0] for r in result], [a.get("data-plot") for a in p.imgs()])
        for (name, complete, nw, nh, _, _, bw, bh, clear, ink), data in zip(result, expected):
            self.assertTrue(complete, name)
            self.assertEqual((nw, nh), png_size(data), "chromium did not decode image %s" % name)
            self.assertGreater(bw * bh, 0, "image %s is not laid out" % name)
            # matplotlib's PNGs are opaque: a partly decoded image leaves transparent pixels
            self.assertEqual(clear, 0, "image %s: %d pixels not decoded" % (name, clear))
            ref = np.round(flatten_rgb(mpimg.imread(io.BytesIO(data), format="png")) * 255)
            ref_ink = int(np.sum(np.any(ref < 230, axis=-1)))
            self.assertLessEqual(abs(ink - ref_ink), 0.02 * ref_ink + 10,
                                 "image %s: chromium shows %d ink pixels, the PNG has %d" % (name, ink, ref_ink))

    def test_chromium_renders_page(self):
        page = self.report
        shot = os.path.join(self.tmp, "report.png")
        data, (w, h), img = screenshot(page, shot, self.tmp)
        keep("report.png", shot)
        self.assertEqual((w, h), WINDOW)
        blank = os.path.join(self.tmp, "blank.html")
        with open(blank, "w") as f:
            f.write("<!DOCTYPE html><html><body></body></html>")
        blank_data, _, blank_img = screenshot(blank, os.path.join(self.tmp, "blank.png"), self.tmp)
        self.assertLess(non_white_fraction(blank_img), 0.001)
        self.assertGreater(len(data), 5 * len(blank_data))
        self.assertGreater(non_white_fraction(img), 0.02)
        # Control: the same page with every image undecodable (same width/height, so the same
        # layout). The plots' pixels must be in the real screenshot where Chromium put the
        # images, and not in the control's.
        with open(page, encoding="utf-8") as f:
            raw = f.read()
        broken = re.sub(r'src="data:image/png;base64,[^"]*"', 'src="data:image/png;base64,iVBORw0KGgoAAAA"', raw)
        self.assertNotEqual(broken, raw)
        broken_page = os.path.join(self.tmp, "broken.html")
        with open(broken_page, "w", encoding="utf-8") as f:
            f.write(broken)
        _, _, broken_img = screenshot(broken_page, os.path.join(self.tmp, "broken.png"), self.tmp)
        keep("broken.png", os.path.join(self.tmp, "broken.png"))
        _, p = parse(page)
        pngs = {a.get("data-plot"): decode_data_uri(a.get("src")) for a in p.imgs()}
        checked = []
        for name, _, nw, nh, left, top, bw, bh, _, _ in self.probe():
            if top + bh > WINDOW[1] - 2 or left + bw > WINDOW[0] - 2:
                continue  # below the screenshot
            ref = mpimg.imread(io.BytesIO(pngs[name]), format="png")
            real = ink_match(img, ref, left, top)
            ctrl = ink_match(broken_img, ref, left, top)
            sys.stderr.write("\n  %s at (%.0f, %.0f): plot ink found %.3f, in the broken control %.3f"
                             % (name, left, top, real, ctrl))
            self.assertGreater(real, 0.9, "image %s is not on the screenshot" % name)
            self.assertLess(ctrl, 0.5, "the control does not tell a missing image %s" % name)
            checked.append(name)
        sys.stderr.write("\n")
        self.assertGreaterEqual(len(checked), 3, "too few plots in the first %d px: %s" % (WINDOW[1], checked))


def flatten_rgb(img):
    """RGB floats in [0, 1], an alpha channel composited on white (as the page shows it)."""
    img = img.astype(np.float64)
    if img.max() > 1.0:
        img = img / 255.0
    if img.shape[-1] == 4:
        img = img[..., :3] * img[..., 3:4] + (1.0 - img[..., 3:4])
    return img[..., :3]


def ink_match(shot, ref, left, top):
    """Fraction of the reference PNG's ink (non-white pixels) that the screenshot reproduces at
    (left, top), within 0.12 per channel; the best over +-1 px shifts (sub-pixel placement)."""
    ref = flatten_rgb(ref)
    shot = shot[..., :3].astype(np.float64)
    if shot.max() > 1.0:
        shot = shot / 255.0
    ink = np.any(ref < 0.9, axis=-1)
    h, w = ink.shape
    best = 0.0
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            y0, x0 = int(round(top)) + dy, int(round(left)) + dx
            if y0 < 0 or x0 < 0 or y0 + h > shot.shape[0] or x0 + w > shot.shape[1]:
                continue
            crop = shot[y0:y0 + h, x0:x0 + w]
            close = np.all(np.abs(crop - ref) < 0.12, axis=-1)
            best = max(best, float(np.mean(close[ink])) if ink.any() else 0.0)
    return best


def html_escape(s):
    import html as _h
    return _h.escape(s, quote=True)


def htmlunescape(s):
    import html as _h
    return _h.unescape(s)


# ---------------------------------------------------------------------------------------------
# a moving-deck campaign: summary.json with the deck's figures at the first contact, traces of a
# heaving deck

DECK_PLAN = {
    "deck_calm": ["landed", "landed", "landed", "timeout", "landed", "landed"],
    "deck_rough": ["landed", "landed", "tipped_over", "landed", "timeout"],
    "static": ["landed", "landed", "timeout"],            # no deck: its touchdowns have no deck figures
}
DECK_NO_TRACE = "deck_rough-0001"       # the largest |rel. vertical speed|, and no trace.csv
DECK_NO_SUMMARY = "deck_calm-0005"      # no summary.json at all
DECK_BAD_SUMMARY = "deck_rough-0004"    # summary.json that is not JSON
DECK_NO_CUT = "deck_calm-0002"          # landed without a deck_cut event
DECK_FALLBACK_WINDOW = "deck_calm-0001"  # a deck_window whose reason has no "a-b s"
GEAR_HEIGHT_M = 0.25


def deck_z(t):
    return 1.0 + 0.3 * math.sin(2 * math.pi * t / 7.0)


def deck_trace_rows(t_contact, t_end, dt=0.02):
    """The deck heaving, the vehicle's gear coming down onto it at t_contact and then riding it."""
    rows = []
    for k in range(int(t_end / dt) + 1):
        t = k * dt
        zp = deck_z(t)
        zb = GEAR_HEIGHT_M + zp + 0.3 * max(0.0, t_contact - t)
        mode = "approach" if t < t_contact - 4 else ("recovery" if t < t_contact else "landed")
        r = {c: "0.0000" for c in TRACE_HEADER}
        r.update({"t_s": "%.3f" % t, "mode": mode, "z_WB_m": "%.5f" % zb, "z_WP_m": "%.5f" % zp,
                  "vz_W_mps": "%.5f" % (-0.3 if t < t_contact else 0.0)})
        rows.append(r)
    return rows


def deck_summary(run, rng, i):
    """A summary.json for a deck run: touchdown with the deck figures and landing_decision events."""
    tc = float(rng.uniform(14.0, 24.0))
    rel = -1.3 if run["id"] == DECK_NO_TRACE else -float(rng.uniform(0.05, 0.95))
    events = [{"t_s": 3.0, "attempt": 1, "what": "attempt_started", "reason": "80 keyframes observed (>= 80)"}]
    for w0 in (tc - 6.0, tc - 1.0):
        reason = ("deck quiescent %.2f-%.2f s by its prediction (vertical speed 0.10 m/s, tilt 2.0 deg)"
                  % (w0, w0 + 0.8))
        if run["id"] == DECK_FALLBACK_WINDOW and w0 < tc - 2:
            reason = "deck quiescent by its prediction"
        events.append({"t_s": w0, "attempt": 1, "what": "deck_window", "reason": reason})
    if run["landed"] and run["id"] != DECK_NO_CUT:
        events.append({"t_s": tc - 0.1, "attempt": 1, "what": "deck_cut", "reason": events[-1]["reason"]})
        events.append({"t_s": tc - 0.1, "attempt": 1, "what": "cut", "reason": "cut: " + events[-2]["reason"]})
    return {"scenario": run["scenario"], "landed": run["landed"], "outcome": run["outcome"],
            "touchdown": {"surface": "platform", "t_s": tc, "offset_m": 0.02, "rel_speed_mps": abs(rel),
                          "rel_vertical_speed_mps": rel, "tilt_deg": 1.0,
                          "mode_at_contact": "approach" if i == 4 else ("recovery" if i % 3 else "touchdown"),
                          "deck_tilt_deg": float(rng.uniform(0.5, 9.0)),
                          "deck_heave_m": float(rng.uniform(-0.5, 0.5)),
                          "deck_vz_mps": float(rng.uniform(-0.6, 0.6))},
            "landing_decision": {"attempts": 1, "events": events}}


def write_summaries(d, runs, deck_scenarios):
    """summary.json (and, for deck runs, trace.csv) for every run; deck runs per deck_scenarios."""
    rng = np.random.default_rng(11)
    for i, r in enumerate(runs):
        rd = os.path.join(d, "runs", r["id"])
        if r["scenario"] in deck_scenarios:
            summ = deck_summary(r, rng, i)
            if r["id"] != DECK_NO_TRACE:
                tc = summ["touchdown"]["t_s"]
                write_trace(os.path.join(rd, "trace.csv"), deck_trace_rows(tc, tc + (3.0 if r["landed"] else 8.0)))
            elif os.path.exists(os.path.join(rd, "trace.csv")):
                os.unlink(os.path.join(rd, "trace.csv"))
        else:  # a static platform: no deck figures; a run without contact has an empty touchdown
            td = {"surface": "platform", "t_s": 20.0, "offset_m": 0.03, "rel_vertical_speed_mps": -0.3,
                  "mode_at_contact": "touchdown"} if r["landed"] else None
            summ = {"landed": r["landed"], "outcome": r["outcome"], "touchdown": td,
                    "landing_decision": {"events": []}}
        if r["id"] == DECK_NO_SUMMARY:
            continue
        with open(os.path.join(rd, "summary.json"), "w", encoding="utf-8") as f:
            if r["id"] == DECK_BAD_SUMMARY:
                f.write('{"touchdown": {"deck_tilt_deg": 3.0, ')
            else:
                json.dump(summ, f)


def expected_deck(d, runs):
    """What the deck section should show, from the summary.json files as written: per scenario
    the deck records, and the runs to plot with the reason each is shown."""
    recs = []
    for r in runs:
        try:
            with open(os.path.join(d, "runs", r["id"], "summary.json"), encoding="utf-8") as f:
                summ = json.load(f)
        except (OSError, ValueError):
            continue
        td = summ.get("touchdown")
        if isinstance(td, dict) and "deck_tilt_deg" in td:
            events = summ["landing_decision"]["events"]
            recs.append({"id": r["id"], "scenario": r["scenario"], "landed": r["landed"],
                         "rel": abs(td["rel_vertical_speed_mps"]), "tilt": td["deck_tilt_deg"],
                         "mode": td["mode_at_contact"], "cut": any(e["what"] == "deck_cut" for e in events)})
    ranked = sorted(recs, key=lambda x: (x["rel"], x["id"]))
    picks = [ranked[-1]["id"], ranked[(len(ranked) - 1) // 2]["id"]]
    if all(x["landed"] for x in recs if x["id"] in picks):
        picks.append(max((x for x in recs if not x["landed"]), key=lambda x: x["rel"])["id"])
    return recs, picks


def deck_row_cells(recs):
    """The table cells after the scenario name, as the report writes them."""
    speeds = [x["rel"] for x in recs]
    soft = sum(1 for v in speeds if v <= 0.5)
    return [str(len(recs)), str(sum(x["landed"] for x in recs)),
            "%d / %d (%.1f%%)" % (soft, len(speeds), 100.0 * soft / len(speeds)),
            "%.2f" % float(np.median(speeds)), "%.2f" % max(speeds), "%.1f" % max(x["tilt"] for x in recs),
            str(sum(x["mode"] == "recovery" for x in recs)), str(sum(x["cut"] for x in recs))]


def section_html(raw, h2_id):
    i = raw.find('<h2 id="%s">' % h2_id)
    if i < 0:
        raise AssertionError("no section %s" % h2_id)
    j = raw.find("<h2", i + 1)
    return raw[i:j if j >= 0 else len(raw)]


def table_rows(fragment):
    """{row header: [cell texts]} of the <tbody> rows in an HTML fragment."""
    out = {}
    for m in re.finditer(r"<tr[^>]*><th>(.*?)</th>(.*?)</tr>", fragment, re.S):
        cells = [htmlunescape(re.sub(r"<[^>]*>", "", c))
                 for c in re.findall(r"<td[^>]*>(.*?)</td>", m.group(2), re.S)]
        if cells:
            out[htmlunescape(m.group(1))] = cells
    return out


def count_colour(img, rgb, tol=0.04):
    return int(np.sum(np.all(np.abs(flatten_rgb(img) - np.array(rgb)) < tol, axis=-1)))


class DeckCampaign(ReportedCampaign):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.mkdtemp(prefix="campaign_report_deck-")
        cls.dir = os.path.join(cls.tmp, "deck")
        cls.runs = make_campaign(cls.dir, DECK_PLAN, name="deck")
        write_summaries(cls.dir, cls.runs, ("deck_calm", "deck_rough"))
        cls.proc = run_report(cls.dir)
        cls.report = os.path.join(cls.dir, "report.html")
        keep("deck", cls.dir)

    def setUp(self):
        super().setUp()
        self.raw, self.page = parse(self.report)
        self.section = section_html(self.raw, "deck")

    def test_section_placed_after_touchdown(self):
        ids = re.findall(r'<h2 id="([^"]+)">', self.raw)
        self.assertEqual(ids, ["stats", "touchdown", "deck", "ecdf", "rate", "time", "sensitivity", "worst",
                               "failed"])
        self.assertIn('<a href="#deck">', self.raw)

    def test_table_counts(self):
        recs, _ = expected_deck(self.dir, self.runs)
        rows = table_rows(self.section)
        per = {}
        for x in recs:
            per.setdefault(x["scenario"], []).append(x)
        self.assertEqual(sorted(per), ["deck_calm", "deck_rough"])  # the fixture has what it should
        self.assertEqual(set(rows), set(per) | {"all deck runs"})    # no row for the static platform
        for s, xs in per.items():
            self.assertEqual(rows[s], deck_row_cells(xs), s)
        self.assertEqual(rows["all deck runs"], deck_row_cells(recs))

    def test_skipped_summaries_are_noted(self):
        text = htmlunescape(re.sub(r"<[^>]*>", "", self.section))
        self.assertIn("2 run(s) skipped, no readable summary.json", text)
        self.assertIn(DECK_NO_SUMMARY + " (no summary.json)", text)
        self.assertIn(DECK_BAD_SUMMARY + " (summary.json not valid JSON", text)

    def test_plots(self):
        _, picks = expected_deck(self.dir, self.runs)
        self.assertEqual(picks[0], DECK_NO_TRACE)
        self.assertEqual(len(picks), 3)
        names = [a.get("data-plot") for a in self.page.imgs()]
        deck_names = ["deck_scatter"] + ["deck:" + p for p in picks if p != DECK_NO_TRACE]
        i = names.index("touchdown") + 1
        self.assertEqual(names[i:i + len(deck_names)], deck_names)
        self.assertEqual(names[i + len(deck_names)], "ecdf")
        for a in self.page.imgs():
            if a.get("data-plot") in deck_names:
                data = decode_data_uri(a.get("src"))
                w, h = png_size(data)
                self.assertEqual((a.get("width"), a.get("height")), (str(w), str(h)))
                img = mpimg.imread(io.BytesIO(data), format="png")
                self.assertGreater(non_white_fraction(img), 0.01, a.get("data-plot"))
        # the scatter in the scenarios' colours (tab10 in campaign.json's order), none for the static one
        scatter = next(a for a in self.page.imgs() if a.get("data-plot") == "deck_scatter")
        img = mpimg.imread(io.BytesIO(decode_data_uri(scatter.get("src"))), format="png")
        tab10 = matplotlib.colormaps["tab10"].colors
        for k, s in enumerate(DECK_PLAN):
            found = count_colour(img, tab10[k])
            if s == "static":
                self.assertLess(found, 5, s)
            else:
                self.assertGreater(found, 20, s)

    def test_missing_trace_is_noted(self):
        m = re.search(r"<h4><code>%s</code>(.*?)</div>" % re.escape(DECK_NO_TRACE), self.section, re.S)
        self.assertIsNotNone(m)
        self.assertIn("no readable trace.csv", m.group(1))
        self.assertNotIn("<img", m.group(1))


# ---------------------------------------------------------------------------------------------
# edge cases

class EdgeCases(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.mkdtemp(prefix="campaign_report_edge-")

    def tearDown(self):
        shutil.rmtree(self.tmp, ignore_errors=True)

    def assertValidPage(self, d, n_imgs):
        proc = run_report(d)
        self.assertEqual(proc.returncode, 0, proc.stderr.decode(errors="replace"))
        report = os.path.join(d, "report.html")
        self.assertFalse(os.path.exists(report + ".tmp"))
        raw, p = parse(report)
        self.assertTrue(raw.startswith("<!DOCTYPE html>"))
        self.assertTrue(raw.rstrip().endswith("</html>"))
        self.assertEqual(len(p.imgs()), n_imgs, [a.get("data-plot") for a in p.imgs()])
        for a in p.imgs():
            png_size(decode_data_uri(a.get("src")))
        return raw, p, "".join(p.text)

    def test_missing_campaign_json(self):
        d = os.path.join(self.tmp, "nothing")
        os.makedirs(d)
        proc = run_report(d)
        self.assertEqual(proc.returncode, 2)
        err = proc.stderr.decode()
        self.assertTrue(err.startswith("campaign_report: " + os.path.join(d, "campaign.json") + ": "), err)
        self.assertFalse(os.path.exists(os.path.join(d, "report.html")))
        # a directory that does not exist at all
        proc = run_report(os.path.join(self.tmp, "absent"))
        self.assertEqual(proc.returncode, 2)
        self.assertIn("campaign.json", proc.stderr.decode())

    def test_unparsable_campaign_json(self):
        for i, content in enumerate([b'{"name": "x", ', b"[1, 2]", b"\xff\xfe garbage", b""]):
            d = os.path.join(self.tmp, "bad%d" % i)
            os.makedirs(d)
            with open(os.path.join(d, "campaign.json"), "wb") as f:
                f.write(content)
            proc = run_report(d)
            self.assertEqual(proc.returncode, 2, content)
            err = proc.stderr.decode()
            self.assertTrue(err.startswith("campaign_report: " + os.path.join(d, "campaign.json") + ": "), err)
            self.assertEqual(err.count("\n"), 1, err)
            self.assertFalse(os.path.exists(os.path.join(d, "report.html")))

    def test_usage(self):
        proc = subprocess.run([sys.executable, os.path.join(TOOLS, "campaign_report.py")],
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, timeout=SCRIPT_TIMEOUT_S)
        self.assertEqual(proc.returncode, 2)
        self.assertIn("usage", proc.stderr.decode())

    def test_empty_campaign(self):
        d = os.path.join(self.tmp, "empty")
        os.makedirs(d)
        make_campaign(d, {"default": [], "static_platform": []}, planned=4,
                      missing=["default-0000", "default-0001", "static_platform-0000", "static_platform-0001"])
        raw, p, text = self.assertValidPage(d, 0)
        self.assertIn("0 / 4", text)
        self.assertIn("no landed runs", text)
        self.assertIn("no completed runs", text)
        self.assertIn("static_platform-0001", text)
        # and without campaign.csv at all (nothing complete yet)
        os.unlink(os.path.join(d, "campaign.csv"))
        os.unlink(os.path.join(d, "report.html"))
        self.assertValidPage(d, 0)

    def test_all_landed(self):
        d = os.path.join(self.tmp, "ok")
        make_campaign(d, {"default": ["landed"] * 3, "static_platform": ["landed"] * 4})
        raw, p, text = self.assertValidPage(d, 4)
        self.assertIn("no failed runs", text)
        self.assertIn("100.0%", text)

    def test_none_landed(self):
        d = os.path.join(self.tmp, "bad")
        make_campaign(d, {"default": ["timeout", "tipped_over", "crashed"]},
                      worst_ids=["default-0002", "default-0001", "default-0000"])
        raw, p, text = self.assertValidPage(d, 3)  # landing rate + two traces
        self.assertIn("no landed runs", text)
        self.assertEqual([a.get("data-plot") for a in p.imgs()], ["rate", "run:default-0001", "run:default-0000"])

    def test_csv_missing_when_runs_complete(self):
        d = os.path.join(self.tmp, "nocsv")
        make_campaign(d, {"default": ["landed", "timeout"]})
        os.unlink(os.path.join(d, "campaign.csv"))
        proc = run_report(d)
        self.assertEqual(proc.returncode, 2)
        self.assertIn(os.path.join(d, "campaign.csv"), proc.stderr.decode())

    def test_no_deck_section_without_deck_figures(self):
        """summary.json files without the deck figures leave the page exactly as without them."""
        d = os.path.join(self.tmp, "static")
        runs = make_campaign(d, {"default": ["landed", "timeout", "landed"], "static_platform": ["landed"]})
        raw, p, text = self.assertValidPage(d, 5)
        write_summaries(d, runs, ())
        raw2, p2, text2 = self.assertValidPage(d, 5)
        self.assertEqual(raw2, raw)
        self.assertNotIn('id="deck"', raw)
        self.assertNotIn("#deck", raw)
        self.assertFalse(any((a.get("data-plot") or "").startswith("deck") for a in p.imgs()))

    def test_minimal_json(self):
        """Only the name: nulls and missing keys everywhere still give a page."""
        d = os.path.join(self.tmp, "minimal")
        os.makedirs(d)
        with open(os.path.join(d, "campaign.json"), "w") as f:
            json.dump({"name": None, "overall": None, "scenarios": {"a": None}, "sensitivity": [None, 3],
                       "worst_runs": [None, {"id": None}], "missing": "nope"}, f)
        self.assertValidPage(d, 0)


def main():
    global TOOLS, KEEP
    ap = argparse.ArgumentParser(add_help=False)
    ap.add_argument("--lander-tools", default=TOOLS)
    ap.add_argument("--keep", default=None)
    args, rest = ap.parse_known_args()
    TOOLS = os.path.abspath(args.lander_tools)
    KEEP = os.path.abspath(args.keep) if args.keep else None
    if not os.path.isfile(os.path.join(TOOLS, "campaign_report.py")):
        sys.stderr.write("report_test: %s: no campaign_report.py there\n" % TOOLS)
        return 2
    prog = unittest.main(argv=[sys.argv[0]] + rest, exit=False, verbosity=2)
    return 0 if prog.result.wasSuccessful() else 1


if __name__ == "__main__":
    sys.exit(main())
