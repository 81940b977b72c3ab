#!/usr/bin/env python3
"""Probe the ring-target detector (`lander detect`) with independently rendered camera images.

Usage, from the repository root (see tools/probe/README.md):
  python3 tools/probe/run_probe.py --out out/probe --conditions all --seed 49
  python3 tools/probe/run_probe.py --out out/probe --conditions clean,noise --n 3
  python3 tools/probe/run_probe.py --out out/probe --report-only

Every image is a pure function of (--seed, condition, index): poses are shared between
conditions (image i of every photometric condition has the pose and ground of clean image i),
so each condition is a paired comparison with the clean baseline. Everything is written under
--out: results/<tag>/results.jsonl (+ summary.md, details.md, run.json), images/<tag>/,
cases/ (GROSS / false-positive / imprecise and a sample of missed images, with the truth and
the command that reruns the detector), cache/ (ground textures, target albedo), report.md.
"""
import argparse
import json
import math
import os
import shutil
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
REPO_ROOT = os.path.dirname(os.path.dirname(HERE))     # tools/probe/ -> repository root

try:
    import numpy as np
    from PIL import Image
    from scipy import signal
except ImportError as _e:
    sys.exit(f"run_probe.py: {_e}. Needs numpy, Pillow and scipy "
             "(Debian/Ubuntu: apt-get install python3-numpy python3-pil python3-scipy).")

sys.dont_write_bytecode = True     # no __pycache__ next to the scripts
sys.path.insert(0, HERE)
import probe_render as pr  # noqa: E402


class ProbeError(Exception):
    """A user-facing error: printed as 'run_probe.py: error: ...' with a non-zero exit."""

    def __init__(self, msg, code=2):
        super().__init__(msg)
        self.code = code

CONDITIONS = ["clean", "overexposure", "underexposure", "haze", "colour_gamma", "occlusion",
              "edge_cut", "glare", "rolling_shutter", "defocus", "noise", "jpeg",
              "uneven_light", "worn", "decoys", "negatives",
              # supplementary (added after the first run found two gross poses at 13-15 m):
              # the same poses at 10-15 m, clean / noise / uneven light
              "far_clean", "far_noise", "far_uneven_light"]
N_DEFAULT = {c: 20 for c in CONDITIONS}
N_DEFAULT["negatives"] = 40
for _c in ("far_clean", "far_noise", "far_uneven_light"):
    N_DEFAULT[_c] = 24
GROUNDS = ["asphalt", "grass", "concrete", "gravel"]


# ------------------------------------------------------------------ helpers
def sev(i, n):
    """Severity 0..1 increasing with the image index."""
    return i / max(1, n - 1)


def lerp(a, b, s):
    return a + (b - a) * s


def shared_scene(seed, i, n, rmin=1.5, rmax=15.0):
    """Pose and ground shared by image i of every paired condition (stratified range and
    view angle, randomly permuted so they are independent of the severity ramp)."""
    rng = np.random.default_rng([seed, 1000, n])
    ranges = np.exp(np.linspace(math.log(rmin), math.log(rmax), n))
    views = np.linspace(0.0, 60.0, n)
    pr_ = rng.permutation(n)
    pv_ = rng.permutation(n)
    rng_i = np.random.default_rng([seed, 1001, i])
    r = float(ranges[pr_[i]] * rng_i.uniform(0.97, 1.03))
    r = min(rmax, max(rmin, r))
    view = float(min(60.0, max(0.0, views[pv_[i]] + rng_i.uniform(-1.5, 1.5))))
    azim = rng_i.uniform(0, 2 * math.pi)
    roll = rng_i.uniform(0, 2 * math.pi)
    cpx = (rng_i.uniform(0.15, 0.85) * pr.W, rng_i.uniform(0.15, 0.85) * pr.H)
    R, p = pr.make_pose(r, view, azim, roll, cpx)
    ground = GROUNDS[int(rng_i.integers(len(GROUNDS)))]
    exposure = rng_i.uniform(0.85, 1.0)
    return dict(R=R, p=p, range=r, view=view, azim=azim, roll=roll, centre_px=cpx,
                ground=ground, exposure=exposure)


def ring_centres_in_image(R, p):
    pts = np.array([[c[1], c[2], 0.0] for c in pr.RINGS])
    uv, z = pr.project(R, p, pts)
    inside = (z > 0) & (uv[:, 0] >= 0) & (uv[:, 0] <= pr.W - 1) & (uv[:, 1] >= 0) & \
        (uv[:, 1] <= pr.H - 1)
    return inside


def ring_sets_fully_in_image(R, p):
    """Per ring set: all 32 points of its outer circle inside the image."""
    res = []
    for (_i, cx, cy, Ro, _r) in pr.RINGS:
        a = np.linspace(0, 2 * math.pi, 32, endpoint=False)
        pts = np.stack([cx + Ro * np.cos(a), cy + Ro * np.sin(a), np.zeros_like(a)], 1)
        uv, z = pr.project(R, p, pts)
        res.append(bool(np.all((z > 0) & (uv[:, 0] >= -0.5) & (uv[:, 0] <= pr.W - 0.5) &
                               (uv[:, 1] >= -0.5) & (uv[:, 1] <= pr.H - 0.5))))
    return res


def add_noise(dn, rng, sigma):
    return dn + rng.normal(0.0, sigma, dn.shape).astype(np.float32)


def disc_kernel(radius, ss=8):
    n = int(math.ceil(radius)) + 1
    g = (np.arange(-n * ss, (n + 1) * ss) + 0.5) / ss - 0.5 / ss
    # supersampled disc, then binned to pixels
    xx, yy = np.meshgrid(g, g)
    m = (xx * xx + yy * yy <= radius * radius).astype(np.float64)
    sz = 2 * n + 1
    m = m[: sz * ss, : sz * ss].reshape(sz, ss, sz, ss).mean(axis=(1, 3))
    return m / m.sum()


def bar_coverage(mask_ring_idx, uu, vv, bars):
    """Fraction of ring pixels covered by the union of bars (pixel-centre test)."""
    cov = np.zeros(uu.shape, bool)
    for (px, py, ang, w) in bars:
        d = (uu - px) * (-math.sin(ang)) + (vv - py) * math.cos(ang)
        cov |= np.abs(d) <= w / 2
    return cov.mean() if cov.size else 0.0


def _rodrigues(w):
    th = float(np.linalg.norm(w))
    if th < 1e-12:
        return np.eye(3)
    return pr._axis_angle(w / th, th)


def rs_equivalent_pose(R, p, ax, ay, vref):
    """Pose that best explains (least-squares reprojection of 24 points on each ring circle)
    where the rolling-shutter image shows the ring circles: an ideal projection (U, V) appears
    at (u, v) with u + ax (v - vref) / H = U and v + ay (v - vref) / H = V. Returns R, p, rms."""
    pts = []
    for (_i, cx, cy, Ro, ri) in pr.RINGS:
        a = np.linspace(0, 2 * math.pi, 24, endpoint=False)
        for rr in (Ro, ri):
            pts.append(np.stack([cx + rr * np.cos(a), cy + rr * np.sin(a), np.zeros_like(a)], 1))
    X = np.concatenate(pts)
    uv, z = pr.project(R, p, X)
    ok = (z > 0) & (uv[:, 0] > 0) & (uv[:, 0] < pr.W - 1) & (uv[:, 1] > 0) & (uv[:, 1] < pr.H - 1)
    X, uv = X[ok], uv[ok]
    v = (uv[:, 1] + ay * vref / pr.H) / (1 + ay / pr.H)
    u = uv[:, 0] - ax * (v - vref) / pr.H
    tgt = np.stack([u, v], 1)

    def resid(par):
        Rr = _rodrigues(par[:3]) @ R
        q, _ = pr.project(Rr, par[3:], X)
        return (q - tgt).ravel()

    par = np.concatenate([np.zeros(3), p])
    lam = 1e-3
    r0 = resid(par)
    for _it in range(100):
        J = np.empty((r0.size, 6))
        for k in range(6):
            dp = np.zeros(6); h = 1e-6 if k < 3 else 1e-6 * max(1.0, abs(par[k]))
            dp[k] = h
            J[:, k] = (resid(par + dp) - r0) / h
        A = J.T @ J; g = J.T @ r0
        step = -np.linalg.solve(A + lam * np.diag(np.diag(A) + 1e-12), g)
        r1 = resid(par + step)
        if r1 @ r1 < r0 @ r0:
            par, r0, lam = par + step, r1, lam * 0.3
            if np.linalg.norm(step) < 1e-10:
                break
        else:
            lam *= 10
    Rr = _rodrigues(par[:3]) @ R
    return Rr, par[3:], float(np.sqrt(np.mean(r0 ** 2)))


