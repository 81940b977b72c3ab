"""lander.Sim: the stepped run equals lander.run bit for bit; observations and truth."""
import numpy as np

import lander

# Long enough for acquisition, observe and the approach's start (frames, detections, the
# vision worker's overlap), short enough for CI.
STEPPED_S = 12


def test_the_stepped_builtin_run_equals_lander_run(default_yaml, tmp_path):
    lander.run(default_yaml, out=tmp_path / "run", overrides={"duration_s": STEPPED_S})
    steps = 0
    with lander.Sim(default_yaml, out=tmp_path / "sim", overrides={"duration_s": STEPPED_S}) as sim:
        sim.reset()
        done = False
        while not done:
            obs, done, info = sim.step()
            steps += 1
    assert steps == STEPPED_S * 30 + 1  # one per camera frame, and the end
    for f in ("summary.json", "trace.csv"):
        assert (tmp_path / "sim" / f).read_bytes() == (tmp_path / "run" / f).read_bytes(), f


def test_observations_hold_the_samples_and_the_frame_and_truth_stays_apart(default_yaml):
    with lander.Sim(default_yaml, overrides={"duration_s": 2}) as sim:
        obs, info = sim.reset(seed=4)
        assert obs["t_s"] == 0.001 and obs["frame"] is None
        obs, done, info = sim.step()
        imu = obs["samples"]["imu"]
        assert imu["gyro_B_radps"].shape[1] == 3 and len(imu["t_s"]) == imu["accel_B_mps2"].shape[0]
        assert np.all(np.diff(imu["t_s"]) > 0)
        # 250 Hz IMU between two 30 Hz frames: 8 or 9 samples.
        obs, done, info = sim.step()
        assert len(obs["samples"]["imu"]["t_s"]) in (8, 9)
        img = obs["frame"]["image"]
        assert img.shape == (720, 1280, 3) and img.dtype == np.uint8
        assert not img.flags.owndata and not img.flags.writeable  # the simulator's pixels, shared
        assert "truth" not in obs and set(info["truth"]) >= {"X_WB", "X_WP", "X_CP", "v_WB_mps"}
        X_WB = info["truth"]["X_WB"]
        assert abs(X_WB[2, 3] - 10.0) < 0.2  # the default start hovers at 10 m
        # A given time: the first step at or after it.
        obs, done, info = sim.step(until_t_s=1.0)
        assert 1.0 <= obs["t_s"] < 1.0015


def test_the_run_end_gives_the_summary(default_yaml):
    with lander.Sim(default_yaml, overrides={"duration_s": 0.5}, frames=False) as sim:
        sim.reset()
        done = False
        while not done:
            obs, done, info = sim.step()
        assert obs is None and info["summary"]["outcome"] == "timeout"
