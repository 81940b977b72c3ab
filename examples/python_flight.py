"""A landing logic written in Python and NumPy, flown on our estimator, our ring detector and
our autopilot (the companion-computer seam, docs/guide/python.md):

    import lander, sys
    sys.path.insert(0, "examples"); from python_flight import PythonLander
    summary = lander.run("scenarios/default.yaml", flight=PythonLander())

or from a scenario or campaign, by the key flight.python (lander run hands such a scenario
to python3 -m lander run; `lander regress` compares it with ours):

    flight:
      python: ../examples/python_flight.py:PythonLander
      plugin_config: {kp_per_s: 0.6}

The logic is examples/pd_lander/pd_lander.cpp's, in NumPy: search (climb and sweep the
heading until the platform is seen), pursue (fly the platform's velocity plus a PI on the
horizontal error), descend inside a gate that narrows near the top, cut a few centimetres
above it. update() returns a velocity setpoint for our autopilot (a dict; see
lander.Sim/lander.env for the other kinds).
"""
import math

import numpy as np

DEFAULTS = {
    "kp_per_s": 0.6, "ki_per_s2": 0.25, "max_integral_mps": 0.8, "max_speed_mps": 2.0,
    "descent_rate_mps": 0.8, "descent_per_m": 0.35, "min_descent_mps": 0.15,
    "descend_gate_m": 0.08, "descend_gate_per_m": 0.12, "cut_clearance_m": 0.03, "cut_error_m": 0.08,
    "contact_clearance_m": 0.02, "lost_after_s": 1.5, "search_height_m": 10.0, "climb_rate_mps": 0.8,
    "search_yaw_rate_degps": 30.0, "fit_window_s": 1.5,
}


