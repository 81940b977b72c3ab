"""lander.campaign.load: typed columns and the row count of campaign.csv."""
import csv
import math
import os

import numpy as np

import lander


def test_load_types_and_rows_against_the_csv(src):
    d = os.path.join(src, "regression", "smoke")
    df = lander.campaign.load(d)
    with open(os.path.join(d, "campaign.csv"), newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert len(df) == len(rows) and list(df.columns) == list(rows[0].keys())
    assert df["landed"].dtype == bool and df["seed"].dtype == np.uint64
    assert df["touchdown_offset_m"].dtype == float and df["id"].dtype == object
    for r, (_, x) in zip(rows, df.iterrows()):
        assert x["landed"] == (r["landed"] == "1")
        assert int(x["seed"]) == int(r["seed"])
        if r["touchdown_offset_m"] == "":
            assert math.isnan(x["touchdown_offset_m"])
        else:
            assert x["touchdown_offset_m"] == float(r["touchdown_offset_m"])


def test_a_missing_directory_is_named(tmp_path):
    import pytest
    with pytest.raises(FileNotFoundError, match="campaign.csv"):
        lander.campaign.load(tmp_path)