# ------------------------------------------------------------------ scene builders
def decal_ground(size=8.0, n=4096):
    return pr.Decal((0.0, 0.0), size, n, -pr.THICK)


def place_in_view(rng, R, p, r_out, dmin, dmax, tries=300, avoid=()):
    """A point on the ground at distance dmin..dmax from the platform centre, clear of the
    platform square (by r_out + 5 cm) and of earlier shapes, projecting inside the image."""
    for _ in range(tries):
        d = rng.uniform(dmin, dmax)
        a = rng.uniform(0, 2 * math.pi)
        x, y = d * math.cos(a), d * math.sin(a)
        if max(abs(x), abs(y)) - r_out < pr.PLATFORM / 2 + 0.05:
            continue
        if any(math.hypot(x - ax, y - ay) < r_out + ar + 0.05 for (ax, ay, ar) in avoid):
            continue
        uv, z = pr.project(R, p, np.array([[x, y, -pr.THICK]]))
        if z[0] > 0 and 20 <= uv[0, 0] <= pr.W - 20 and 20 <= uv[0, 1] <= pr.H - 20:
            return x, y
    return None


def add_decoy_shape(dec, rng, x, y, kind, r_out, albedo):
    """kind: annulus | disc | concentric | ringset_copy. Returns description."""
    if kind == "disc":
        dec.annulus(x, y, r_out, 0.0, albedo)
        return dict(kind=kind, x=x, y=y, R=r_out)
    if kind == "annulus":
        ratio = rng.uniform(0.15, 0.85)
        dec.annulus(x, y, r_out, ratio * r_out, albedo)
        return dict(kind=kind, x=x, y=y, R=r_out, r=ratio * r_out)
    if kind == "concentric":
        k = int(rng.integers(3, 6))
        radii = np.sort(rng.uniform(0.15, 1.0, 2 * k))[::-1] * r_out
        for j in range(k):
            dec.annulus(x, y, radii[2 * j], radii[2 * j + 1], albedo)
        return dict(kind=kind, x=x, y=y, radii=[float(v) for v in radii])
    if kind == "ringset_copy":
        rs = pr.RINGS[int(rng.integers(1, 7))]
        dec.annulus(x, y, rs[3], rs[4], albedo)
        return dict(kind=kind, x=x, y=y, R=rs[3], r=rs[4], copy_of=rs[0])
    raise ValueError(kind)


def worn_dirt(rng, coverage):
    """Dirt layer over the platform: grey blotches + scratches, alpha>0.5 area ~ coverage."""
    dec = pr.Decal((0.0, 0.0), pr.PLATFORM, 2048, 0.0)
    target_blot = coverage * 0.8
    n_blot = 0
    while (dec.alpha > 0.5).mean() < target_blot and n_blot < 2000:
        x, y = rng.uniform(-0.9, 0.9, 2)
        rad = rng.uniform(0.02, 0.09)
        alb = rng.uniform(0.3, 0.6)
        a = rng.uniform(0.7, 1.0)
        # irregular blotch: a few overlapping discs
        for _ in range(int(rng.integers(2, 5))):
            ox, oy = rng.normal(0, rad * 0.6, 2)
            rr = rad * rng.uniform(0.4, 1.0)
            g = dec._grid(x + ox - rr, x + ox + rr, y + oy - rr, y + oy + rr)
            if g is None:
                continue
            sl, xs, ys = g
            d = np.hypot(xs - x - ox, ys - y - oy)
            cov = (np.clip((rr - d) / dec.res + 0.5, 0, 1) * a).astype(np.float32)
            dec._paint(sl, cov, alb)
        n_blot += 1
    n_scr = 0
    while (dec.alpha > 0.5).mean() < coverage and n_scr < 500:
        x0, y0 = rng.uniform(-0.9, 0.9, 2)
        ang = rng.uniform(0, math.pi)
        ln = rng.uniform(0.1, 0.6)
        w = rng.uniform(0.0015, 0.004)
        x1, y1 = x0 + ln * math.cos(ang), y0 + ln * math.sin(ang)
        g = dec._grid(min(x0, x1) - w, max(x0, x1) + w, min(y0, y1) - w, max(y0, y1) + w)
        n_scr += 1
        if g is None:
            continue
        sl, xs, ys = g
        vx, vy = x1 - x0, y1 - y0
        t = np.clip(((xs - x0) * vx + (ys - y0) * vy) / (vx * vx + vy * vy), 0, 1)
        d = np.hypot(xs - x0 - t * vx, ys - y0 - t * vy)
        cov = np.clip((w / 2 - d) / dec.res + 0.5, 0, 1).astype(np.float32)
        dec._paint(sl, cov, rng.uniform(0.4, 0.7))
    return dec, dict(blotches=n_blot, scratches=n_scr,
                     coverage=float((dec.alpha > 0.5).mean()))


def sample_cut_pose(rng, i, n, seed):
    """Condition 7: centre ring centre in view, 1-3 outer ring-set centres outside."""
    want = 1 + (i % 3)
    for _ in range(5000):
        r = math.exp(rng.uniform(math.log(1.5), math.log(15.0)))
        view = rng.uniform(0, 60)
        azim = rng.uniform(0, 2 * math.pi)
        roll = rng.uniform(0, 2 * math.pi)
        # centre near an edge
        side = rng.integers(4)
        m = rng.uniform(0.02, 0.25)
        u = rng.uniform(0.05, 0.95) * pr.W
        v = rng.uniform(0.05, 0.95) * pr.H
        if side == 0:
            u = m * pr.W
        elif side == 1:
            u = (1 - m) * pr.W
        elif side == 2:
            v = m * pr.H
        else:
            v = (1 - m) * pr.H
        R, p = pr.make_pose(r, view, azim, roll, (u, v))
        inside = ring_centres_in_image(R, p)
        if inside[0] and (6 - inside[1:].sum()) == want:
            return R, p, dict(range=r, view=view, azim=azim, roll=roll, centre_px=(u, v),
                              sets_out=want)
    raise RuntimeError("no cut pose")


