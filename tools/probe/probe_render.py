"""Independent camera-image generator for probing the ring-target detector.

Ray-casts every sub-pixel ray of a pinhole camera (OpenCV convention, pixel centres at
integer coordinates) onto the platform plane z_P = 0 (the textured 1.8 m top surface) and
onto a procedural ground plane at z_P = -thickness; textures are sampled with trilinear
mip-mapping; sub-samples (ss x ss per pixel) are averaged (area antialiasing).
The output of render() is linear radiance (albedo x illumination), float32 HxWx3.

Call configure(texture_png, cache_dir) before rendering: texture_png is the target texture
written by tools/probe/make_texture (from models/target.yaml); cache_dir (or None for no cache)
holds the ground textures and the target albedo as .npy files (about 130 MB).
"""
import hashlib
import math
import os

import numpy as np
from PIL import Image

_TEXTURE = None     # path of the target texture PNG (configure())
_CACHE = None       # cache directory or None (configure())


def configure(texture_png, cache_dir=None):
    """Set the target texture PNG and the cache directory (None: no on-disk cache)."""
    global _TEXTURE, _CACHE, _TARGET_PYR
    _TEXTURE = texture_png
    _CACHE = cache_dir
    _TARGET_PYR = None


def _cache_load(name):
    if _CACHE is None:
        return None
    cp = os.path.join(_CACHE, name)
    if not os.path.exists(cp):
        return None
    try:
        return np.load(cp)
    except (OSError, ValueError):
        return None          # damaged cache file: recompute (and overwrite)


def _cache_save(name, arr):
    if _CACHE is None:
        return
    os.makedirs(_CACHE, exist_ok=True)
    cp = os.path.join(_CACHE, name)
    tmp = cp + ".tmp%d" % os.getpid()
    with open(tmp, "wb") as f:
        np.save(f, arr)
    os.replace(tmp, cp)      # atomic: an interrupted run leaves no truncated cache file

# ---------------------------------------------------------------- camera / target model
W, H = 1280, 720
FX = FY = 640.0
CX, CY = 639.5, 359.5

PLATFORM = 1.8          # m, square side
THICK = 0.04            # m, platform thickness (ground plane at z = -THICK)
TEX_PX = 4096
PX_PER_M = TEX_PX / PLATFORM
ALB_BLACK = 0.03        # albedo of the dark rings / code cells
ALB_WHITE = 0.85        # albedo of the white surface
ALB_SIDE = 0.45         # platform side walls

RINGS = [  # id, cx, cy, R_out, r_in  (models/target.yaml)
    (0, 0.0, 0.0, 0.38, 0.285),
    (1, 0.66, 0.0, 0.20, 0.040),
    (2, 0.33, 0.5715767665, 0.20, 0.080),
    (3, -0.33, 0.5715767665, 0.20, 0.116),
    (4, -0.66, 0.0, 0.20, 0.060),
    (5, -0.33, -0.5715767665, 0.20, 0.100),
    (6, 0.33, -0.5715767665, 0.20, 0.132),
]


def platform_to_tex(x, y):
    """P (x, y) -> texture pixel (u, v); inverse of target.h texture_to_platform
    (x = (u + 0.5) / px_per_m - size/2, y = size/2 - (v + 0.5) / px_per_m)."""
    u = (x + PLATFORM / 2) * PX_PER_M - 0.5
    v = (PLATFORM / 2 - y) * PX_PER_M - 0.5
    return u, v


# ---------------------------------------------------------------- mip pyramids
def build_pyramid(img):
    """img: 2-D float32 (square power of two). Returns list of levels (2x2 box filter)."""
    pyr = [img.astype(np.float32)]
    while pyr[-1].shape[0] > 1:
        a = pyr[-1]
        pyr.append(0.25 * (a[0::2, 0::2] + a[1::2, 0::2] + a[0::2, 1::2] + a[1::2, 1::2]))
    return pyr


