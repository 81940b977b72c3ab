"""A flight software written in Python: it lands the default scenario, flies from the
flight.python key through `lander run` and a campaign, and its exceptions end the run."""
import json
import os
import subprocess

import pytest

import lander
from lander import _paths
from python_flight import PythonLander

# The moving-cart landings' touchdown offset limit (the campaigns' offset_limit_m).
OFFSET_LIMIT_M = 0.10


def test_the_example_lands_the_default_scenario(default_yaml, tmp_path):
    s = lander.run(default_yaml, out=tmp_path, flight=PythonLander())
    assert s["landed"], s["outcome_detail"]
    assert s["touchdown_offset_m"] < OFFSET_LIMIT_M
    assert s["flight_software"] == {"name": "python_lander", "version": "1.0"}
    assert [t["to"] for t in s["mode_transitions"]][-1] == "cut"
    fs = json.loads((tmp_path / "flight_software.json").read_text())
    assert fs["source"] == "builtin"  # given as an object, not by flight.python


def test_the_seams_own_names_fly_a_whole_python_flight_software(default_yaml):
    class Hover:
        """A whole flight software: no estimator, every rotor at a constant speed."""
        def __init__(self):
            self.calls = {"on_imu": 0, "on_baro": 0, "begin_frame": 0, "deliver_frame": 0}
        def on_imu(self, s):
            self.calls["on_imu"] += 1
            return [420.0] * 6
        def on_baro(self, b):
            self.calls["on_baro"] += 1
        def begin_frame(self, frame):
            self.calls["begin_frame"] += 1
            assert frame.image.shape == (720, 1280, 3)
            return {"index": frame.index}
        def deliver_frame(self, job):
            self.calls["deliver_frame"] += 1
        def status(self):
            return {"mode": "hover"}
    h = Hover()
    s = lander.run(default_yaml, overrides={"duration_s": 1}, flight=h)
    assert s["outcome"] == "timeout" and s["final_mode"] == ""
    # 250 Hz from t = 0 to 1 s inclusive, 30 frames.
    assert h.calls["on_imu"] == 251 and h.calls["begin_frame"] == 30 and h.calls["on_baro"] > 0
    assert h.calls["deliver_frame"] >= 28  # the last frames' results are due after the end


def test_an_exception_in_python_ends_the_run_naming_the_method(default_yaml, tmp_path):
    class Broken(PythonLander):
        def update(self, inputs):
            if inputs.t_s > 0.5:
                raise ZeroDivisionError("deliberate")
            return super().update(inputs)
    with pytest.raises(lander.FlightSoftwareError, match=r"threw in update: ZeroDivisionError: deliberate"):
        lander.run(default_yaml, out=tmp_path, flight=Broken())
    s = json.loads((tmp_path / "summary.json").read_text())
    assert s["outcome"] == "error" and "update" in s["outcome_detail"]


def test_flight_python_flies_through_lander_run_and_a_campaign(src, tmp_path):
    example = os.path.join(src, "examples", "python_flight.py")
    (tmp_path / "py.yaml").write_text(
        "name: py_static\nseed: 4\nduration_s: 40\ncart: {path: static}\n"
        "vehicle: {control: closed_loop, start_m: [-1.0, 0.5, 4.0]}\n"
        f"flight: {{python: '{example}:PythonLander', plugin_config: {{kp_per_s: 0.6}}}}\n")
    r = subprocess.run([_paths.LANDER_BINARY, "run", str(tmp_path / "py.yaml"), "--out", str(tmp_path / "one"),
                        "--quiet"], capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stdout + r.stderr
    s = json.loads((tmp_path / "one" / "summary.json").read_text())
    assert s["landed"] and s["flight_software"]["name"] == "python_lander"
    fs = json.loads((tmp_path / "one" / "flight_software.json").read_text())
    assert fs["source"] == "python" and fs["plugin"].endswith("python_flight.py:PythonLander")
    (tmp_path / "c.yaml").write_text("name: py\nseed: 2\nscenarios:\n  - {file: py.yaml, runs: 1}\n")
    df = lander.campaign.run(tmp_path / "c.yaml", tmp_path / "camp", jobs=1, progress=False)
    assert len(df) == 1 and bool(df["landed"].iloc[0])
    assert df["flight_software"].iloc[0] == "python_lander"
    t = lander.campaign.trace(tmp_path / "camp", df["id"].iloc[0])
    assert t["t_s"].dtype == float and t["mode"].iloc[-1] == "cut"


def test_a_bad_plugin_config_key_is_refused(default_yaml, src):
    # (A relative flight.python path is taken from the scenario file's folder, as in a file.)
    example = os.path.join(src, "examples", "python_flight.py")
    with pytest.raises(lander.ConfigError, match=r"python_flight.py:PythonLander: ValueError: flight.plugin_config: unknown keys \['kp'\]"):
        lander.run(default_yaml, overrides={"flight.python": example + ":PythonLander",
                                            "flight.plugin_config": {"kp": 1}})
