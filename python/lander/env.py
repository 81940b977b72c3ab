"""A landing environment with the shape of Gymnasium's API, without depending on gymnasium
(Debian 12 does not ship it; when it is importable, "lander/Landing-v0" is registered).

    env = lander.env.LandingEnv("scenarios/default.yaml", action="velocity")
    obs, info = env.reset(seed=1)
    obs, reward, terminated, truncated, info = env.step(env.action_space.sample())

One step is one camera frame period (1/camera.rate_hz; 30 Hz by default).

Actions (action=...):
  "velocity"         [vx, vy, vz, yaw]: velocity (m/s, W, z up) and heading (rad) for our
                     autopilot, which flies on our estimator (default)
  "attitude_thrust"  [roll, pitch, yaw, thrust]: attitude (rad, z-y-x) and total thrust (N)
                     for our autopilot's inner loop
  "rotor_speeds"     six rotor speeds (rad/s, hex-X order of controller/mixer.h), straight
                     to the motors; all zero cuts them (a touchdown)
Observation: a float64 vector of the latest sensor readings the flight software was given,
  OBSERVATION_FIELDS names its 19 entries (NaN where a sensor has not reported yet); with
  frames=True a dict {"sensors": that vector, "image": H x W x 3 uint8 BGR}.
Reward: -(horizontal distance to the platform, m) x step period (s), -0.1 x |velocity
  relative to the platform| (m/s) x step period; +100 when the run ends landed, -100 when it
  ends touched_ground, tipped_over or diverged. The distance uses the truth, which the
  observation never holds (info["truth"] has it, for analysis).
Termination: exactly the simulator's outcomes (landed, touched_ground, tipped_over,
  diverged, aborted, error); truncation: the scenario's duration_s (outcome timeout).
"""
import numpy as np

from . import Sim

OBSERVATION_FIELDS = (
    "t_s", "gyro_x_radps", "gyro_y_radps", "gyro_z_radps", "accel_x_mps2", "accel_y_mps2", "accel_z_mps2",
    "baro_pressure_pa", "gps_x_m", "gps_y_m", "gps_z_m", "gps_vx_mps", "gps_vy_mps", "gps_vz_mps", "gps_valid",
    "ultrasonic_range_m", "mag_x_uT", "mag_y_uT", "mag_z_uT")
TERMINAL = {"landed", "touched_ground", "tipped_over", "diverged", "aborted", "error"}
CRASH = {"touched_ground", "tipped_over", "diverged"}


class Box:
    """A box space like gymnasium.spaces.Box: low, high, shape, dtype, sample(), contains()."""

    def __init__(self, low, high, shape, dtype=np.float64, seed=None):
        self.low = np.broadcast_to(np.asarray(low, dtype=dtype), shape).copy()
        self.high = np.broadcast_to(np.asarray(high, dtype=dtype), shape).copy()
        self.shape, self.dtype = tuple(shape), dtype
        self._rng = np.random.default_rng(seed)

    def sample(self):
        lo = np.where(np.isfinite(self.low), self.low, -1.0)
        hi = np.where(np.isfinite(self.high), self.high, 1.0)
        return self._rng.uniform(lo, hi).astype(self.dtype)

    def contains(self, x):
        x = np.asarray(x)
        return x.shape == self.shape and bool(np.all(x >= self.low) and np.all(x <= self.high))

    def __repr__(self):
        return f"Box({self.low.min()}, {self.high.max()}, {self.shape}, {np.dtype(self.dtype).name})"


_ACTION_SPACES = {
    "velocity": lambda: Box([-5, -5, -2, -np.pi], [5, 5, 2, np.pi], (4,)),
    "attitude_thrust": lambda: Box([-0.6, -0.6, -np.pi, 0], [0.6, 0.6, np.pi, 120], (4,)),
    "rotor_speeds": lambda: Box(0, 800, (6,)),
}


class LandingEnv:
    """See the module's doc."""
    metadata = {"render_modes": []}

    def __init__(self, scenario="scenarios/default.yaml", action="velocity", frames=False, overrides=None):
        if action not in _ACTION_SPACES:
            raise ValueError(f"action must be one of {sorted(_ACTION_SPACES)}, got {action!r}")
        self.action_kind, self.frames = action, frames
        self._sim = Sim(scenario, overrides=overrides, action=action, frames=frames)
        self.action_space = _ACTION_SPACES[action]()
        self.observation_space = Box(-np.inf, np.inf, (len(OBSERVATION_FIELDS),))
        self._last = np.full(len(OBSERVATION_FIELDS), np.nan)
        self._t = 0.0

    def _sensors(self, obs):
        s, v = obs["samples"], self._last
        v[0] = obs["t_s"]
        if len(s["imu"]["t_s"]):
            v[1:4], v[4:7] = s["imu"]["gyro_B_radps"][-1], s["imu"]["accel_B_mps2"][-1]
        if len(s["baro"]["t_s"]):
            v[7] = s["baro"]["pressure_pa"][-1]
        if len(s["gps"]["t_s"]):
            v[8:11], v[11:14], v[14] = s["gps"]["p_W_m"][-1], s["gps"]["v_W_mps"][-1], s["gps"]["valid"][-1]
        if len(s["ultrasonic"]["t_s"]):
            v[15] = s["ultrasonic"]["range_m"][-1]
        if len(s["magnetometer"]["t_s"]):
            v[16:19] = s["magnetometer"]["field_B_uT"][-1]
        return v.copy()

    def _observation(self, obs):
        sensors = self._sensors(obs)
        if not self.frames:
            return sensors
        return {"sensors": sensors, "image": None if obs["frame"] is None else obs["frame"]["image"]}

    def reset(self, seed=None, options=None):
        self._last[:] = np.nan
        obs, info = self._sim.reset(seed)
        self._t = obs["t_s"]
        return self._observation(obs), info

    def step(self, action):
        a = np.asarray(action, dtype=np.float64)
        if a.shape != self.action_space.shape:
            raise ValueError(f"action shape {a.shape}, expected {self.action_space.shape}")
        obs, done, info = self._sim.step(action=a)
        if done:
            outcome = info["summary"]["outcome"]
            reward = 100.0 if outcome == "landed" else (-100.0 if outcome in CRASH else 0.0)
            terminated, truncated = outcome in TERMINAL, outcome == "timeout"
            return self._observation_end(), reward, terminated, truncated, info
        dt = obs["t_s"] - self._t
        self._t = obs["t_s"]
        tr = info["truth"]
        d = np.linalg.norm(tr["X_WB"][:2, 3] - tr["X_WP"][:2, 3])
        cart_v = np.array([tr["cart_qd"][0], tr["cart_qd"][1], 0.0])
        reward = -d * dt - 0.1 * np.linalg.norm(tr["v_WB_mps"] - cart_v) * dt
        return self._observation(obs), float(reward), False, False, info

    def _observation_end(self):
        sensors = self._last.copy()
        return sensors if not self.frames else {"sensors": sensors, "image": None}

    def close(self):
        self._sim.close()


try:  # register with gymnasium when it is installed (it is not a dependency)
    import gymnasium as _gym
    _gym.register(id="lander/Landing-v0", entry_point="lander.env:LandingEnv")
except Exception:  # noqa: BLE001 - absent or incompatible: the class works without it
    pass
