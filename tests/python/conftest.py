"""Shared fixtures of the Python tests (run by ctest, label `python`): the `cariesim` program, a tree
cache per session, and trajectories."""

import os
import pathlib
import subprocess

import numpy as np
import pytest


@pytest.fixture(scope="session", autouse=True)
def tree_cache(tmp_path_factory):
    """Every build of the session (and of the processes it starts) shares one scratch tree cache."""
    folder = tmp_path_factory.mktemp("cache")
    os.environ["CARIESIM_CACHE_DIR"] = str(folder)
    return folder


@pytest.fixture(scope="session")
def cariesim_exe():
    """The `cariesim` program of this build (ctest passes it)."""
    exe = os.environ.get("CARIESIM_EXE")
    if not exe:
        pytest.skip("CARIESIM_EXE is not set (ctest sets it)")
    return exe


def run_cariesim(exe, *args):
    """Runs `cariesim ARGS` (no shell); returns the CompletedProcess, failing the test on an error."""
    r = subprocess.run([exe, *map(str, args)], capture_output=True, text=True)
    assert r.returncode == 0, f"cariesim {' '.join(map(str, args))}: {r.stderr}"
    return r


def press_and_slide(duration=0.2, depth=0.6):
    """A trajectory array (N x 8) over the friction block: down onto the carious top, then along x."""
    t = np.linspace(0.0, duration, 21)
    x = np.where(t < duration / 3, -20.0, -20.0 + 8.0 * (t - duration / 3))
    z = np.where(t < duration / 3, 1.0 - (1.0 + depth) * t / (duration / 3), -depth)
    # The friction block's home posture (-50 degrees about y: the handle rising toward +x).
    angle = np.deg2rad(-50.0)
    q = np.array([np.cos(angle / 2), 0.0, np.sin(angle / 2), 0.0])
    return np.column_stack([t, x, np.zeros_like(t), z, np.tile(q, (t.size, 1))])


def write_trajectory(path, traj):
    """A trajectory array as the CSV `cariesim sim` reads, each number in its shortest exact form."""
    lines = ["t,px,py,pz,qw,qx,qy,qz"] + [",".join(repr(float(v)) for v in row) for row in traj]
    pathlib.Path(path).write_text("\n".join(lines) + "\n")