def _bilinear(level, u, v, wrap):
    n = level.shape[0]
    i0 = np.floor(v).astype(np.int64)
    j0 = np.floor(u).astype(np.int64)
    fv = (v - i0).astype(np.float32)
    fu = (u - j0).astype(np.float32)
    i1 = i0 + 1
    j1 = j0 + 1
    if wrap:
        i0 %= n; i1 %= n; j0 %= n; j1 %= n
    else:
        np.clip(i0, 0, n - 1, out=i0); np.clip(i1, 0, n - 1, out=i1)
        np.clip(j0, 0, n - 1, out=j0); np.clip(j1, 0, n - 1, out=j1)
    flat = level.ravel()
    a = flat[i0 * n + j0]; b = flat[i0 * n + j1]
    c = flat[i1 * n + j0]; d = flat[i1 * n + j1]
    top = a + (b - a) * fu
    bot = c + (d - c) * fu
    return top + (bot - top) * fv


def sample_pyramid(pyr, u, v, lod, wrap):
    """Trilinear sample. u, v: level-0 texel coords (pixel centres at integers)."""
    nlev = len(pyr)
    lod = np.clip(lod, 0.0, nlev - 1 - 1e-6)
    l0 = np.floor(lod).astype(np.int64)
    f = (lod - l0).astype(np.float32)
    out = np.empty(u.shape, np.float32)
    for L in np.unique(l0):
        m = l0 == L
        uu, vv, ff = u[m], v[m], f[m]
        s0 = 2.0 ** L
        a = _bilinear(pyr[L], (uu + 0.5) / s0 - 0.5, (vv + 0.5) / s0 - 0.5, wrap)
        if L + 1 < nlev:
            s1 = 2.0 ** (L + 1)
            b = _bilinear(pyr[L + 1], (uu + 0.5) / s1 - 0.5, (vv + 0.5) / s1 - 0.5, wrap)
            a = a + (b - a) * ff
        out[m] = a
    return out


# ---------------------------------------------------------------- target texture
_TARGET_PYR = None


def target_pyramid():
    """Albedo pyramid of the exact target texture (the PNG given to configure(), written by
    tools/probe/make_texture from render_target_texture). The cache file is keyed by the
    texture's SHA-1, so a changed texture is never served from a stale cache."""
    global _TARGET_PYR
    if _TARGET_PYR is None:
        if _TEXTURE is None:
            raise RuntimeError("probe_render.configure(texture_png, cache_dir) was not called")
        with open(_TEXTURE, "rb") as f:
            key = hashlib.sha1(f.read()).hexdigest()[:16]
        name = f"target_albedo_{key}.npy"
        alb = _cache_load(name)
        if alb is None:
            t = np.asarray(Image.open(_TEXTURE).convert("L"), dtype=np.float32) / 255.0
            alb = (ALB_BLACK + (ALB_WHITE - ALB_BLACK) * t).astype(np.float32)
            _cache_save(name, alb)
        _TARGET_PYR = build_pyramid(alb)
    return _TARGET_PYR


# ---------------------------------------------------------------- ground textures
GROUND_RES = 0.01   # m per texel
GROUND_N = 2048     # periodic tile: 20.48 m
GROUND_TINT = {"asphalt": (1.0, 1.0, 1.04), "grass": (0.62, 1.0, 0.42),
               "concrete": (1.03, 1.0, 0.95), "gravel": (1.05, 1.0, 0.92)}


def _fft_noise(rng, n, beta, lo_cut=0.0, hi_cut=None):
    """Periodic 1/f^beta noise, zero mean, unit std."""
    fy = np.fft.fftfreq(n)[:, None]
    fx = np.fft.rfftfreq(n)[None, :]
    f = np.sqrt(fx * fx + fy * fy)
    f[0, 0] = 1.0
    amp = f ** (-beta)
    if lo_cut > 0:
        amp *= (f > lo_cut)
    if hi_cut is not None:
        amp *= np.exp(-(f / hi_cut) ** 2)
    amp[0, 0] = 0.0
    spec = (rng.standard_normal(amp.shape) + 1j * rng.standard_normal(amp.shape)) * amp
    out = np.fft.irfft2(spec, s=(n, n)).astype(np.float32)
    out -= out.mean()
    out /= out.std() + 1e-12
    return out


