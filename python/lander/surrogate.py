"""The detector's behaviour as tables, fitted on rendered frames with truth (issue 55, first part).

A vision surrogate replaces rendering and detection by a draw from a calibrated model of the
detector. This module fits that model's tables from the loop's frames CSVs
(``lander bench loop --frames-csv F``: each camera frame's true platform pose at the exposure's
middle, ``true_*``, and the detection's, ``det_*``) and checks them on held-back frames. The
simulator does not fly the surrogate yet: the tables are what it will draw from.

    python3 -m lander.surrogate fit FRAMES.csv [FRAMES2.csv ...] --out MODEL.json

A view's cell: the platform centre's true depth along the optical axis (``depth_edges_m``),
whether the centre projects inside the image (``in_view``), and the image motion the flight
software predicted over the exposure (``blur_edges_px``). Per cell: the frames, the detection
rate with its 95 % Wilson interval, the persistence of detections from one frame to the next,
and for detections the position error in the camera frame (mean, covariance, its 5/50/95 %
quantiles per axis) and the rotation error's angle quantiles. Errors are correlated in time as
the detector's are: the lag-1 autocorrelation of each position error axis over consecutive
detected frames, pooled.

The held-back check splits each file's frames into alternating blocks (``block_frames``), fits
on the even blocks and compares the odd ones: each cell's held-back detection rate against the
fitted interval, and the fraction of held-back position errors inside the fitted 5-95 % range
(90 % if the tables hold).
"""

from __future__ import annotations

import argparse
import json
import math
import sys

import numpy as np
import pandas as pd

DEPTH_EDGES_M = [0.0, 0.5, 1.0, 2.0, 3.0, 5.0, 8.0, 12.0, 20.0, math.inf]
BLUR_EDGES_PX = [0.0, 3.0, 8.0, math.inf]
# The image's half extents in normalised coordinates (cx / fx, cy / fy of the default camera,
# models/camera_default.yaml): 640 / 640 and 360 / 640.
HALF_EXTENT = (1.0, 0.5625)
# A cell with fewer frames than this reports its counts but no error statistics.
MIN_ERRORS = 5
REQUIRED = ["frame", "detected", "predicted_blur_px",
            "true_x_CP_m", "true_y_CP_m", "true_z_CP_m", "true_qw_CP", "true_qx_CP", "true_qy_CP", "true_qz_CP",
            "det_x_CP_m", "det_y_CP_m", "det_z_CP_m", "det_qw_CP", "det_qx_CP", "det_qy_CP", "det_qz_CP"]


class FitError(ValueError):
    """A frames CSV the fit cannot use: names the file and what is wrong."""


def load_frames(path: str) -> pd.DataFrame:
    """One frames CSV with every column the fit needs; a missing column or a true pose that is
    not finite names the file (and the line)."""
    try:
        d = pd.read_csv(path)
    except (OSError, pd.errors.ParserError, pd.errors.EmptyDataError) as e:
        raise FitError(f"{path}: cannot read: {e}") from e
    missing = [c for c in REQUIRED if c not in d.columns]
    if missing:
        raise FitError(f"{path}: no column {', '.join(missing)} (written by lander bench loop --frames-csv "
                       "since the frames carry their truth)")
    true_cols = [c for c in REQUIRED if c.startswith("true_")]
    bad = ~np.isfinite(d[true_cols].to_numpy(dtype=float)).all(axis=1)
    if bad.any():
        raise FitError(f"{path}:{int(np.argmax(bad)) + 2}: true pose not finite")
    d = d.copy()
    d["source_file"] = path
    return d


def wilson(k: int, n: int, z: float = 1.96) -> tuple[float, float]:
    if n == 0:
        return (0.0, 1.0)
    p = k / n
    c = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    m = (p + z * z / (2 * n)) / (1 + z * z / n)
    return (max(0.0, m - c), min(1.0, m + c))