# ------------------------------------------------------------------ one image
class Shot:
    """One image while it is made: its pose, parameters, render options and the effects still
    to apply. Every step draws from `rng` in the order make_image calls them, so an image stays
    a pure function of (seed, condition, index)."""

    def __init__(self, cond, i, n, seed):
        self.rng = np.random.default_rng([seed, CONDITIONS.index(cond), i])
        self.i, self.n, self.seed = i, n, seed
        self.s = sev(i, n)
        self.far = cond.startswith("far_")
        if self.far:
            sc = shared_scene(seed + 900, i, n, rmin=10.0, rmax=15.0)
            cond = cond[4:]          # same image effects as the base condition
        elif cond == "negatives":
            sc = shared_scene(seed + 500, i, n)
        elif cond == "edge_cut":
            sc = shared_scene(seed, i % 20, 20)
        else:
            sc = shared_scene(seed, i, n)
        self.cond = cond
        self.R, self.p = sc["R"], sc["p"]
        self.params = dict(range_m=sc["range"], view_deg=sc["view"], ground=sc["ground"],
                           exposure=sc["exposure"], centre_px=list(sc["centre_px"]))
        self.rkw = dict(ground=sc["ground"])
        self.exposure = sc["exposure"]
        self.ext = "png"
        self.target_present = True
        self.post = []   # DN-domain operations


def scene_edge_cut(sh):
    """Condition 7: a pose with the centre ring near an image edge."""
    sh.R, sh.p, info = sample_cut_pose(sh.rng, sh.i, sh.n, sh.seed)
    sh.params.update(range_m=info["range"], view_deg=info["view"],
                     centre_px=list(info["centre_px"]), sets_out=info["sets_out"])


