"""Frames with exact labels for training a detector: lander.dataset.write (see its doc)."""
import json
import os

import numpy as np

from . import Sim, _lander


def _conic_ellipse(C):
    """Centre (px), semi-axes (px) and angle (rad) of the image conic C (3x3, symmetric)."""
    A, B, Cc, D, E, F = C[0, 0], 2 * C[0, 1], C[1, 1], 2 * C[0, 2], 2 * C[1, 2], C[2, 2]
    M = np.array([[A, B / 2], [B / 2, Cc]])
    centre = np.linalg.solve(M, -0.5 * np.array([D, E]))
    F0 = F + 0.5 * (D * centre[0] + E * centre[1])
    w, v = np.linalg.eigh(M)
    axes = np.sqrt(np.abs(-F0 / w))
    angle = float(np.arctan2(v[1, 0], v[0, 0]))
    return centre.tolist(), sorted(axes.tolist(), reverse=True), angle


def labels(K, X_CP, target, width, height):
    """The exact labels of one view: every ring set's projected centre and outer and inner
    ellipses, the code square's cell corners, the platform top's visible fraction."""
    R, t = X_CP[:3, :3], X_CP[:3, 3]
    H = K @ np.column_stack([R[:, 0], R[:, 1], t])  # the top plane z_P = 0 -> pixels
    Hinv = np.linalg.inv(H)

    def project(xy):
        u = H @ np.array([xy[0], xy[1], 1.0])
        return (u[:2] / u[2]).tolist()

    def circle(c, r):
        Q = np.array([[1, 0, -c[0]], [0, 1, -c[1]], [-c[0], -c[1], c[0] ** 2 + c[1] ** 2 - r * r]])
        centre, axes, angle = _conic_ellipse(Hinv.T @ Q @ Hinv)
        return {"centre_px": centre, "axes_px": axes, "angle_rad": angle}

    rings = []
    for s in target["ring_sets"]:
        c = s["centre_m"]
        rings.append({"id": s["id"], "centre_px": project(c), "outer": circle(c, s["outer_radius_m"]),
                      "inner": circle(c, s["inner_radius_m"])})
    code = target["code_pattern"]
    half = code["cells"] * code["cell_m"] / 2
    grid = np.linspace(-half, half, code["cells"] + 1)
    corners = [[project((x, y)) for x in grid] for y in grid[::-1]]  # row 0 = the +y edge
    sx, sy = target["platform_size_m"]
    xs, ys = np.meshgrid(np.linspace(-sx / 2, sx / 2, 21), np.linspace(-sy / 2, sy / 2, 21))
    pts = np.stack([xs.ravel(), ys.ravel(), np.ones(xs.size)])
    u = H @ pts
    in_front = (R @ np.vstack([pts[:2], np.zeros(xs.size)]) + t[:, None])[2] > 0
    uv = u[:2] / u[2]
    inside = in_front & (uv[0] >= -0.5) & (uv[0] <= width - 0.5) & (uv[1] >= -0.5) & (uv[1] <= height - 0.5)
    return {"rings": rings, "code_cell_corners_px": corners, "visible_fraction": float(inside.mean())}


def write(scenario, out, *, every_n_frames=10, seed=None, max_frames=None, overrides=None):
    """Flies the scenario with its flight software and writes every n-th camera frame as
    OUT/frames/frame_NNNNN.png with one JSON line per frame in OUT/manifest.jsonl:

      frame, t_start_s, t_end_s, image (relative path), K (3x3, the plant camera's pinhole),
      X_CP (4x4: the platform in the camera at mid-exposure, truth), rings [{id, centre_px
      (the projected centre), outer / inner {centre_px, axes_px, angle_rad} (the projected
      circles)}], code_cell_corners_px ((cells + 1)^2 grid, row 0 the code square's +y edge),
      visible_fraction (of the platform top inside the image), render (the scenario's render
      and lighting keys).

    The labels are the simulator's truth, exact for the undistorted pinhole (the default
    camera has no distortion); the pixels are the renderer's, with the scenario's blur and
    noise. Returns the number of frames written.
    """
    import yaml
    os.makedirs(os.path.join(out, "frames"), exist_ok=True)
    written = 0
    with Sim(scenario, seed=seed, overrides=overrides) as sim, \
            open(os.path.join(out, "manifest.jsonl"), "w") as manifest:
        sim.reset()
        with open(os.path.join(sim.out_dir, "scenario.resolved.yaml")) as fh:
            resolved = yaml.safe_load(fh)
        cam = resolved["camera"]["intrinsics"]
        K = np.array([[cam["fx_px"], 0, cam["cx_px"]], [0, cam["fy_px"], cam["cy_px"]], [0, 0, 1.0]])
        target = _lander.target_geometry(resolved["world"]["target"])
        while max_frames is None or written < max_frames:
            obs, done, info = sim.step()
            if done:
                break
            f = obs["frame"]
            if f is None or f["index"] % every_n_frames:
                continue
            X_CP = info["truth"]["X_CP_mid_exposure"]
            name = f"frames/frame_{f['index']:05d}.png"
            _lander.write_image(os.path.join(out, name), f["image"])
            rec = {"frame": f["index"], "t_start_s": f["t_start_s"], "t_end_s": f["t_end_s"], "image": name,
                   "K": K.tolist(), "X_CP": X_CP.tolist(), "render": resolved.get("render", {})}
            rec.update(labels(K, X_CP, target, cam["width_px"], cam["height_px"]))
            manifest.write(json.dumps(rec) + "\n")
            written += 1
    return written
