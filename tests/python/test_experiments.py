"""The paper's experiments as functions: their summary and arrays are those of `cariesim
experiment`."""

import json

import numpy as np

import cariesim
from conftest import run_cariesim


def test_friction_matches_the_command(cariesim_exe, tmp_path):
    result = cariesim.friction(rate=500.0)
    assert result["out"] is None and result["figures"] == []
    assert result["arrays"], "the experiment's CSVs"
    run_cariesim(cariesim_exe, "experiment", "friction", "--no-figures", "--quiet", "--rate", "500",
                 "--out", tmp_path / "exp")
    summary = json.loads((tmp_path / "exp" / "summary.json").read_text())
    ours = dict(result["summary"])
    for s in (ours, summary):  # how long it took differs
        s.pop("wall_seconds")
    assert ours == summary
    assert len(ours["runs"]) == 8
    for name, array in result["arrays"].items():
        theirs = np.genfromtxt(tmp_path / "exp" / f"{name}.csv", delimiter=",", names=True, dtype=None,
                               encoding="utf-8")
        for column in array.dtype.names:
            if array[column].dtype.kind == "f":
                assert np.array_equal(array[column], theirs[column].astype(float), equal_nan=True), (name, column)