def _draw_polyline_dark(img, rng, n_lines, res, width_m, value, length_m):
    n = img.shape[0]
    for _ in range(n_lines):
        x, y = rng.uniform(0, n, 2)
        ang = rng.uniform(0, 2 * np.pi)
        steps = int(length_m / res)
        w = max(1, int(round(width_m / res)))
        for _s in range(steps):
            ang += rng.normal(0, 0.08)
            x = (x + math.cos(ang)) % n
            y = (y + math.sin(ang)) % n
            i, j = int(y), int(x)
            img[i:i + w, j:j + w] = img[i:i + w, j:j + w] * 0.3 + value * 0.7


def ground_pyramid(kind):
    name = f"ground_{kind}.npy"
    g = _cache_load(name)
    if g is None:
        rng = np.random.default_rng({"asphalt": 11, "grass": 12, "concrete": 13, "gravel": 14}[kind])
        n = GROUND_N
        coarse = _fft_noise(rng, n, 1.3)          # patches (metres)
        mid = _fft_noise(rng, n, 0.8)
        fine = rng.standard_normal((n, n)).astype(np.float32)  # 1 cm grain
        if kind == "asphalt":
            g = 0.12 + 0.025 * coarse + 0.015 * mid + 0.02 * fine
            _draw_polyline_dark(g, rng, 25, GROUND_RES, 0.015, 0.05, 3.0)   # cracks
            # a faded painted stripe
            g[:, 300:315] = g[:, 300:315] * 0.4 + 0.35
        elif kind == "grass":
            blades = _fft_noise(rng, n, 0.2)
            g = 0.16 + 0.035 * coarse + 0.03 * mid + 0.03 * blades + 0.02 * fine
            # worn dirt patches
            g += 0.05 * (coarse > 1.2)
        elif kind == "concrete":
            g = 0.30 + 0.03 * coarse + 0.015 * mid + 0.015 * fine
            for k in range(0, n, 250):   # slab joints every 2.5 m
                g[k:k + 2, :] -= 0.12
                g[:, k:k + 2] -= 0.12
            _draw_polyline_dark(g, rng, 10, GROUND_RES, 0.01, 0.15, 2.0)
        elif kind == "gravel":
            pebbles = _fft_noise(rng, n, 0.0, hi_cut=0.25)
            g = 0.22 + 0.02 * coarse + 0.05 * pebbles + 0.03 * fine
        g = np.clip(g, 0.02, 0.9).astype(np.float32)
        _cache_save(name, g)
    return build_pyramid(g)


_GROUNDS = {}


def get_ground(kind):
    if kind not in _GROUNDS:
        _GROUNDS[kind] = ground_pyramid(kind)
    return _GROUNDS[kind]


