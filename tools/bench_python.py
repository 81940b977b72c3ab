#!/usr/bin/env python3
"""The Python package's step cost: lander.Sim.step() per second with and without frames,
against the same run through lander.run (no stepping), and the frame's crossing into NumPy.

    /usr/bin/python3 tools/bench_python.py [--seconds S] [--json FILE]

Timings are for the results page (docs/results/performance.md), never for a test.
"""
import argparse
import json
import os
import platform
import subprocess
import time

import numpy as np

import lander

HERE = os.path.dirname(os.path.abspath(__file__))


def stepped(scenario, seconds, frames):
    t0 = time.perf_counter()
    steps = 0
    with lander.Sim(scenario, overrides={"duration_s": seconds}, frames=frames) as sim:
        sim.reset()
        done = False
        while not done:
            obs, done, info = sim.step()
            if not done and frames and obs["frame"] is not None:
                np.asarray(obs["frame"]["image"]).sum(dtype=np.uint64)  # touch every pixel once
            steps += 1
    return steps, time.perf_counter() - t0


def timed_run(scenario, seconds):
    t0 = time.perf_counter()
    lander.run(scenario, overrides={"duration_s": seconds})
    return time.perf_counter() - t0


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--seconds", type=float, default=10.0)
    p.add_argument("--json")
    a = p.parse_args()
    scenario = os.path.join(HERE, "..", "scenarios", "default.yaml")
    # Each twice, the faster kept: the run-to-run spread on a loaded 2-core machine is ~5 %.
    plain = min(timed_run(scenario, a.seconds) for _ in range(2))
    steps_f, with_frames = min((stepped(scenario, a.seconds, True) for _ in range(2)), key=lambda x: x[1])
    steps_n, without = min((stepped(scenario, a.seconds, False) for _ in range(2)), key=lambda x: x[1])
    img = np.random.default_rng(1).integers(0, 255, (720, 1280, 3), dtype=np.uint8)
    t0 = time.perf_counter()
    for _ in range(100):
        img.copy()
    copy_ms = (time.perf_counter() - t0) * 10
    commit = subprocess.run(["git", "-C", HERE, "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
    r = {"command": "tools/bench_python.py --seconds %g" % a.seconds, "commit": commit,
         "date": time.strftime("%Y-%m-%d"), "machine": f"{platform.node()} {os.cpu_count()} cores",
         "sim_s": a.seconds, "lander_run_wall_s": plain,
         "stepped_with_frames": {"steps": steps_f, "wall_s": with_frames, "steps_per_s": steps_f / with_frames},
         "stepped_without_frames": {"steps": steps_n, "wall_s": without, "steps_per_s": steps_n / without},
         "stepping_overhead_per_step_ms": (without - plain) / steps_n * 1e3,
         "note": "stepping overhead within the run-to-run spread when negative",
         "frame_into_numpy": "a view of the simulator's pixels: no copy",
         "a_frame_copy_would_cost_ms": copy_ms}
    print(json.dumps(r, indent=2))
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(r, fh, indent=2)


if __name__ == "__main__":
    main()
