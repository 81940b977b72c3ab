"""lander.surrogate's fit: tables recovered from frames drawn from a known detector, the
held-back checks passing on them, and frames CSVs it cannot use refused by name."""

import json
import math

import numpy as np
import pandas as pd
import pytest

from lander import surrogate

# Frames drawn per cell: the detection rate's standard error is sqrt(p (1 - p) / n) <= 0.008
# and the error's mean's sigma / sqrt(n * p) <= 0.0004 m.
N_PER_CELL = 4000
# Two cells: near and in view, far and out of view.
CELLS = [
    {"z": 1.5, "x": 0.1, "p": 0.8, "mean": (0.003, 0.0, -0.002), "std": (0.01, 0.02, 0.005)},
    {"z": 9.0, "x": 12.0, "p": 0.1, "mean": (0.0, 0.01, 0.0), "std": (0.03, 0.03, 0.06)},
]
# Sampling tolerances: 4 standard errors (a false failure once in ~16000 checks).
Z_TOL = 4.0


def synthetic_frames(rng: np.random.Generator) -> pd.DataFrame:
    rows = []
    frame = 0
    for c in CELLS:
        for _ in range(N_PER_CELL):
            detected = rng.random() < c["p"]
            e = rng.normal(c["mean"], c["std"]) if detected else np.full(3, np.nan)
            det = (c["x"] + e[0], 0.2 + e[1], c["z"] + e[2]) if detected else (np.nan,) * 3
            rows.append({"frame": frame, "detected": int(detected), "predicted_blur_px": 1.0,
                         "true_x_CP_m": c["x"], "true_y_CP_m": 0.2, "true_z_CP_m": c["z"],
                         "true_qw_CP": 1.0, "true_qx_CP": 0.0, "true_qy_CP": 0.0, "true_qz_CP": 0.0,
                         "det_x_CP_m": det[0], "det_y_CP_m": det[1], "det_z_CP_m": det[2],
                         "det_qw_CP": 1.0 if detected else np.nan, "det_qx_CP": 0.0 if detected else np.nan,
                         "det_qy_CP": 0.0 if detected else np.nan, "det_qz_CP": 0.0 if detected else np.nan})
            frame += 1
    return pd.DataFrame(rows)


@pytest.fixture(scope="module")
def model(tmp_path_factory):
    path = tmp_path_factory.mktemp("sur") / "frames.csv"
    synthetic_frames(np.random.default_rng(55)).to_csv(path, index=False)
    out = path.parent / "model.json"
    assert surrogate.main(["fit", str(path), "--out", str(out)]) == 0
    with open(out) as f:
        return json.load(f)


def cell_of(model, c):
    found = [m for m in model["cells"] if m["depth_m"][0] <= c["z"] < float(m["depth_m"][1])]
    assert len(found) == 1, found
    return found[0]


def test_detection_rates_and_errors_recovered(model):
    assert model["frames"] == N_PER_CELL * len(CELLS)
    for c in CELLS:
        m = cell_of(model, c)
        assert m["in_view"] == (abs(c["x"] / c["z"]) < surrogate.HALF_EXTENT[0])
        assert m["frames"] == N_PER_CELL
        se = math.sqrt(c["p"] * (1 - c["p"]) / N_PER_CELL)
        assert abs(m["p_detect"] - c["p"]) < Z_TOL * se
        lo, hi = m["p_detect_95"]
        assert lo < m["p_detect"] < hi
        pe = m["position_error_m"]
        n_det = m["detections"]
        for i in range(3):
            assert abs(pe["mean"][i] - c["mean"][i]) < Z_TOL * c["std"][i] / math.sqrt(n_det)
            # The sample std's standard error is about std / sqrt(2 n).
            assert abs(math.sqrt(pe["cov"][i][i]) - c["std"][i]) < Z_TOL * c["std"][i] / math.sqrt(2 * n_det)
        assert m["rotation_error_deg"]["max"] == pytest.approx(0.0, abs=1e-6)


def test_independent_draws_show_no_persistence_or_correlation(model):
    # Draws are independent: a detection follows a detection as often as any frame is one
    # (pooled over the cells: between the two rates), and errors are uncorrelated in time.
    p = model["persistence"]
    assert 0.1 < p["after_miss"] < p["after_detection"] < 0.8
    for a in "xyz":
        n = model["error_autocorrelation_lag1"]["pairs"]
        assert abs(model["error_autocorrelation_lag1"][a]) < Z_TOL / math.sqrt(n)


def test_held_back_checks_pass_on_a_stationary_detector(model):
    hb = model["held_back"]
    assert hb["detection_rate"]["cells_compared"] == len(CELLS)
    assert hb["detection_rate"]["cells_agreeing"] == len(CELLS)
    cov = hb["position_error_coverage_5_95"]
    n = cov["detections"]
    assert n > 1000
    for a in "xyz":
        # 90 % expected; the held-back half's binomial spread, and the fitted quantiles' own.
        assert abs(cov[a] - 0.90) < Z_TOL * math.sqrt(0.09 / n) + 0.02


def test_unusable_frames_csv_is_refused_by_name(tmp_path, capsys):
    d = synthetic_frames(np.random.default_rng(1)).head(50)
    no_truth = tmp_path / "no_truth.csv"
    d.drop(columns=["true_z_CP_m"]).to_csv(no_truth, index=False)
    with pytest.raises(surrogate.FitError, match=r"no_truth\.csv: no column true_z_CP_m"):
        surrogate.fit([str(no_truth)])
    nan_truth = tmp_path / "nan_truth.csv"
    d2 = d.copy()
    d2.loc[7, "true_qw_CP"] = np.nan
    d2.to_csv(nan_truth, index=False)
    with pytest.raises(surrogate.FitError, match=r"nan_truth\.csv:9: true pose not finite"):
        surrogate.fit([str(nan_truth)])
    assert surrogate.main(["fit", str(tmp_path / "missing.csv"), "--out", str(tmp_path / "m.json")]) == 2
    assert "missing.csv: cannot read" in capsys.readouterr().err