# ---------------------------------------------------------------- decals (analytic shapes)
class Decal:
    """An albedo/alpha layer on a plane z = z0 covering [x0, x0+size] x [y0, y0+size],
    rasterised with analytic area antialiasing (edge coverage from the signed distance)."""

    def __init__(self, centre_xy, size_m, n, z0):
        self.n = n
        self.size = size_m
        self.res = size_m / n
        self.x0 = centre_xy[0] - size_m / 2
        self.y0 = centre_xy[1] - size_m / 2
        self.z0 = z0
        self.alb = np.zeros((n, n), np.float32)   # premultiplied albedo
        self.alpha = np.zeros((n, n), np.float32)
        self._pyr = None

    def _grid(self, xmin, xmax, ymin, ymax):
        j0 = max(0, int((xmin - self.x0) / self.res) - 2)
        j1 = min(self.n, int((xmax - self.x0) / self.res) + 3)
        i0 = max(0, int((self.y0 + self.size - ymax) / self.res) - 2)
        i1 = min(self.n, int((self.y0 + self.size - ymin) / self.res) + 3)
        if j1 <= j0 or i1 <= i0:
            return None
        xs = self.x0 + (np.arange(j0, j1) + 0.5) * self.res
        ys = self.y0 + self.size - (np.arange(i0, i1) + 0.5) * self.res
        return (slice(i0, i1), slice(j0, j1)), xs[None, :], ys[:, None]

    def _paint(self, sl, cov, albedo):
        a = self.alpha[sl]
        self.alb[sl] = self.alb[sl] * (1 - cov) + albedo * cov
        self.alpha[sl] = a * (1 - cov) + cov

    def annulus(self, cx, cy, r_out, r_in, albedo):
        g = self._grid(cx - r_out, cx + r_out, cy - r_out, cy + r_out)
        if g is None:
            return
        sl, xs, ys = g
        d = np.hypot(xs - cx, ys - cy)
        cov = np.clip((r_out - d) / self.res + 0.5, 0, 1)
        if r_in > 0:
            cov = cov - np.clip((r_in - d) / self.res + 0.5, 0, 1)
        self._paint(sl, cov.astype(np.float32), albedo)

    def square(self, cx, cy, half, albedo, angle=0.0):
        r = half * 1.5
        g = self._grid(cx - r, cx + r, cy - r, cy + r)
        if g is None:
            return
        sl, xs, ys = g
        c, s = math.cos(angle), math.sin(angle)
        lx = (xs - cx) * c + (ys - cy) * s
        ly = -(xs - cx) * s + (ys - cy) * c
        cov = np.clip((half - np.abs(lx)) / self.res + 0.5, 0, 1) * \
            np.clip((half - np.abs(ly)) / self.res + 0.5, 0, 1)
        self._paint(sl, cov.astype(np.float32), albedo)

    def pyramid(self):
        if self._pyr is None:
            self._pyr = (build_pyramid(self.alb), build_pyramid(self.alpha))
        return self._pyr

    def sample(self, x, y, lod_m):
        """x, y: P coords on the decal plane; lod_m: sample footprint in metres."""
        u = (x - self.x0) / self.res - 0.5
        v = (self.y0 + self.size - y) / self.res - 0.5
        inside = (u > -1) & (u < self.n) & (v > -1) & (v < self.n)
        alb = np.zeros(x.shape, np.float32)
        alpha = np.zeros(x.shape, np.float32)
        if inside.any():
            pa, pal = self.pyramid()
            lod = np.log2(np.maximum(lod_m[inside] / self.res, 1e-6))
            alb[inside] = sample_pyramid(pa, u[inside], v[inside], lod, wrap=False)
            alpha[inside] = sample_pyramid(pal, u[inside], v[inside], lod, wrap=False)
        return alb, alpha


# ---------------------------------------------------------------- poses
def rot_to_quat(R):
    """Rotation matrix -> quaternion (w, x, y, z), w >= 0."""
    t = np.trace(R)
    if t > 0:
        s = math.sqrt(t + 1.0) * 2
        w = 0.25 * s
        x = (R[2, 1] - R[1, 2]) / s
        y = (R[0, 2] - R[2, 0]) / s
        z = (R[1, 0] - R[0, 1]) / s
    elif R[0, 0] > R[1, 1] and R[0, 0] > R[2, 2]:
        s = math.sqrt(1.0 + R[0, 0] - R[1, 1] - R[2, 2]) * 2
        w = (R[2, 1] - R[1, 2]) / s
        x = 0.25 * s
        y = (R[0, 1] + R[1, 0]) / s
        z = (R[0, 2] + R[2, 0]) / s
    elif R[1, 1] > R[2, 2]:
        s = math.sqrt(1.0 + R[1, 1] - R[0, 0] - R[2, 2]) * 2
        w = (R[0, 2] - R[2, 0]) / s
        x = (R[0, 1] + R[1, 0]) / s
        y = 0.25 * s
        z = (R[1, 2] + R[2, 1]) / s
    else:
        s = math.sqrt(1.0 + R[2, 2] - R[0, 0] - R[1, 1]) * 2
        w = (R[1, 0] - R[0, 1]) / s
        x = (R[0, 2] + R[2, 0]) / s
        y = (R[1, 2] + R[2, 1]) / s
        z = 0.25 * s
    q = np.array([w, x, y, z])
    q /= np.linalg.norm(q)
    if q[0] < 0:
        q = -q
    return q


def quat_to_rot(q):
    w, x, y, z = np.asarray(q, float) / np.linalg.norm(q)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def _axis_angle(axis, ang):
    axis = np.asarray(axis, float)
    axis = axis / np.linalg.norm(axis)
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + math.sin(ang) * K + (1 - math.cos(ang)) * K @ K


