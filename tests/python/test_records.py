"""read_recording against `cariesim export`: the same numbers (export writes each in its shortest
exact form, so they read back bit for bit), with and without pandas; study databases."""

import csv

import numpy as np
import pytest

import cariesim
from conftest import press_and_slide, run_cariesim, write_trajectory


@pytest.fixture(scope="module")
def recording(tmp_path_factory, cariesim_exe):
    """A short servo session on the friction block, recorded, and its export."""
    folder = tmp_path_factory.mktemp("recording")
    write_trajectory(folder / "traj.csv", press_and_slide(duration=0.3))
    run_cariesim(cariesim_exe, "servo", "--scene", "friction-block", "--device", f"scripted:{folder / 'traj.csv'}",
                 "--record", folder / "rec.db", "--quiet", "--no-standby")
    run_cariesim(cariesim_exe, "export", folder / "rec.db", "--out", folder / "export", "--quiet")
    return folder


def _csv(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def _same(column, texts):
    """A numeric column equals the CSV's texts read as numbers, exactly."""
    values = np.asarray(column)
    if values.dtype.kind in "iu":
        return [int(v) for v in values] == [int(t) for t in texts]
    if values.dtype.kind == "f":  # float64, or float32 for what the table stores as 32 bits
        return np.array_equal(values, np.array(texts, dtype=values.dtype), equal_nan=True)
    return [str(v) for v in values] == list(texts)


def test_samples_and_events_equal_the_export(recording):
    rec = cariesim.read_recording(recording / "rec.db", pandas=False)
    samples = _csv(recording / "export" / "samples.csv")
    assert list(rec["samples"].keys()) == list(samples[0].keys())
    assert len(rec["samples"]["t"]) == len(samples) > 100
    for name, column in rec["samples"].items():
        assert _same(column, [row[name] for row in samples]), name
    events = _csv(recording / "export" / "events.csv")
    assert list(rec["events"].keys()) == ["t", "kind", "detail", "value", "lesion", "duration"]
    for name, column in rec["events"].items():
        assert _same(column, [row[name] for row in events]), name
    session = _csv(recording / "export" / "session.csv")[0]
    assert rec["session"]["scene"] == session["scene"] == "friction-block"
    assert rec["session"]["rate_hz"] == float(session["rate_hz"])
    assert "sliding" in set(rec["samples"]["state"])


def test_pandas_frames(recording):
    pd = pytest.importorskip("pandas")
    rec = cariesim.read_recording(recording / "rec.db")
    assert isinstance(rec["samples"], pd.DataFrame) and isinstance(rec["events"], pd.DataFrame)
    plain = cariesim.read_recording(recording / "rec.db", pandas=False)
    assert np.array_equal(rec["samples"]["fz"].to_numpy(), plain["samples"]["fz"])


def test_bad_files_raise(tmp_path):
    (tmp_path / "not.db").write_text("hello")
    with pytest.raises(cariesim.Error, match="not.db"):
        cariesim.read_recording(tmp_path / "not.db")
    with pytest.raises(cariesim.Error, match="missing.db"):
        cariesim.read_studies([tmp_path / "missing.db"])
