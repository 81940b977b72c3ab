"""lander: software-in-the-loop landing of a hexarotor on a moving cart, from Python.

The simulator's C++ core (MuJoCo plant, offscreen camera, sensors, our flight software) in a
Python package (docs/guide/python.md):

    import lander
    summary = lander.run("scenarios/default.yaml", seed=3)          # summary.json as a dict
    sim = lander.Sim("scenarios/default.yaml")                      # step frame by frame
    obs, info = sim.reset(seed=1)
    obs, done, info = sim.step()                                    # info["truth"] kept apart
    frame = lander.Detector().detect(image)                         # our ring detector
    df = lander.campaign.load("out/smoke")                          # campaign.csv, typed

A flight software written in Python flies with lander.run(scenario, flight=obj): `obj` has
either the seam's methods (on_imu, begin_frame, deliver_frame, ...: the C++ seam's names,
flight/include/lander/flight/flight_software.h) or a landing logic's (update, on_vision) for
our estimator, detector and autopilot (examples/python_flight.py).
"""
import os as _os

from . import _lander
from ._lander import (AltitudeEstimate, BaroSample, ConfigError, FlightSoftwareError, GpsSample,
                      ImuSample, LandingInputs, MagSample, NavState, PlatformObservation,
                      UltrasonicSample)

__version__ = _lander.__version__
FLIGHT_SOFTWARE_API_VERSION = _lander.FLIGHT_SOFTWARE_API_VERSION

__all__ = ["run", "Sim", "Detector", "detect", "ConfigError", "FlightSoftwareError", "campaign",
           "env", "dataset", "__version__"]


def run(scenario, *, seed=None, out=None, video=False, overrides=None, flight=None,
        vision_schedule="auto"):
    """Runs one scenario and returns its summary.json as a dict.

    scenario: a scenario file's path, or a dict with a scenario file's keys (validated the same
      way; relative paths from the working directory).
    seed: replaces the scenario's seed. out: a directory for the usual files (summary.json,
      trace.csv, ...); None runs in a temporary directory, removed afterwards. video: write
      camera.mp4 and chase.mp4 (needs out). overrides: {dotted.key: value}, applied on top of
      the scenario like a campaign's dispersion. flight: a flight software written in Python
      (see the package's doc); None flies the scenario's (ours, its flight.plugin, or its
      flight.python class).
    Raises ConfigError (a ValueError) naming the key, and for files the line, for bad input;
    a Python flight software's exception ends the run with outcome "error".
    """
    if video and out is None:
        raise ConfigError("video=True needs out=DIR")
    return _lander.run(scenario, seed, None if out is None else _os.fspath(out), bool(video), overrides,
                       flight, vision_schedule)


class Sim:
    """A closed-loop run stepped from Python.

    sim = Sim(scenario, seed=None, overrides=None, out=None, flight=None, action="none",
              frames=True)
    obs, info = sim.reset(seed=None)        # a new run, paused after its first physics step
    obs, done, info = sim.step()            # on to the next camera frame
    obs, done, info = sim.step(until_t_s=T) # on to the first step at or after T (s)

    obs: {"t_s", "samples": {"imu": {"t_s", "gyro_B_radps", "accel_B_mps2"}, "baro", "gps",
    "ultrasonic", "magnetometer", "platform_telemetry", "rotor_commands"} as NumPy arrays of
    what the flight software was given since the last step, "frame": {"index", "t_start_s",
    "t_end_s", "readout_s", "image"} or None} (t_start_s: the first row's exposure start,
    t_end_s: the last row's end; readout_s > 0 with camera.rolling_shutter_readout_ms); the image is an H x W x 3 BGR uint8 array sharing the
    simulator's pixels (no copy, read-only). info["truth"]: X_WB, X_WP, X_WC, X_CP (4x4, now), with a
    frame X_WC_mid_exposure, X_WP_mid_exposure and X_CP_mid_exposure (at its exposure's middle:
    the label of its pixels), the vehicle's velocities, the cart's rates: never given to the
    flight software. When the run
    has ended, obs is None, done is True and info["summary"] is summary.json.

    With the scenario's own flight software (flight=None, action="none") the files a stepped
    run writes are those of lander.run, bit for bit. action="velocity" ([vx, vy, vz, yaw]),
    "attitude_thrust" ([roll, pitch, yaw, thrust_N]) or "rotor_speeds" (6 x rad/s) flies the
    actions given to step(action=...) instead (lander.env).
    """

    def __init__(self, scenario, *, seed=None, overrides=None, out=None, flight=None,
                 action="none", frames=True):
        self._sim = _lander.Sim(scenario, seed, overrides, None if out is None else _os.fspath(out),
                                flight, action, bool(frames))

    def reset(self, seed=None):
        obs, _done, info = self._sim.reset(seed)
        return obs, info

    def step(self, until_t_s=None, action=None):
        return self._sim.step(-1.0 if until_t_s is None else float(until_t_s), action)

    def close(self):
        self._sim.close()

    @property
    def out_dir(self):
        return self._sim.out_dir

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


Detector = _lander.Detector
Detector.__doc__ = """Our ring and code-map detector.

Detector(camera=None, target=None, flight_file=None): camera a camera YAML path (like
models/camera_default.yaml) or a dict of intrinsics; target a target YAML; flight_file a
flight parameter file for the detector's parameters (default models/flight.yaml).
detect(image, blur_px=(0, 0)) -> dict: detected, status, reason, X_CP (4x4), cov (6x6),
centres, ellipses, ... (the fields of `lander detect --json`). Stateful: frames in order.
"""


def detect(image, camera=None, target=None):
    """One image through a fresh Detector (see Detector)."""
    return Detector(camera, target).detect(image)


from . import campaign, dataset, env  # noqa: E402  (they use the names above)