class PythonLander:
    """The landing logic: on_vision(obs) for each vision result, update(inputs) at 30 Hz."""

    def __init__(self, flight_config=None, plugin_config=None):
        unknown = set(plugin_config or {}) - set(DEFAULTS)
        if unknown:
            raise ValueError(f"flight.plugin_config: unknown keys {sorted(unknown)} (known: {sorted(DEFAULTS)})")
        self.p = {**DEFAULTS, **(plugin_config or {})}
        landing = ((flight_config or {}).get("controller") or {}).get("landing") or {}
        self.gear_height_m = float(landing.get("gear_height_m", 0.25))
        self.mode, self.transitions = "search", []
        self.fixes = []            # (t, p_W) of the last fit_window_s
        self.nav_history = []      # (t, R_WB, p_W, v_W) at the outer-loop steps of the last second
        self.pending = None
        self.platform_W_m = None   # the fitted line's position at the latest fix (trace.csv)
        self.v_platform = np.zeros(3)
        self.t_fix = None
        self.h_camera = math.nan
        self.integral = np.zeros(2)
        self.yaw = None
        self.last_t = None

    def info(self):
        return {"name": "python_lander", "version": "1.0"}

    def on_vision(self, obs):
        if obs.detected:
            self.pending = (obs.t_s, np.array(obs.X_CP))

    def _switch(self, t, mode, reason):
        if mode != self.mode:
            self.transitions.append((t, self.mode, mode, reason))
            self.mode = mode

    def _take_fix(self, inputs):
        t_obs, X_CP = self.pending
        self.pending = None
        if self.t_fix is not None and t_obs <= self.t_fix:
            return
        # The attitude and position of the exposure, not of the delivery ~0.1 s later.
        t, R_WB, p_W, v_W = min(self.nav_history, key=lambda s: abs(s[0] - t_obs))
        X_WB = np.eye(4)
        X_WB[:3, :3], X_WB[:3, 3] = R_WB, p_W + v_W * (t_obs - t)
        X_WC = X_WB @ np.array(inputs.X_BC)
        p = X_WC[:3, :3] @ X_CP[:3, 3] + X_WC[:3, 3]
        if not np.all(np.isfinite(p)):
            return
        self.fixes = [f for f in self.fixes if f[0] >= t_obs - self.p["fit_window_s"]] + [(t_obs, p)]
        ts = np.array([f[0] for f in self.fixes])
        ps = np.array([f[1] for f in self.fixes])
        # A straight line through the fixes by least squares (no slope from < 3 or < 0.3 s).
        if len(ts) >= 3 and ts[-1] - ts[0] > 0.3:
            tc = ts - ts.mean()
            self.v_platform = (tc[:, None] * (ps - ps.mean(axis=0))).sum(axis=0) / (tc * tc).sum()
        else:
            self.v_platform = np.zeros(3)
        self.platform_W_m = ps.mean(axis=0) + self.v_platform * (t_obs - ts.mean())
        self.t_fix = t_obs
        self.h_camera = X_WC[2, 3] - p[2]

    def _height(self, inputs, t):
        if self.t_fix is not None and t - self.t_fix < 0.5 and math.isfinite(self.h_camera):
            return self.h_camera - np.array(inputs.X_BC)[2, 3]  # the camera sits below B
        if inputs.altitude_valid:
            return inputs.altitude.h_surface_m
        return inputs.nav.p_W_m[2]

    def update(self, inputs):
        t, nav = inputs.t_s, inputs.nav
        R_WB = np.array(nav.R_WB)
        if self.yaw is None:
            self.yaw = math.atan2(R_WB[1, 0], R_WB[0, 0])
            self.hold = np.array(nav.p_W_m)
        self.nav_history = [s for s in self.nav_history if s[0] > t - 1.0] + [(t, R_WB, np.array(nav.p_W_m), np.array(nav.v_W_mps))]
        if self.pending is not None:
            self._take_fix(inputs)
        p_W = np.array(nav.p_W_m)
        h = self._height(inputs, t)
        fresh = self.t_fix is not None and t - self.t_fix < self.p["lost_after_s"]
        if not fresh:
            return self._search(t, p_W, h)
        self.search_t = None
        pred = self.platform_W_m + self.v_platform * (t - self.t_fix)
        err = pred[:2] - p_W[:2]
        clearance = h - self.gear_height_m
        e = float(np.linalg.norm(err))
        if (clearance < self.p["cut_clearance_m"] and e < self.p["cut_error_m"]) or clearance < self.p["contact_clearance_m"]:
            self._switch(t, "cut", "gear at the top" if clearance < self.p["contact_clearance_m"] else "centred, gear within cut_clearance_m")
            return {"kind": "motors_cut"}
        dt = 0.0 if self.last_t is None else min(max(t - self.last_t, 0.0), 0.1)
        self.last_t = t
        self.integral += self.p["ki_per_s2"] * err * dt
        n = np.linalg.norm(self.integral)
        if n > self.p["max_integral_mps"]:
            self.integral *= self.p["max_integral_mps"] / n
        v = self.v_platform[:2] + self.p["kp_per_s"] * err + self.integral
        n = np.linalg.norm(v)
        if n > self.p["max_speed_mps"]:
            v *= self.p["max_speed_mps"] / n
        vz = 0.0
        if e < self.p["descend_gate_m"] + self.p["descend_gate_per_m"] * max(0.0, clearance):
            vz = -min(max(self.p["descent_per_m"] * clearance, self.p["min_descent_mps"]), self.p["descent_rate_mps"])
            self._switch(t, "descend", "centred within the descent gate")
        else:
            self._switch(t, "pursue", "outside the descent gate")
        return {"kind": "velocity", "v_W_mps": [v[0], v[1], vz], "yaw_rad": self.yaw}

    def _search(self, t, p_W, h):
        self._switch(t, "lost" if self.t_fix is not None else "search", "no fix")
        last = getattr(self, "search_t", None)
        self.yaw += math.radians(self.p["search_yaw_rate_degps"]) * (0.0 if last is None else min(max(t - last, 0.0), 0.1))
        self.search_t = t
        target = self.hold if self.t_fix is None else self.platform_W_m + self.v_platform * (t - self.t_fix)
        v = self.p["kp_per_s"] * (target[:2] - p_W[:2])
        n = np.linalg.norm(v)
        if n > self.p["max_speed_mps"]:
            v *= self.p["max_speed_mps"] / n
        vz = self.p["climb_rate_mps"] if h < self.p["search_height_m"] else 0.0
        return {"kind": "velocity", "v_W_mps": [v[0], v[1], vz], "yaw_rad": self.yaw}