def negative_square_shapes(sh, dec, sub):
    """Negatives on a white square: discs or ring-set copies in a grid, a line or at random."""
    rng, i = sh.rng, sh.i
    shapes = []
    dec.square(0.0, 0.0, pr.PLATFORM / 2, pr.ALB_WHITE, angle=0.0)
    layout = ["grid", "line", "random"][int(rng.integers(3))] if sub == "square_discs" \
        else ["grid", "line", "random"][(i // 5) % 3]
    sh.params["layout"] = layout
    if layout == "grid":
        pts = [(x, y) for x in (-0.55, 0.0, 0.55) for y in (-0.55, 0.0, 0.55)]
    elif layout == "line":
        pts = [(x, y) for x in (-0.66, -0.22, 0.22, 0.66) for y in (-0.45, 0.45)]
    else:
        pts = []
        while len(pts) < 7:
            x, y = rng.uniform(-0.65, 0.65, 2)
            if all(math.hypot(x - a, y - b) > 0.45 for a, b in pts):
                pts.append((x, y))
    pts = pts[:7] if sub == "square_ringsets" else pts
    for k, (x, y) in enumerate(pts):
        if sub == "square_discs":
            dec.annulus(x, y, rng.uniform(0.1, 0.22), 0.0, pr.ALB_BLACK)
            shapes.append(dict(kind="disc", x=x, y=y))
        else:
            rs = pr.RINGS[k % 7]
            rr = 0.2 if rs[0] == 0 else rs[3]
            ri = rs[4] * (0.2 / rs[3]) if rs[0] == 0 else rs[4]
            dec.annulus(x, y, rr, ri, pr.ALB_BLACK)
            shapes.append(dict(kind="ringset_ratio_copy", x=x, y=y, R=rr, r=ri,
                               copy_of=rs[0]))
    return shapes


def scene_negatives(sh):
    """No platform: the ground alone, or ring-like shapes that are not the target."""
    rng, i = sh.rng, sh.i
    sh.target_present = False
    sub = ["ground_only", "scattered_rings", "concentric", "square_discs",
           "square_ringsets"][i % 5]
    sh.params["subclass"] = sub
    sh.rkw["platform"] = False
    dec = decal_ground()
    shapes = []
    if sub == "scattered_rings":
        for _ in range(int(rng.integers(4, 11))):
            d = rng.uniform(0, 3.0); a = rng.uniform(0, 2 * math.pi)
            kind = ["annulus", "disc", "ringset_copy"][int(rng.integers(3))]
            shapes.append(add_decoy_shape(dec, rng, d * math.cos(a), d * math.sin(a), kind,
                                          rng.uniform(0.08, 0.4), rng.uniform(0.02, 0.08)))
    elif sub == "concentric":
        for k in range(int(rng.integers(1, 3))):
            x, y = (0.0, 0.0) if k == 0 else tuple(rng.uniform(-2.5, 2.5, 2))
            shapes.append(add_decoy_shape(dec, rng, x, y, "concentric",
                                          rng.uniform(0.3, 0.8), rng.uniform(0.02, 0.06)))
    elif sub in ("square_discs", "square_ringsets"):
        shapes = negative_square_shapes(sh, dec, sub)
    sh.params["shapes"] = shapes
    sh.rkw["decals"] = [dec]


def scene_decoys(sh):
    """Ring-like shapes on the ground around the platform, more with severity."""
    rng = sh.rng
    dec = decal_ground()
    nshape = int(round(lerp(2, 8, sh.s)))
    shapes, avoid = [], []
    for _ in range(nshape):
        kind = ["annulus", "disc", "concentric", "ringset_copy"][int(rng.integers(4))]
        r_out = rng.uniform(0.1, 0.45) if kind != "ringset_copy" else 0.2
        xy = place_in_view(rng, sh.R, sh.p, r_out, 1.0, 3.0, avoid=avoid)
        if xy is None:
            continue
        avoid.append((xy[0], xy[1], r_out))
        shapes.append(add_decoy_shape(dec, rng, xy[0], xy[1], kind, r_out,
                                      rng.uniform(0.02, 0.08)))
    sh.params["shapes"] = shapes
    sh.params["n_decoys_in_view"] = len(shapes)
    sh.rkw["decals"] = [dec]


def scene_worn(sh):
    """Dirt, blotches and scratches on the target."""
    cov = lerp(0.05, 0.15, sh.s)
    dirt, info = worn_dirt(sh.rng, cov)
    sh.rkw["dirt"] = dirt
    sh.params["worn"] = info


def scene_rolling_shutter(sh):
    """Row-dependent image shifts, with the rigid pose that explains them best."""
    rng, R, p, s = sh.rng, sh.R, sh.p, sh.s
    params = sh.params
    amp = lerp(10, 40, s) * (1 if rng.uniform() < 0.5 else -1)
    mode = ["horizontal", "vertical", "both"][sh.i % 3]
    uv, _ = pr.project(R, p, np.zeros((1, 3)))
    vref = float(uv[0, 1])
    rows = np.arange(pr.H, dtype=np.float64)
    xs = amp * (rows - vref) / pr.H if mode in ("horizontal", "both") else None
    amp2 = lerp(10, 40, s) * (1 if rng.uniform() < 0.5 else -1)
    ys = amp2 * (rows - vref) / pr.H if mode in ("vertical", "both") else None
    sh.rkw["xshift"], sh.rkw["yshift"] = xs, ys
    params.update(rs_mode=mode, rs_x_px_over_frame=amp if xs is not None else 0.0,
                  rs_y_px_over_frame=amp2 if ys is not None else 0.0, rs_ref_row=vref)
    Re, pe, rms = rs_equivalent_pose(R, p, params["rs_x_px_over_frame"],
                                     params["rs_y_px_over_frame"], vref)
    params.update(rs_equiv_R_CP=Re.tolist(), rs_equiv_p_CP_m=pe.tolist(),
                  rs_equiv_fit_rms_px=rms,
                  rs_equiv_vs_truth_pos_pct=float(100 * np.linalg.norm(pe - p) / np.linalg.norm(p)),
                  rs_equiv_vs_truth_rot_deg=rot_err_deg(R, Re))


SCENE_STEPS = dict(edge_cut=scene_edge_cut, negatives=scene_negatives, decoys=scene_decoys,
                   worn=scene_worn, rolling_shutter=scene_rolling_shutter)


def add_glare(sh, L):
    """A saturating glare blob on the target, sized so that the wanted fraction of it clips."""
    rng, R, p = sh.rng, sh.R, sh.p
    x, y, valid, onp, ring = pr.pixel_geometry(R, p)
    frac = lerp(0.2, 0.4, sh.s)
    vv, uu = np.nonzero(onp)
    k = int(rng.integers(len(uu)))
    bu, bv = uu[k], vv[k]
    dist = np.hypot(uu - bu, vv - bv)
    yy, xx = np.mgrid[0:pr.H, 0:pr.W]
    d = np.hypot(xx - bu, yy - bv)

    def glare_blob(Rb):
        soft = max(2.0, Rb / 8)
        return (2.0 / (1 + np.exp(np.clip((d - Rb) / soft, -50, 50))) +
                0.08 * np.exp(-(d / (2.5 * Rb)) ** 2)).astype(np.float32)

    # bisection on the blob radius so that the saturated part of the target's image
    # (all channels >= full scale before noise) is the wanted fraction
    lo, hi = 1.0, float(dist.max()) * 1.2
    for _it in range(16):
        Rb = 0.5 * (lo + hi)
        satf = ((((L + glare_blob(Rb)[..., None]) * sh.exposure).min(axis=2) >= 1.0) & onp).sum() \
            / max(1, onp.sum())
        if satf < frac:
            lo = Rb
        else:
            hi = Rb
    blob = glare_blob(Rb)
    L = L + blob[..., None].astype(np.float32)
    sh.params.update(glare_centre_px=[int(bu), int(bv)], glare_radius_px=Rb,
                     glare_target_frac=frac)
    sh.post.append(("glare_measure", onp))
    return L


def optical_effects(sh, L):
    """Linear-domain (optical) effects on the rendered radiance L."""
    cond, rng, s = sh.cond, sh.rng, sh.s
    if cond == "glare":
        L = add_glare(sh, L)
    if cond == "defocus":
        rad = lerp(2, 5, s)
        ker = disc_kernel(rad).astype(np.float32)
        L = np.stack([signal.fftconvolve(L[..., c], ker, mode="same") for c in range(3)], -1)
        sh.params["defocus_radius_px"] = rad
    if cond == "uneven_light":
        m = lerp(0.40, 0.25, s)
        ang = rng.uniform(0, 2 * math.pi)
        x, y, valid, onp, ring = pr.pixel_geometry(sh.R, sh.p)
        sd = x * math.cos(ang) + y * math.sin(ang)
        e = 0.86
        fac = 1 - (1 - m) * np.clip((sd + e) / (2 * e), 0, 1)
        fac = np.where(valid, fac, 1.0) ** 2.2          # brightness (DN) ratio m
        L = L * fac[..., None].astype(np.float32)
        sh.params.update(ramp_min_brightness=m, ramp_dir_deg=math.degrees(ang))
    if cond == "colour_gamma":
        k = lerp(1.1, 1.3, s)
        warm = (sh.i % 2 == 0)
        g = np.array([k, 1.0, 2 - k] if warm else [2 - k, 1.0, k], np.float32)
        L = L * g
        perm = np.random.default_rng([sh.seed, 77]).permutation(sh.n)
        gam = float(np.exp(np.linspace(math.log(0.5), math.log(2.2), sh.n))[perm[sh.i]])
        sh.post.append(("gamma", gam))
        sh.params.update(wb_gains_rgb=g.tolist(), gamma=gam)
    return L


def add_occlusion(sh, dn):
    """One or two bars across the rings, covering 5-25 % of them."""
    rng, s = sh.rng, sh.s
    x, y, valid, onp, ring = pr.pixel_geometry(sh.R, sh.p)
    vv, uu = np.nonzero(ring)
    uc, _ = pr.project(sh.R, sh.p, np.zeros((1, 3)))
    nb = 1 if sh.i % 2 == 0 else 2
    want = lerp(0.05, 0.25, s)
    best = None
    for _t in range(1500):
        bars = []
        for _b in range(nb):
            w = rng.uniform(0.03, 0.10) * pr.W
            ang = rng.uniform(0, math.pi)
            k = int(rng.integers(len(uu)))
            off = rng.uniform(-w / 2 - 10, w / 2 + 10)   # may clip the target's side
            bars.append((float(uu[k] - off * math.sin(ang)), float(vv[k] + off * math.cos(ang)),
                         ang, w))
        c = bar_coverage(ring, uu.astype(float), vv.astype(float), bars)
        if 0.05 <= c <= 0.25 and (best is None or abs(c - want) < abs(best[1] - want)):
            best = (bars, c)
            if abs(c - want) < 0.01:
                break
    if best is None:
        raise RuntimeError("occlusion: no bar placement covering 5-25 % of the rings")
    bars, c = best
    yy, xx = np.mgrid[0:pr.H, 0:pr.W].astype(np.float32)
    cols = [(25, 25, 28), (200, 60, 30), (230, 200, 40), (60, 60, 70), (15, 15, 15)]
    descr = []
    for (px, py, ang, w) in bars:
        col = np.array(cols[int(rng.integers(len(cols)))], np.float32)
        d = (xx - px) * (-math.sin(ang)) + (yy - py) * math.cos(ang)
        soft = rng.uniform(0.7, 2.5)
        a = np.clip((w / 2 - np.abs(d)) / soft + 0.5, 0, 1)[..., None]
        shade = 1.0 + 0.15 * np.clip(d / (w / 2), -1, 1)[..., None]   # rounded look
        dn = dn * (1 - a) + a * col * shade
        descr.append(dict(point_px=[px, py], angle_deg=math.degrees(ang), width_px=w,
                          colour=col.tolist()))
    sh.params.update(bars=descr, ring_coverage=c)
    return dn


def dn_effects(sh, dn):
    """DN-domain effects (gain, haze, gamma, occluding bars). Returns (dn, read noise sigma)."""
    cond, rng, s, params = sh.cond, sh.rng, sh.s, sh.params
    noise_sigma = 1.0
    if cond == "overexposure":
        gain = lerp(1.5, 3.0, s)
        dn = np.clip(dn * gain, 0, 255)
        params["gain"] = gain
    if cond == "underexposure":
        gain = lerp(0.3, 0.1, s)
        dn = dn * gain
        noise_sigma = lerp(2, 6, s)
        params.update(gain=gain, noise_sigma_dn=noise_sigma)
    if cond == "haze":
        a = lerp(0.40, 0.25, s)
        h = rng.uniform(120, 230)
        dn = a * dn + (1 - a) * h
        params.update(contrast=a, haze_dn=h)
    for op in sh.post:
        if op[0] == "gamma":
            dn = 255.0 * np.clip(dn / 255.0, 0, 1) ** op[1]
    if cond == "occlusion":
        dn = add_occlusion(sh, dn)
    return dn, noise_sigma


def sensor_output(sh, dn, noise_sigma):
    """The 8-bit image: glare's clipped share measured, read noise (and salt and pepper for
    the noise condition), quantisation; the JPEG quality of the jpeg condition."""
    rng, params = sh.rng, sh.params
    for op in sh.post:
        if op[0] == "glare_measure":   # saturated (all channels at full scale, before noise)
            onp = op[1]
            sat = (dn.min(axis=2) >= 254.5) & onp
            params["glare_saturated_frac_of_target"] = float(sat.sum() / max(1, onp.sum()))
    dn = add_noise(dn, rng, noise_sigma)
    if sh.cond == "noise":
        sg = lerp(8, 20, sh.s)
        dn = add_noise(dn, rng, sg)
        img = pr.quantise(dn)
        m = rng.uniform(size=img.shape[:2])
        img[m < 0.0025] = 0
        img[(m >= 0.0025) & (m < 0.005)] = 255
        params.update(noise_sigma_dn=sg, salt_pepper=0.005)
    else:
        img = pr.quantise(dn)
    if sh.cond == "jpeg":
        params["jpeg_quality"] = int(round(lerp(50, 20, sh.s)))
        sh.ext = "jpg"
    return img


def image_truth(sh):
    """The truth record of the image: pose, what of the target is in view, the parameters."""
    R, p = sh.R, sh.p
    inside = ring_centres_in_image(R, p)
    full = ring_sets_fully_in_image(R, p)
    return dict(condition=("far_" + sh.cond) if sh.far else sh.cond, index=sh.i, seed=sh.seed,
                target_present=sh.target_present,
                R_CP=R.tolist(), p_CP_m=p.tolist(), q_CP_wxyz=pr.rot_to_quat(R).tolist(),
                range_m=float(np.linalg.norm(p)),
                ring_centres_in_image=int(inside.sum()), ring_sets_fully_in_image=int(sum(full)),
                params=sh.params)


def make_image(cond, i, n, seed):
    """Returns (uint8 HxWx3 image, file extension, truth dict)."""
    # The shared pose and ground, then the condition's own scene (pose, decals, dirt, shifts).
    sh = Shot(cond, i, n, seed)
    if sh.cond in SCENE_STEPS:
        SCENE_STEPS[sh.cond](sh)
    L = pr.render(sh.R, sh.p, **sh.rkw)
    # Optics on the radiance, the camera response, then effects on the digital numbers.
    L = optical_effects(sh, L)
    dn = pr.response(L, sh.exposure)
    dn, noise_sigma = dn_effects(sh, dn)
    img = sensor_output(sh, dn, noise_sigma)
    return img, sh.ext, image_truth(sh)


def save_image(img, path, ext, truth):
    if ext == "jpg":
        Image.fromarray(img).save(path, quality=truth["params"]["jpeg_quality"])
    else:
        Image.fromarray(img).save(path, compress_level=3)


# ------------------------------------------------------------------ detection / evaluation
def detector_cmd(cfg, path):
    """The detector command line (an argument list; never run through a shell)."""
    return [cfg["lander"], "detect", path, "--camera", cfg["camera"], "--target", cfg["target"],
            "--json"]


def detect(cfg, path):
    """Runs the detector on one image. Returns (parsed JSON dict, seconds). A timeout counts as
    not detected (status 'timeout'); output without a JSON object raises ProbeError."""
    cmd = detector_cmd(cfg, path)
    t = time.time()
    try:
        r = subprocess.run(cmd, capture_output=True, text=True, timeout=60)
    except subprocess.TimeoutExpired:
        return dict(detected=False, status="timeout", reason="timeout 60 s"), 60.0
    except OSError as e:
        raise ProbeError(f"cannot run the detector {cfg['lander']}: {e}", 3)
    dt = time.time() - t
    d = None
    for ln in reversed(r.stdout.splitlines()):
        if ln.strip().startswith("{"):
            try:
                d = json.loads(ln)
            except ValueError:
                d = None
            break
    if not isinstance(d, dict) or "detected" not in d or \
            (d.get("detected") and not ("p_CP_m" in d and "q_CP_wxyz" in d)):
        def tail(txt):
            txt = txt.strip()
            return (txt[-400:] if txt else "(empty)").replace("\n", "\n    ")
        raise ProbeError(
            "the detector's output is not the expected JSON (a line with 'detected', and "
            "'p_CP_m' / 'q_CP_wxyz' when detected).\n"
            f"  command: {' '.join(cmd)}\n  exit code: {r.returncode}\n"
            f"  stdout: {tail(r.stdout)}\n  stderr: {tail(r.stderr)}", 3)
    return d, dt


def rot_err_deg(R1, R2):
    c = (np.trace(np.asarray(R1).T @ np.asarray(R2)) - 1) / 2
    return math.degrees(math.acos(max(-1.0, min(1.0, c))))


def evaluate(truth, d):
    out = dict(detected=bool(d.get("detected", False)), status=d.get("status"),
               reason=d.get("reason"), source=d.get("source"),
               reproj_err_px=d.get("reproj_err_px"))
    if out["detected"]:
        pd = np.array(d["p_CP_m"]); qd = d["q_CP_wxyz"]
        out["p_det"] = pd.tolist(); out["q_det"] = list(qd)
    if not truth["target_present"]:
        out["cls"] = "FALSE_POSITIVE" if out["detected"] else "rejected"
        return out
    if not out["detected"]:
        out["cls"] = "missed"
        return out
    pt = np.array(truth["p_CP_m"])
    pe = float(np.linalg.norm(pd - pt))
    pct = 100 * pe / float(np.linalg.norm(pt))
    re = rot_err_deg(np.array(truth["R_CP"]), pr.quat_to_rot(qd))
    out.update(pos_err_m=pe, pos_err_pct=pct, rot_err_deg=re)
    if "rs_equiv_R_CP" in truth["params"]:
        pq = np.array(truth["params"]["rs_equiv_p_CP_m"])
        out["rs_equiv_pos_err_pct"] = float(100 * np.linalg.norm(pd - pq) / np.linalg.norm(pq))
        out["rs_equiv_rot_err_deg"] = rot_err_deg(np.array(truth["params"]["rs_equiv_R_CP"]),
                                                  pr.quat_to_rot(qd))
    if pct < 2 and re < 3:
        out["cls"] = "correct"
    elif pct < 5 and re < 10:
        out["cls"] = "imprecise"
    else:
        out["cls"] = "GROSS"
    return out


# ------------------------------------------------------------------ report
def summarise(rows, title):
    lines = [f"### {title}", "",
             "| condition | n | correct | imprecise | GROSS | missed | median pos err % | max pos err % | median rot err deg | max rot err deg | not correct although the clean twin is |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    by = {}
    for r in rows:
        by.setdefault(r["condition"], []).append(r)
    clean_ok = {r["index"] for r in by.get("clean", []) if r["cls"] == "correct"}
    clean_ok_far = {r["index"] for r in by.get("far_clean", []) if r["cls"] == "correct"}
    for c in CONDITIONS:
        if c not in by:
            continue
        rs = by[c]
        if c == "negatives":
            fp = sum(r["cls"] == "FALSE_POSITIVE" for r in rs)
            lines.append(f"| negatives (target-free) | {len(rs)} | {len(rs) - fp} rejected | - | "
                         f"{fp} false positives | - | - | - | - | - | - |")
            continue
        cnt = {k: sum(r["cls"] == k for r in rs) for k in ("correct", "imprecise", "GROSS", "missed")}
        pe = [r["pos_err_pct"] for r in rs if r.get("pos_err_pct") is not None]
        re = [r["rot_err_deg"] for r in rs if r.get("rot_err_deg") is not None]
        f = (lambda v: f"{v:.2f}")
        twin_ok = clean_ok_far if c.startswith("far_") else clean_ok
        paired = "-" if c in ("clean", "edge_cut", "far_clean") else \
            str(sum(r["cls"] != "correct" and r["index"] in twin_ok for r in rs))
        lines.append(f"| {c} | {len(rs)} | {cnt['correct']} | {cnt['imprecise']} | {cnt['GROSS']} | "
                     f"{cnt['missed']} | {f(np.median(pe)) if pe else '-'} | {f(max(pe)) if pe else '-'} | "
                     f"{f(np.median(re)) if re else '-'} | {f(max(re)) if re else '-'} | {paired} |")
        if any("rs_equiv_rot_err_deg" in r for r in rs):
            def cls2(r):
                if r["cls"] == "missed":
                    return "missed"
                a, b = r["rs_equiv_pos_err_pct"], r["rs_equiv_rot_err_deg"]
                return "correct" if (a < 2 and b < 3) else ("imprecise" if (a < 5 and b < 10) else "GROSS")
            c2 = [cls2(r) for r in rs]
            pe2 = [r["rs_equiv_pos_err_pct"] for r in rs if "rs_equiv_pos_err_pct" in r]
            re2 = [r["rs_equiv_rot_err_deg"] for r in rs if "rs_equiv_rot_err_deg" in r]
            lines.append(f"| {c} (vs RS-equivalent pose) | {len(rs)} | {c2.count('correct')} | "
                         f"{c2.count('imprecise')} | {c2.count('GROSS')} | {c2.count('missed')} | "
                         f"{f(np.median(pe2)) if pe2 else '-'} | {f(max(pe2)) if pe2 else '-'} | "
                         f"{f(np.median(re2)) if re2 else '-'} | {f(max(re2)) if re2 else '-'} | - |")
    return "\n".join(lines) + "\n"


SEV_KEYS = {"overexposure": ["gain"], "underexposure": ["gain", "noise_sigma_dn"],
            "haze": ["contrast", "haze_dn"], "colour_gamma": ["wb_gains_rgb", "gamma"],
            "occlusion": ["ring_coverage"], "edge_cut": ["sets_out"],
            "glare": ["glare_saturated_frac_of_target"],
            "rolling_shutter": ["rs_mode", "rs_x_px_over_frame", "rs_y_px_over_frame",
                                "rs_equiv_vs_truth_rot_deg"],
            "defocus": ["defocus_radius_px"], "noise": ["noise_sigma_dn"], "jpeg": ["jpeg_quality"],
            "uneven_light": ["ramp_min_brightness"], "worn": ["worn"],
            "decoys": ["n_decoys_in_view"], "negatives": ["subclass", "layout"],
            "far_noise": ["noise_sigma_dn"], "far_uneven_light": ["ramp_min_brightness"]}


def details(rows):
    out = ["| image | range m | view deg | sets centre/full in view | ground | severity | class | pos err % | rot err deg | source | reason (first 90 chars) |",
           "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        p = r["params"]
        sv = []
        for k in SEV_KEYS.get(r["condition"], []):
            if k in p:
                v = p[k]
                if k == "worn":
                    v = f"{v['coverage']:.3f}"
                elif isinstance(v, float):
                    v = f"{v:.3g}"
                elif isinstance(v, list):
                    v = "[" + ",".join(f"{x:.2f}" for x in v) + "]"
                sv.append(f"{k}={v}")
        pe = f"{r['pos_err_pct']:.2f}" if r.get("pos_err_pct") is not None else "-"
        re_ = f"{r['rot_err_deg']:.2f}" if r.get("rot_err_deg") is not None else "-"
        out.append(f"| {os.path.basename(r['image'])} | {r['range_m']:.2f} | {p.get('view_deg', 0):.1f} | "
                   f"{r['ring_centres_in_image']}/{r['ring_sets_fully_in_image']} | {p.get('ground')} | "
                   f"{'; '.join(sv)} | {r['cls']} | {pe} | {re_} | {r.get('source')} | "
                   f"{(r.get('reason') or '')[:90].replace('|', '/')} |")
    return "\n".join(out) + "\n"


def miss_reasons(rows):
    """Miss reasons grouped by their first clause (the detector's reason strings list every
    pass it tried, separated by ';'; the first clause is the first pass's verdict)."""
    import re
    lines = ["| condition | missed | first clause of `reason` (count) |", "|---|---|---|"]
    by = {}
    for r in rows:
        if r["cls"] == "missed":
            key = (r["reason"] or r["status"] or "").split(";")[0].strip()
            key = re.sub(r"[0-9]+\.[0-9]+", "#", key)          # numbers -> '#'
            key = re.sub(r"\(max error # px, gate # px\)", "", key).strip()
            by.setdefault(r["condition"], []).append(key[:110])
    for c in CONDITIONS:
        if c not in by:
            continue
        cnt = {}
        for x in by[c]:
            cnt[x] = cnt.get(x, 0) + 1
        txt = "; ".join(f"{k} ({v})" for k, v in sorted(cnt.items(), key=lambda kv: -kv[1]))
        lines.append(f"| {c} | {len(by[c])} | {txt} |")
    return "\n".join(lines) + "\n"


def gross_list(rows):
    lines = []
    for r in rows:
        if r["cls"] not in ("GROSS", "FALSE_POSITIVE", "imprecise"):
            continue
        t = r
        s = (f"- **{r['cls']}** `{r['case_file'] or r['image']}` ({r['condition']} #{r['index']}, "
             f"range {r['range_m']:.2f} m, view {r['params'].get('view_deg', 0):.1f} deg)")
        if r["condition"] != "negatives":
            s += (f": truth p_CP = [{', '.join(f'{v:.3f}' for v in t['p_CP_m'])}] m, q = "
                  f"[{', '.join(f'{v:.4f}' for v in t['q_CP_wxyz'])}]")
        if r.get("p_det"):
            s += (f"; detected p_CP = [{', '.join(f'{v:.3f}' for v in r['p_det'])}] m, q = "
                  f"[{', '.join(f'{v:.4f}' for v in r['q_det'])}]")
        if r.get("pos_err_pct") is not None:
            s += f"; pos err {r['pos_err_m']:.3f} m ({r['pos_err_pct']:.1f} %), rot err {r['rot_err_deg']:.2f} deg"
        s += f"; reproj_err_px {r.get('reproj_err_px')}, source `{r.get('source')}`, reason \"{r.get('reason')}\""
        lines.append(s)
    return "\n".join(lines) + ("\n" if lines else "(none)\n")


# ------------------------------------------------------------------ set-up checks
TEXTURE_HOWTO = (
    "Make it from the repository root (after `cmake -S . -B build && cmake --build build`):\n"
    "  g++ -O2 -std=c++17 tools/probe/make_texture.cpp -o build/make_texture -I estimator/include "
    "-I /usr/include/eigen3 -I /usr/include/opencv4 build/estimator/liblander_estimator.a "
    "-lyaml-cpp -lopencv_imgcodecs -lopencv_core\n"
    "  build/make_texture models/target.yaml {tex}\n"
    "or pass an existing texture with --texture PNG.")


def check_model_files(camera, target):
    """The renderer has the camera and target model built in (probe_render.py: W, H, FX, FY,
    CX, CY, PLATFORM, THICK, TEX_PX, RINGS). Refuse YAML files that disagree with it, since the
    truth poses would then not match what the detector assumes. Needs python3-yaml; without it
    the check is skipped with a note."""
    try:
        import yaml
    except ImportError:
        print("note: python3-yaml not installed; not checking that --camera / --target match "
              "the renderer's built-in model", file=sys.stderr)
        return
    try:
        with open(camera) as f:
            cam = yaml.safe_load(f)
        with open(target) as f:
            tgt = yaml.safe_load(f)
    except (OSError, yaml.YAMLError) as e:
        raise ProbeError(f"cannot read the camera / target YAML: {e}")
    bad = []
    try:
        want = dict(width_px=pr.W, height_px=pr.H, fx_px=pr.FX, fy_px=pr.FY, cx_px=pr.CX,
                    cy_px=pr.CY)
        for k, v in want.items():
            if abs(float(cam[k]) - v) > 1e-9:
                bad.append(f"{camera}: {k} = {cam[k]}, the renderer uses {v}")
        for k in ("k1", "k2", "p1", "p2", "k3"):
            if abs(float(cam.get(k, 0.0))) > 0:
                bad.append(f"{camera}: {k} = {cam[k]}, the renderer has no lens distortion")
        ps = [float(v) for v in tgt["platform_size_m"]]
        if any(abs(v - pr.PLATFORM) > 1e-9 for v in ps):
            bad.append(f"{target}: platform_size_m = {ps}, the renderer uses {pr.PLATFORM}")
        if abs(float(tgt["platform_thickness_m"]) - pr.THICK) > 1e-9:
            bad.append(f"{target}: platform_thickness_m = {tgt['platform_thickness_m']}, "
                       f"the renderer uses {pr.THICK}")
        if int(tgt["texture_px"]) != pr.TEX_PX:
            bad.append(f"{target}: texture_px = {tgt['texture_px']}, the renderer uses {pr.TEX_PX}")
        rings = {int(r["id"]): r for r in tgt["ring_sets"]}
        for (i, cx, cy, ro, ri) in pr.RINGS:
            r = rings.get(i)
            if r is None or abs(float(r["centre_m"][0]) - cx) > 1e-9 or \
                    abs(float(r["centre_m"][1]) - cy) > 1e-9 or \
                    abs(float(r["outer_radius_m"]) - ro) > 1e-9 or \
                    abs(float(r["inner_radius_m"]) - ri) > 1e-9:
                bad.append(f"{target}: ring set {i} differs from the renderer's RINGS")
        if len(rings) != len(pr.RINGS):
            bad.append(f"{target}: {len(rings)} ring sets, the renderer has {len(pr.RINGS)}")
    except (KeyError, TypeError, ValueError, IndexError) as e:
        raise ProbeError(f"unexpected camera / target YAML layout ({type(e).__name__}: {e})")
    if bad:
        raise ProbeError("the camera / target model differs from the one built into "
                         "probe_render.py:\n  " + "\n  ".join(bad))


def check_setup(cfg):
    for key, what in (("camera", "camera calibration (--camera)"),
                      ("target", "target model (--target)")):
        if not os.path.isfile(cfg[key]):
            raise ProbeError(f"{what} not found: {cfg[key]}")
    lander = cfg["lander"]
    if not os.path.exists(lander):
        raise ProbeError(f"detector binary not found: {lander}\n"
                         "Build it (`cmake -S . -B build && cmake --build build`, it becomes "
                         "build/lander) or pass --lander PATH.")
    if not os.path.isfile(lander) or not os.access(lander, os.X_OK):
        raise ProbeError(f"detector binary is not an executable file: {lander}")
    tex = cfg["texture"]
    if not os.path.isfile(tex):
        raise ProbeError(f"target texture not found: {tex}\n" + TEXTURE_HOWTO.format(tex=tex))
    try:
        with Image.open(tex) as im:
            size = im.size
    except OSError as e:
        raise ProbeError(f"cannot read the target texture {tex}: {e}\n" +
                         TEXTURE_HOWTO.format(tex=tex))
    if size != (pr.TEX_PX, pr.TEX_PX):
        raise ProbeError(f"target texture {tex} is {size[0]} x {size[1]} px, expected "
                         f"{pr.TEX_PX} x {pr.TEX_PX}\n" + TEXTURE_HOWTO.format(tex=tex))
    check_model_files(cfg["camera"], cfg["target"])


def parse_conditions(text):
    if text.strip() == "all":
        return list(CONDITIONS)
    conds = []
    for c in text.split(","):
        c = c.strip()
        if not c:
            continue
        if c not in CONDITIONS:
            raise ProbeError(f"unknown condition '{c}'; choose from: all, " + ", ".join(CONDITIONS))
        if c not in conds:
            conds.append(c)
    if not conds:
        raise ProbeError("no condition given (--conditions)")
    return conds


def file_sha1(path):
    import hashlib
    with open(path, "rb") as f:
        return hashlib.sha1(f.read()).hexdigest()


def write_results(resfile, rows):
    tmp = resfile + ".tmp"
    with open(tmp, "w") as f:
        for r in rows:
            f.write(json.dumps(r) + "\n")
    os.replace(tmp, resfile)


def read_results(resfile):
    try:
        with open(resfile) as f:
            return [json.loads(ln) for ln in f if ln.strip()]
    except (OSError, ValueError) as e:
        raise ProbeError(f"cannot read {resfile}: {e}")


# ------------------------------------------------------------------ run
def run(args, cfg, conds, out, rows):
    """Generates, detects and evaluates every image of conds; appends to rows (which the
    caller writes out, also after an error)."""
    resdir = os.path.join(out, "results", args.tag)
    imgdir = os.path.join(out, "images", args.tag)
    casedir = os.path.join(out, "cases")
    resfile = os.path.join(resdir, "results.jsonl")
    pr.configure(cfg["texture"], os.path.join(out, "cache"))
    t_all = time.time()
    for c in conds:
        n = args.n or N_DEFAULT[c]
        if c == "negatives" and args.n:
            n = 2 * args.n
        kept_missed = 0
        for fn in os.listdir(casedir):      # cases of an earlier run of this condition
            if fn.startswith(f"{args.tag}_{c}_") and fn[len(args.tag) + len(c) + 2:][:2].isdigit():
                os.remove(os.path.join(casedir, fn))
        for i in range(n):
            t0 = time.time()
            img, ext, truth = make_image(c, i, n, args.seed)
            name = f"{c}_{i:02d}.{ext}"
            path = os.path.join(imgdir, name)
            save_image(img, path, ext, truth)
            tg = time.time() - t0
            try:
                d, td = detect(cfg, path)
            except ProbeError as e:
                raise ProbeError(f"{e}\n  (image kept: {path})", e.code)
            ev = evaluate(truth, d)
            row = dict(truth); row.update(ev)
            row.update(image=os.path.relpath(path, out), t_gen_s=tg, t_det_s=td, case_file=None)
            keep = ev["cls"] in ("GROSS", "FALSE_POSITIVE", "imprecise") or \
                (ev["cls"] == "missed" and kept_missed < args.missed_samples)
            if keep:
                if ev["cls"] == "missed":
                    kept_missed += 1
                base = f"{args.tag}_{c}_{i:02d}_{ev['cls']}"
                case_img = os.path.join(casedir, base + "." + ext)
                shutil.copy(path, case_img)
                with open(os.path.join(casedir, base + ".json"), "w") as f:
                    json.dump(dict(truth=truth, detection=d, evaluation=ev,
                                   rerun=detector_cmd(cfg, case_img)), f, indent=1)
                row["case_file"] = os.path.relpath(case_img, out)
            if not args.keep_images and not keep:
                os.remove(path)
            rows.append(row)
            extra = ""
            if ev.get("pos_err_pct") is not None:
                extra = f" pos {ev['pos_err_pct']:.2f}% rot {ev['rot_err_deg']:.2f}deg"
            print(f"{c:16s} {i:2d} r={truth['range_m']:5.2f} {ev['cls']:10s}{extra} "
                  f"[{ev.get('source')}] {ev.get('reason')}  gen {tg:.1f}s det {td:.2f}s",
                  flush=True)
        write_results(resfile, rows)
    print(f"total {time.time() - t_all:.0f} s")


# ------------------------------------------------------------------ report files
CLASS_TEXT = ("Classes (truth vs detection): correct = position error < 2 % of the range and "
              "rotation error < 3 deg; imprecise = detected, < 5 % and < 10 deg; GROSS = "
              "beyond; missed = not detected. Negatives (no target in the image): any detection "
              "is a FALSE_POSITIVE, otherwise rejected.")


def write_tag_reports(out, tag):
    resdir = os.path.join(out, "results", tag)
    rows = read_results(os.path.join(resdir, "results.jsonl"))
    rows = [r for r in rows if r.get("condition") in CONDITIONS]
    order = {c: k for k, c in enumerate(CONDITIONS)}
    rows.sort(key=lambda r: (order[r["condition"]], r["index"]))
    seeds = sorted({r["seed"] for r in rows})
    seed_txt = ", ".join(str(s) for s in seeds) if seeds else "?"
    with open(os.path.join(resdir, "summary.md"), "w") as f:
        f.write(summarise(rows, f"Results ({tag}, seed {seed_txt})"))
        f.write("\n#### Miss reasons\n\n" + miss_reasons(rows))
        f.write("\n#### GROSS / false-positive / imprecise detections\n\n" + gross_list(rows))
    with open(os.path.join(resdir, "details.md"), "w") as f:
        f.write(f"# Per-image results ({tag})\n\n" + details(rows))
    return rows


def write_report(out):
    """<out>/report.md: the summary of every tag under <out>/results/."""
    resroot = os.path.join(out, "results")
    tags = sorted(t for t in os.listdir(resroot)
                  if os.path.isfile(os.path.join(resroot, t, "results.jsonl")))
    parts = ["# Detector probe report", "",
             "Written by tools/probe/run_probe.py (method: tools/probe/README.md). Images are "
             "rendered by an independent numpy ray caster (tools/probe/probe_render.py) and "
             "given to `lander detect IMAGE --camera CAM --target TARGET --json`.", "",
             CLASS_TEXT, ""]
    for tag in tags:
        resdir = os.path.join(resroot, tag)
        parts.append(f"## Tag `{tag}`")
        parts.append("")
        try:
            with open(os.path.join(resdir, "run.json")) as f:
                meta = json.load(f)
            parts.append(f"Last run {meta.get('finished', '?')}: detector `{meta.get('lander')}`"
                         f" (sha1 {meta.get('lander_sha1', '?')[:12]}), camera "
                         f"`{meta.get('camera')}`, target `{meta.get('target')}`, texture "
                         f"sha1 {meta.get('texture_sha1', '?')[:12]}, seed {meta.get('seed')}, "
                         f"conditions {','.join(meta.get('conditions', []))}.")
            parts.append("")
        except (OSError, ValueError):
            pass
        with open(os.path.join(resdir, "summary.md")) as f:
            parts.append(f.read().rstrip())
        parts.append("")
        parts.append(f"Per-image table: results/{tag}/details.md; kept images and their truth: "
                     f"cases/{tag}_*.")
        parts.append("")
    with open(os.path.join(out, "report.md"), "w") as f:
        f.write("\n".join(parts) + "\n")


# ------------------------------------------------------------------ main
def parse_args(argv=None):
    ap = argparse.ArgumentParser(
        description="Probe the ring-target detector with independently rendered images. "
                    "Every output goes under --out.",
        epilog="Example (from the repository root): python3 tools/probe/run_probe.py "
               "--out out/probe --conditions clean,noise --n 3")
    ap.add_argument("--out", required=True, metavar="DIR",
                    help="output directory: results/<tag>/, images/<tag>/, cases/, cache/, "
                         "report.md (and the default texture.png)")
    ap.add_argument("--lander", default=os.path.join(REPO_ROOT, "build", "lander"), metavar="PATH",
                    help="the lander CLI (default: build/lander of this repository)")
    ap.add_argument("--camera", default=os.path.join(REPO_ROOT, "models", "camera_default.yaml"),
                    metavar="YAML", help="camera calibration (default: models/camera_default.yaml)")
    ap.add_argument("--target", default=os.path.join(REPO_ROOT, "models", "target.yaml"),
                    metavar="YAML", help="target model (default: models/target.yaml)")
    ap.add_argument("--texture", default=None, metavar="PNG",
                    help="target texture from make_texture (default: <out>/texture.png)")
    ap.add_argument("--conditions", default="all",
                    help="comma list of: " + ",".join(CONDITIONS) + " (or 'all')")
    ap.add_argument("--seed", type=int, default=49)
    ap.add_argument("--n", type=int, default=None,
                    help="images per condition (default 20, negatives 40, far_* 24; "
                         "negatives get 2 x N)")
    ap.add_argument("--tag", default="main", help="results/<tag>/, images/<tag>/")
    ap.add_argument("--report-only", action="store_true",
                    help="only rewrite the summaries and report.md from results/<tag>/")
    ap.add_argument("--keep-images", action="store_true", help="keep every image in images/<tag>/")
    ap.add_argument("--missed-samples", type=int, default=3, help="missed images kept per condition")
    args = ap.parse_args(argv)
    if args.n is not None and args.n < 1:
        ap.error("--n must be >= 1")
    if args.missed_samples < 0:
        ap.error("--missed-samples must be >= 0")
    if not args.tag or os.sep in args.tag or args.tag in (".", ".."):
        ap.error("--tag must be a plain name")
    return args


def main(argv=None):
    args = parse_args(argv)
    out = os.path.abspath(args.out)
    cfg = dict(lander=os.path.abspath(args.lander), camera=os.path.abspath(args.camera),
               target=os.path.abspath(args.target),
               texture=os.path.abspath(args.texture or os.path.join(out, "texture.png")))
    conds = parse_conditions(args.conditions)
    resdir = os.path.join(out, "results", args.tag)
    resfile = os.path.join(resdir, "results.jsonl")

    if args.report_only:
        if not os.path.isfile(resfile):
            raise ProbeError(f"no results to report: {resfile} does not exist "
                             "(run without --report-only first)")
    else:
        check_setup(cfg)
        for d in (resdir, os.path.join(out, "images", args.tag), os.path.join(out, "cases")):
            os.makedirs(d, exist_ok=True)
        rows = []
        if os.path.exists(resfile):
            rows = [r for r in read_results(resfile) if r.get("condition") not in conds]
            other = sorted({r["seed"] for r in rows} - {args.seed})
            if other:
                print(f"warning: {resfile} keeps earlier results of other conditions with seed "
                      f"{other}; this run uses seed {args.seed}", file=sys.stderr)
        meta = dict(started=time.strftime("%Y-%m-%d %H:%M:%S"), lander=cfg["lander"],
                    lander_realpath=os.path.realpath(cfg["lander"]),
                    lander_sha1=file_sha1(cfg["lander"]), camera=cfg["camera"],
                    target=cfg["target"], texture=cfg["texture"],
                    texture_sha1=file_sha1(cfg["texture"]), seed=args.seed, conditions=conds,
                    n=args.n, argv=sys.argv[1:])
        meta["finished"] = "not finished"
        with open(os.path.join(resdir, "run.json"), "w") as f:
            json.dump(meta, f, indent=1)
        try:
            run(args, cfg, conds, out, rows)
        except KeyboardInterrupt:
            write_results(resfile, rows)
            raise ProbeError(f"interrupted; {len(rows)} results so far in {resfile}", 130)
        except ProbeError:
            write_results(resfile, rows)
            raise
        meta["finished"] = time.strftime("%Y-%m-%d %H:%M:%S")
        with open(os.path.join(resdir, "run.json"), "w") as f:
            json.dump(meta, f, indent=1)
    write_tag_reports(out, args.tag)
    write_report(out)
    with open(os.path.join(resdir, "summary.md")) as f:
        print(f.read())
    print(f"report: {os.path.join(out, 'report.md')}")


if __name__ == "__main__":
    try:
        main()
    except ProbeError as e:
        print(f"run_probe.py: error: {e}", file=sys.stderr)
        sys.exit(e.code)
