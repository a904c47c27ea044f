"""Functions the sweep tests send to other processes (importable there: ctest puts this folder on
PYTHONPATH)."""

import cariesim
from conftest import press_and_slide


def peak_forces(scene):
    """Peak normal and friction force (N) of a press-and-slide on the scene's carious top."""
    out = cariesim.Simulator(scene.build()).run(press_and_slide())
    return {"fz_max": float(out["fz"].max()), "fx_min": float(out["fx"].min()), "steps": int(out.shape[0])}


def square(point):
    """A function of the point itself (a sweep without a scene)."""
    return point["x"] * point["x"]
