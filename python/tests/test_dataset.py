"""lander.dataset.write: frames with labels that reproject."""
import json

import numpy as np

import lander


def test_labels_reproject(default_yaml, tmp_path):
    n = lander.dataset.write(default_yaml, tmp_path, every_n_frames=15, max_frames=2, overrides={"duration_s": 2})
    assert n == 2
    lines = [json.loads(x) for x in (tmp_path / "manifest.jsonl").read_text().splitlines()]
    assert len(lines) == 2 and (tmp_path / lines[0]["image"]).exists()
    target = lander._lander.target_geometry(None)
    for rec in lines:
        K, X = np.array(rec["K"]), np.array(rec["X_CP"])
        assert len(rec["rings"]) == len(target["ring_sets"]) == 7
        for ring, spec in zip(rec["rings"], target["ring_sets"]):
            # The label against a projection made another way (a 3D point through K [R|t]):
            # the same to floating-point precision, far inside the 0.05 px.
            p = X[:3, :3] @ np.array([*spec["centre_m"], 0.0]) + X[:3, 3]
            uv = (K @ p)[:2] / p[2]
            assert np.abs(np.array(ring["centre_px"]) - uv).max() < 0.05
            assert ring["outer"]["axes_px"][0] >= ring["inner"]["axes_px"][0] > 0
        assert 0.0 <= rec["visible_fraction"] <= 1.0