def make_pose(rng_range, view_deg, azim, roll, centre_px, look_at=(0.0, 0.0)):
    """Camera at distance rng_range from the point look_at (on z_P = 0), at view angle
    view_deg from the platform normal, azimuth azim; the look_at point appears at image
    pixel centre_px; roll about the optical axis. Returns R_CP, p_CP (x_C = R_CP x_P + p_CP)."""
    th = math.radians(view_deg)
    L = np.array([look_at[0], look_at[1], 0.0])
    c = L + rng_range * np.array([math.sin(th) * math.cos(azim), math.sin(th) * math.sin(azim),
                                  math.cos(th)])
    zc = (L - c) / rng_range                     # optical axis in P (looking at L)
    tmp = np.array([1.0, 0.0, 0.0]) if abs(zc[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    xc = np.cross(tmp, zc); xc /= np.linalg.norm(xc)
    yc = np.cross(zc, xc)
    R_look = np.vstack([xc, yc, zc])             # rows: camera axes in P -> R_CP
    R_roll = _axis_angle([0, 0, 1], roll)
    d = np.array([(centre_px[0] - CX) / FX, (centre_px[1] - CY) / FY, 1.0])
    d /= np.linalg.norm(d)
    z = np.array([0, 0, 1.0])
    ax = np.cross(z, d)
    if np.linalg.norm(ax) < 1e-12:
        R_off = np.eye(3)
    else:
        R_off = _axis_angle(ax, math.acos(np.clip(d @ z, -1, 1)))
    R_CP = R_off @ R_roll @ R_look
    p_CP = -R_CP @ c
    return R_CP, p_CP


def project(R_CP, p_CP, pts_P):
    X = (R_CP @ np.asarray(pts_P, float).T).T + p_CP
    u = FX * X[:, 0] / X[:, 2] + CX
    v = FY * X[:, 1] / X[:, 2] + CY
    return np.stack([u, v], 1), X[:, 2]


# ---------------------------------------------------------------- the renderer
def pixel_geometry(R_CP, p_CP, xshift=None, yshift=None):
    """Per-pixel (centre ray) hit point on z_P = 0: x, y (H x W), valid mask, on-platform
    mask and dark-ring mask (pixel centre in a ring annulus)."""
    uu, vv = np.meshgrid(np.arange(W, dtype=np.float64), np.arange(H, dtype=np.float64))
    if xshift is not None:
        uu = uu + xshift[:, None]
    if yshift is not None:
        vv = vv + yshift[:, None]
    R_PC = R_CP.T
    o = -R_PC @ p_CP
    dC = np.stack([(uu - CX) / FX, (vv - CY) / FY, np.ones_like(uu)], -1)
    dP = dC @ R_PC.T
    valid = dP[..., 2] < -1e-9
    t = np.where(valid, -o[2] / np.where(valid, dP[..., 2], -1), 0)
    x = o[0] + t * dP[..., 0]
    y = o[1] + t * dP[..., 1]
    onp = valid & (np.abs(x) <= PLATFORM / 2) & (np.abs(y) <= PLATFORM / 2)
    ring = np.zeros_like(onp)
    for (_i, cx, cy, R, r) in RINGS:
        d = np.hypot(x - cx, y - cy)
        ring |= onp & (d <= R) & (d >= r)
    return x, y, valid, onp, ring


def render(R_CP, p_CP, ground="asphalt", ss=3, platform=True, decals=(), dirt=None,
           xshift=None, yshift=None, sky=0.95, chunk_rows=48):
    """Linear radiance image (H x W x 3 float32).
    decals: Decal objects (drawn over the ground, or over the platform for z0 = 0).
    dirt: Decal on z = 0 whose alpha/albedo overrides the target albedo (worn target).
    xshift/yshift: per-row (H,) pixel offsets of the sampled ray (rolling shutter)."""
    tpyr = target_pyramid() if platform else None
    gpyr = get_ground(ground)
    tint = np.array(GROUND_TINT[ground], np.float32)
    R_PC = R_CP.T
    o = -R_PC @ p_CP
    offs = (np.arange(ss) + 0.5) / ss - 0.5
    out = np.zeros((H, W, 3), np.float32)
    us = (np.arange(W)[:, None] + offs[None, :]).ravel()          # W*ss
    for r0 in range(0, H, chunk_rows):
        r1 = min(H, r0 + chunk_rows)
        rows = np.arange(r0, r1)
        vs = (rows[:, None] + offs[None, :]).ravel()               # nr*ss
        U = np.broadcast_to(us[None, :], (vs.size, us.size)).astype(np.float64)
        V = np.broadcast_to(vs[:, None], (vs.size, us.size)).astype(np.float64)
        if xshift is not None:
            U = U + np.repeat(xshift[r0:r1], ss)[:, None]
        if yshift is not None:
            V = V + np.repeat(yshift[r0:r1], ss)[:, None]
        dx = (U - CX) / FX
        dy = (V - CY) / FY
        dPx = R_PC[0, 0] * dx + R_PC[0, 1] * dy + R_PC[0, 2]
        dPy = R_PC[1, 0] * dx + R_PC[1, 1] * dy + R_PC[1, 2]
        dPz = R_PC[2, 0] * dx + R_PC[2, 1] * dy + R_PC[2, 2]
        valid = dPz < -1e-9
        dPz_s = np.where(valid, dPz, -1.0)
        rad = np.empty(U.shape + (3,), np.float32)
        rad[...] = sky
        # ---- top plane z = 0
        t0 = -o[2] / dPz_s
        x0 = o[0] + t0 * dPx
        y0 = o[1] + t0 * dPy
        # ---- ground plane z = -THICK
        tg = (-THICK - o[2]) / dPz_s
        xg = o[0] + tg * dPx
        yg = o[1] + tg * dPy
        half = PLATFORM / 2
        on_top = valid & (np.abs(x0) <= half) & (np.abs(y0) <= half) if platform else \
            np.zeros_like(valid)
        under = valid & ~on_top & (np.abs(xg) <= half) & (np.abs(yg) <= half) if platform else \
            np.zeros_like(valid)
        on_ground = valid & ~on_top & ~under

        def footprint(xx, yy):
            # sub-sample footprint on the plane (m): from grid differences
            gx = np.hypot(np.gradient(xx, axis=1), np.gradient(yy, axis=1))
            gy = np.hypot(np.gradient(xx, axis=0), np.gradient(yy, axis=0))
            return np.maximum(np.sqrt(gx * gy), np.maximum(gx, gy) / 4.0)

        x0c = np.where(valid, x0, 0.0); y0c = np.where(valid, y0, 0.0)
        fp0 = np.where(valid, footprint(x0c, y0c), 1e3)
        if on_top.any():
            xs, ys = x0[on_top], y0[on_top]
            tu, tv = platform_to_tex(xs, ys)
            lod = np.log2(np.maximum(fp0[on_top] * PX_PER_M, 1e-6))
            alb = sample_pyramid(tpyr, tu, tv, lod, wrap=False)
            if dirt is not None:
                da, dal = dirt.sample(xs, ys, fp0[on_top])
                alb = alb * (1 - dal) + da
            for dc in decals:
                if dc.z0 == 0.0:
                    da, dal = dc.sample(xs, ys, fp0[on_top])
                    alb = alb * (1 - dal) + da
            rad[on_top] = alb[:, None]
        if under.any():
            rad[under] = ALB_SIDE
        if on_ground.any():
            xgc = np.where(valid, xg, 0.0); ygc = np.where(valid, yg, 0.0)
            fpg = np.where(valid, footprint(xgc, ygc), 1e3)
            xs, ys = xg[on_ground], yg[on_ground]
            f = fpg[on_ground]
            lod = np.log2(np.maximum(f / GROUND_RES, 1e-6))
            g = sample_pyramid(gpyr, xs / GROUND_RES - 0.5, -ys / GROUND_RES - 0.5, lod, wrap=True)
            col = g[:, None] * tint[None, :]
            for dc in decals:
                if dc.z0 != 0.0 or not platform:
                    da, dal = dc.sample(xs, ys, f)
                    col = col * (1 - dal[:, None]) + da[:, None]
            rad[on_ground] = col
        # average ss x ss
        nr = r1 - r0
        out[r0:r1] = rad.reshape(nr, ss, W, ss, 3).mean(axis=(1, 3))
    return out


def response(L, exposure=0.93):
    """Linear radiance -> DN (float, 0..255) with a gamma 1/2.2 camera response."""
    return 255.0 * np.clip(L * exposure, 0, 1) ** (1 / 2.2)


def quantise(dn):
    return np.clip(np.round(dn), 0, 255).astype(np.uint8)
