"""The Simulator against `cariesim sim`: the same values on the same trajectory; arrays checked row
by row; the GIL released while it runs."""

import csv
import threading
import time

import numpy as np
import pytest

import cariesim
from conftest import press_and_slide, run_cariesim, write_trajectory

# Decimals `cariesim sim` writes per column (SimCsvWriter, experiment/simulate.cpp).
QUATERNION_COLUMNS = {f"{p}_q{c}" for p in "hg" for c in "wxyz"}


def _sim_csv(exe, tmp_path, traj, *args):
    write_trajectory(tmp_path / "traj.csv", traj)
    run_cariesim(exe, "sim", "--scene", "friction-block", "--trajectory", tmp_path / "traj.csv",
                 "--out", tmp_path / "out.csv", "--quiet", *args)
    with open(tmp_path / "out.csv", newline="") as f:
        return list(csv.DictReader(f))


def _as_csv_text(name, value):
    """A value as sim's CSV writes that column."""
    if name == "state":
        return str(value)
    if name == "contacts":
        return str(int(value))
    return f"{value:.{9 if name in QUATERNION_COLUMNS else 6}f}"


def test_run_equals_cariesim_sim(cariesim_exe, tmp_path):
    traj = press_and_slide()
    rows = _sim_csv(cariesim_exe, tmp_path, traj, "--rate", "2000")
    out = cariesim.Simulator(cariesim.load_scene("friction-block").build(), rate=2000.0).run(traj)
    assert out.dtype.names == tuple(rows[0].keys())
    assert out.shape == (len(rows),)
    states = set(out["state"])
    assert "sliding" in states, states  # the run touches the block
    for name in out.dtype.names:
        if name == "step_us":  # wall time, differs between any two runs
            continue
        ours = [_as_csv_text(name, v) for v in out[name]]
        theirs = [row[name] for row in rows]
        assert ours == theirs, name
    # CSV zero may print as -0.000000 on one side only if the values differ; the texts are equal.


def test_overrides_and_params_change_the_run(cariesim_exe, tmp_path):
    traj = press_and_slide()
    scene = cariesim.load_scene("friction-block")
    key = "lesions[0].material.stiffness"
    rows = _sim_csv(cariesim_exe, tmp_path, traj, "--set", f"{key}=2.5")
    out = cariesim.Simulator(scene.with_overrides({key: 2.5}).build()).run(traj)
    assert [_as_csv_text("fz", v) for v in out["fz"]] == [r["fz"] for r in rows]
    plain = cariesim.Simulator(scene.build()).run(traj)
    pressing = out["t"] > 0.1  # pressed in and sliding
    assert out["fz"][pressing].mean() > 1.1 * plain["fz"][pressing].mean() > 0.05
    # Params set on the simulator are what run() uses.
    sim = cariesim.Simulator(scene.build())
    sim.params.set(0, "stiffness", 2.5)
    assert np.array_equal(sim.run(traj)["fz"], out["fz"])


def test_step_carries_the_state():
    model = cariesim.load_scene("friction-block").build()
    sim = cariesim.Simulator(model, rate=1000.0)
    traj = press_and_slide()
    first = sim.step(traj[0, 1:])
    assert first.dtype == cariesim.sim_dtype() and first["t"][0] == 0.0
    for row in traj[1:]:
        last = sim.step(row[1:])
    assert sim.steps == traj.shape[0]
    assert last["t"][0] == pytest.approx((traj.shape[0] - 1) / 1000.0)
    assert last["state"][0] in cariesim.STATE_NAMES
    sim.reset()
    assert sim.steps == 0


@pytest.mark.parametrize("make, row, words", [
    (lambda t: t[:, :7], None, "expected an N×8 array"),
    (lambda t: t[0], None, "expected an N×8 array"),
    (lambda t: t[:0], None, "no rows"),
    (lambda t: _set(t, 5, 2, np.nan), 5, "column 'py' is not finite"),
    (lambda t: _set(t, 7, 4, 2.0), 7, "a unit quaternion is expected"),
    (lambda t: _set(t, 3, 0, 0.0), 3, "does not increase"),
])
def test_bad_arrays_are_refused_with_their_row(make, row, words):
    sim = cariesim.Simulator(cariesim.load_scene("friction-block").build())
    with pytest.raises(cariesim.Error) as info:
        sim.run(make(press_and_slide()))
    assert words in str(info.value)
    assert info.value.row == row
    with pytest.raises(cariesim.Error, match="a unit quaternion is expected"):
        sim.step([0, 0, 5, 1, 1, 0, 0])
    with pytest.raises(cariesim.Error, match="pose of 7 numbers"):
        sim.step([0, 0, 5])


def _set(traj, row, column, value):
    traj = traj.copy()
    traj[row, column] = value
    return traj


def test_run_releases_the_gil():
    sim = cariesim.Simulator(cariesim.load_scene("friction-block").build(), rate=1000.0)
    traj = press_and_slide(duration=20.0)
    # How fast this loop spins with the GIL to itself.
    calibration, start = 0, time.perf_counter()
    while time.perf_counter() - start < 0.05:
        calibration += 1
    rate = calibration / (time.perf_counter() - start)
    inside = threading.Event()
    done = threading.Event()

    def worker():
        inside.set()
        sim.run(traj)
        done.set()

    thread = threading.Thread(target=worker)
    thread.start()
    inside.wait()
    ticks = 0
    start = time.perf_counter()
    while not done.is_set():
        time.perf_counter()
        ticks += 1
    elapsed = time.perf_counter() - start
    thread.join()
    # Held, the GIL would stop this loop for the whole run (but a switch interval or two); released,
    # it spins all along (a tenth of its speed allows for a busy machine).
    assert elapsed > 0.1, elapsed
    assert ticks > 0.1 * rate * elapsed, (ticks, rate, elapsed)
