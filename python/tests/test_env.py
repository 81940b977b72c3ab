"""lander.env.LandingEnv: Gymnasium's shapes, the actions, termination by the outcomes."""
import numpy as np

import lander
from lander.env import OBSERVATION_FIELDS, LandingEnv

LOW_START = {"name": "low", "seed": 2, "duration_s": 4, "cart": {"path": "static"},
             "vehicle": {"control": "closed_loop", "start_m": [0.0, 3.0, 2.0]}}


def test_reset_and_step_have_gymnasiums_shapes():
    env = LandingEnv(LOW_START, action="velocity")
    obs, info = env.reset(seed=1)
    assert obs.shape == (len(OBSERVATION_FIELDS),) and env.observation_space.shape == obs.shape
    out = env.step(np.array([0.0, 0.0, 0.0, 0.0]))
    assert len(out) == 5
    obs, reward, terminated, truncated, info = out
    assert obs.shape == (19,) and isinstance(reward, float) and terminated is False and truncated is False
    assert np.isfinite(obs[1:7]).all()  # the IMU has reported
    assert env.action_space.contains(env.action_space.sample())
    env.close()


def test_a_hover_is_truncated_at_duration_s():
    env = LandingEnv(LOW_START, action="velocity")
    env.reset()
    terminated = truncated = False
    steps = 0
    while not (terminated or truncated):
        _, _, terminated, truncated, info = env.step(np.zeros(4))
        steps += 1
    assert truncated and not terminated and info["summary"]["outcome"] == "timeout"
    assert steps == 4 * 30 + 1
    env.close()


def test_cut_rotors_end_in_the_simulators_outcome():
    env = LandingEnv(LOW_START, action="rotor_speeds")
    env.reset()
    terminated = truncated = False
    reward = 0.0
    while not (terminated or truncated):
        _, reward, terminated, truncated, info = env.step(np.zeros(6))
    # From 2 m beside the platform with the motors off: it falls on the ground.
    assert terminated and info["summary"]["outcome"] == "touched_ground" and reward == -100.0
    env.close()
