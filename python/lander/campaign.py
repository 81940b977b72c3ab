"""Campaigns from Python: lander.campaign.load(dir) -> pandas.DataFrame, trace(dir, run_id),
run(campaign, out, jobs=...) driving the `lander campaign run` runner (processes, resume).
"""
import os
import subprocess
import sys

import numpy as np
import pandas as pd

from . import _paths

# campaign.csv's columns that are text (everything else is a number or a sampled value).
_TEXT = {"id", "scenario", "outcome", "status", "detail", "flight_software", "flight_software_version",
         "flight_plugin_sha256"}
_BOOL = {"landed", "path_covered"}


def _typed(df):
    for col in df.columns:
        if col in _TEXT:
            df[col] = df[col].fillna("").astype(str)
        elif col in _BOOL:
            cells = df[col]
            if cells.isna().any() and col == "path_covered":
                continue  # runs without a route: no value
            df[col] = cells.map({1: True, 0: False, "1": True, "0": False}).astype(bool)
        elif col == "seed":
            df[col] = df[col].astype(np.uint64)
        else:
            try:  # Python's float(): exact (pandas' own parser may miss the last digit)
                df[col] = df[col].map(lambda x: float(x) if isinstance(x, str) else np.nan).astype(float)
            except ValueError:
                df[col] = df[col].fillna("").astype(str)  # a categorical sampled value
    return df


def load(directory):
    """One row per run of DIR/campaign.csv (after `lander campaign report` or a finished run):
    numbers as floats (missing as NaN), `landed` as bool, `seed` as uint64, text as str."""
    path = os.path.join(os.fspath(directory), "campaign.csv")
    if not os.path.isfile(path):
        raise FileNotFoundError(f"{path}: not found; run `lander campaign report {directory}` first")
    df = pd.read_csv(path, dtype=str, keep_default_na=False, na_values=[""])
    return _typed(df)


def trace(directory, run_id):
    """The run's trace.csv as a DataFrame of floats (the `mode` column as str)."""
    path = os.path.join(os.fspath(directory), "runs", run_id, "trace.csv")
    if not os.path.isfile(path):
        raise FileNotFoundError(f"{path}: no such run trace")
    df = pd.read_csv(path)
    for col in df.columns:
        if col != "mode":
            df[col] = df[col].astype(float)
    return df


def run(campaign, out, *, jobs=None, flight_plugin=None, only=None, progress=None, lander_binary=None):
    """Runs (or resumes) a campaign with the project's runner and returns load(out).

    progress: None prints the runner's progress lines to stderr; a callable gets each line;
    False is silent. Raises subprocess.CalledProcessError on a bad input (exit 2).
    """
    cmd = [lander_binary or _paths.LANDER_BINARY, "campaign", "run", os.fspath(campaign), "--out", os.fspath(out)]
    if jobs is not None:
        cmd += ["--jobs", str(int(jobs))]
    if flight_plugin is not None:
        cmd += ["--flight-plugin", os.fspath(flight_plugin)]
    if only:
        cmd += ["--only", ",".join(only)]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, bufsize=1)
    for line in proc.stdout:
        line = line.rstrip("\n")
        if progress is None:
            print(line, file=sys.stderr)
        elif callable(progress):
            progress(line)
    code = proc.wait()
    if code not in (0, 1):  # 1: some run was a simulator failure; the campaign is still merged
        raise subprocess.CalledProcessError(code, cmd)
    return load(out)