def _quat_angle_deg(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Angle (deg) of the rotation between unit quaternions a and b (rows w, x, y, z)."""
    dot = np.abs(np.sum(a * b, axis=1)).clip(0.0, 1.0)
    return np.degrees(2.0 * np.arccos(dot))


def features(d: pd.DataFrame) -> pd.DataFrame:
    """Each frame's cell and errors."""
    out = pd.DataFrame(index=d.index)
    z = d["true_z_CP_m"].to_numpy(dtype=float)
    x, y = d["true_x_CP_m"].to_numpy(dtype=float), d["true_y_CP_m"].to_numpy(dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        in_view = (z > 0) & (np.abs(x / z) < HALF_EXTENT[0]) & (np.abs(y / z) < HALF_EXTENT[1])
    out["depth_bin"] = np.digitize(z, DEPTH_EDGES_M[1:-1])
    out["in_view"] = in_view.astype(int)
    out["blur_bin"] = np.digitize(d["predicted_blur_px"].fillna(0.0).to_numpy(dtype=float), BLUR_EDGES_PX[1:-1])
    out["detected"] = d["detected"].astype(int)
    for a in "xyz":
        out[f"e{a}"] = d[f"det_{a}_CP_m"] - d[f"true_{a}_CP_m"]
    qt = d[["true_qw_CP", "true_qx_CP", "true_qy_CP", "true_qz_CP"]].to_numpy(dtype=float)
    qd = d[["det_qw_CP", "det_qx_CP", "det_qy_CP", "det_qz_CP"]].to_numpy(dtype=float)
    out["rot_err_deg"] = _quat_angle_deg(qt, qd)
    out["frame"] = d["frame"].astype(int)
    out["source_file"] = d["source_file"]
    return out


def _persistence(f: pd.DataFrame) -> dict:
    """P(detected | the previous frame detected) and P(detected | it did not), over consecutive
    frames of one file."""
    prev = f.groupby("source_file")["detected"].shift(1)
    consecutive = f.groupby("source_file")["frame"].diff() == 1
    after_hit = f["detected"][(prev == 1) & consecutive]
    after_miss = f["detected"][(prev == 0) & consecutive]
    return {"after_detection": float(after_hit.mean()) if len(after_hit) else None,
            "after_miss": float(after_miss.mean()) if len(after_miss) else None,
            "pairs_after_detection": int(len(after_hit)), "pairs_after_miss": int(len(after_miss))}


def _error_autocorrelation(f: pd.DataFrame) -> dict:
    """Lag-1 autocorrelation of each position error axis over consecutive detected frames."""
    out = {}
    det = f[f["detected"] == 1]
    consecutive = det.groupby("source_file")["frame"].diff() == 1
    for a in "xyz":
        e = det[f"e{a}"]
        prev = det.groupby("source_file")[f"e{a}"].shift(1)
        pair = consecutive & prev.notna() & e.notna()
        out[a] = float(np.corrcoef(e[pair], prev[pair])[0, 1]) if pair.sum() >= MIN_ERRORS else None
    out["pairs"] = int(consecutive.sum())
    return out


def _cell_key(depth_bin: int, in_view: int, blur_bin: int) -> tuple:
    """A cell's bounds: ((depth from, to), in view, (blur from, to)), as a cell dict's _key()."""
    return ((DEPTH_EDGES_M[depth_bin], DEPTH_EDGES_M[depth_bin + 1]), bool(in_view),
            (BLUR_EDGES_PX[blur_bin], BLUR_EDGES_PX[blur_bin + 1]))


def fit_cells(f: pd.DataFrame) -> list[dict]:
    cells = []
    for bins, g in f.groupby(["depth_bin", "in_view", "blur_bin"]):
        depth, in_view, blur = _cell_key(*bins)
        n, k = len(g), int(g["detected"].sum())
        lo, hi = wilson(k, n)
        cell = {"depth_m": list(depth), "in_view": in_view, "blur_px": list(blur), "frames": n, "detections": k,
                "p_detect": k / n, "p_detect_95": [lo, hi], "persistence": _persistence(g)}
        e = g.loc[g["detected"] == 1, ["ex", "ey", "ez"]].dropna()
        if len(e) >= MIN_ERRORS:
            cell["position_error_m"] = {
                "mean": e.mean().tolist(), "cov": np.cov(e.to_numpy().T).tolist(),
                "q05": e.quantile(0.05).tolist(), "q50": e.quantile(0.50).tolist(), "q95": e.quantile(0.95).tolist()}
            r = g.loc[g["detected"] == 1, "rot_err_deg"].dropna()
            cell["rotation_error_deg"] = {"q50": float(r.quantile(0.5)), "q95": float(r.quantile(0.95)),
                                          "max": float(r.max())}
        cells.append(cell)
    return cells


def _key(cell: dict) -> tuple:
    return (tuple(cell["depth_m"]), cell["in_view"], tuple(cell["blur_px"]))


def held_back_check(train: list[dict], test: list[dict]) -> dict:
    """Each held-back cell against the fitted one: its detection rate inside the fitted 95 %
    interval widened by its own sampling spread, and its errors inside the fitted 5-95 %."""
    fitted = {_key(c): c for c in train}
    rows = []
    for c in test:
        t = fitted.get(_key(c))
        if t is None:
            rows.append({"cell": [c["depth_m"], c["in_view"], c["blur_px"]], "frames": c["frames"], "fitted": None})
            continue
        lo, hi = wilson(c["detections"], c["frames"])
        agrees = not (hi < t["p_detect_95"][0] or lo > t["p_detect_95"][1])
        rows.append({"cell": [c["depth_m"], c["in_view"], c["blur_px"]], "frames": c["frames"],
                     "p_detect_fitted": t["p_detect"], "p_detect_held_back": c["p_detect"], "agrees": agrees})
    return {"cells": rows, "cells_agreeing": sum(1 for r in rows if r.get("agrees")),
            "cells_compared": sum(1 for r in rows if "agrees" in r)}


def error_coverage(train_f: pd.DataFrame, test_f: pd.DataFrame, train_cells: list[dict]) -> dict:
    """Fraction of held-back detections whose position error lies in the fitted 5-95 % range of
    its cell, per axis (0.90 expected)."""
    fitted = {_key(c): c for c in train_cells if "position_error_m" in c}
    hits = {a: [0, 0] for a in "xyz"}
    det = test_f[test_f["detected"] == 1]
    for bins, g in det.groupby(["depth_bin", "in_view", "blur_bin"]):
        c = fitted.get(_cell_key(*bins))
        if c is None:
            continue
        for i, a in enumerate("xyz"):
            e = g[f"e{a}"].dropna()
            lo, hi = c["position_error_m"]["q05"][i], c["position_error_m"]["q95"][i]
            hits[a][0] += int(((e >= lo) & (e <= hi)).sum())
            hits[a][1] += int(len(e))
    return {a: (h[0] / h[1] if h[1] else None) for a, h in hits.items()} | {"detections": hits["x"][1]}


def fit(paths: list[str], block_frames: int = 30) -> dict:
    """The model from frames CSVs, with its held-back checks."""
    if not paths:
        raise FitError("no frames CSV given")
    f = features(pd.concat([load_frames(p) for p in paths], ignore_index=True))
    block = (f["frame"] // block_frames) % 2
    train_f, test_f = f[block == 0], f[block == 1]
    train_cells, test_cells = fit_cells(train_f), fit_cells(test_f)
    return {"schema": "lander.vision_surrogate/0",
            "fitted_on": paths, "frames": int(len(f)), "detections": int(f["detected"].sum()),
            "depth_edges_m": DEPTH_EDGES_M[:-1] + ["inf"], "blur_edges_px": BLUR_EDGES_PX[:-1] + ["inf"],
            "cells": _json_safe(fit_cells(f)),
            "persistence": _persistence(f), "error_autocorrelation_lag1": _error_autocorrelation(f),
            "held_back": {"block_frames": block_frames,
                          "detection_rate": _json_safe(held_back_check(train_cells, test_cells)),
                          "position_error_coverage_5_95": error_coverage(train_f, test_f, train_cells)}}


def _json_safe(v):
    if isinstance(v, float) and math.isinf(v):
        return "inf"
    if isinstance(v, dict):
        return {k: _json_safe(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_json_safe(x) for x in v]
    return v


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python3 -m lander.surrogate", description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    f = sub.add_parser("fit", help="fit the tables from frames CSVs")
    f.add_argument("frames_csv", nargs="+")
    f.add_argument("--out", required=True)
    f.add_argument("--block-frames", type=int, default=30)
    a = ap.parse_args(argv)
    try:
        model = fit(a.frames_csv, a.block_frames)
    except FitError as e:
        print(f"lander.surrogate: {e}", file=sys.stderr)
        return 2
    with open(a.out, "w") as out:
        json.dump(model, out, indent=1)
    hb = model["held_back"]
    print(f"{model['frames']} frames, {model['detections']} detections, {len(model['cells'])} cells; held back: "
          f"{hb['detection_rate']['cells_agreeing']} of {hb['detection_rate']['cells_compared']} cells' detection "
          f"rates agree, position errors inside the fitted 5-95 %: "
          + ", ".join(f"{a} {v:.2f}" for a, v in hb["position_error_coverage_5_95"].items()
                      if a in "xyz" and v is not None))
    return 0


if __name__ == "__main__":
    sys.exit(main())
