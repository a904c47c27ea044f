"""The paper's experiments (docs/cli.md, `cariesim experiment`): each run by the library into a
folder, returned as its summary and its arrays."""

import csv
import json
import os
import pathlib
import shutil
import subprocess
import sys
import tempfile

import numpy as np

from . import _cariesim
from ._scene import format_value


def experiment_names():
    """The experiments, in the order `all` runs them."""
    return list(_cariesim.experiment_names())


def _read_csv(path):
    """A CSV of the experiments as a structured array: numeric columns as float, the rest as text."""
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    if not rows:
        return np.zeros(0)
    header, body = rows[0], rows[1:]
    columns = []
    for j, name in enumerate(header):
        values = [r[j] if j < len(r) else "" for r in body]
        try:
            columns.append(np.array([float(v) for v in values], dtype=float))
        except ValueError:
            columns.append(np.array(values, dtype=str))
    return np.rec.fromarrays(columns, names=[h.strip() for h in header]) if body else np.zeros(0)


def _draw(out, name):
    """Runs the experiment's figure script (the one `cariesim experiment` runs) on its folder."""
    script = pathlib.Path(__file__).parent / "plots" / f"plot_{name}.py"
    subprocess.run([sys.executable, str(script), str(out)], check=True, stdout=subprocess.DEVNULL)
    listing = pathlib.Path(out) / f"figures_{name}.txt"
    figures = listing.read_text().split() if listing.exists() else []
    listing.unlink(missing_ok=True)
    return figures


def run_experiment(name, out=None, rate=1000.0, overrides=None, figures=False):
    """Runs one experiment ("friction", "boundary", "insertion", "oral") into `out` (a temporary
    folder, removed afterwards, when None) and returns {"summary": dict, "arrays": {csv stem:
    structured array}, "figures": [files], "out": folder or None}. `overrides` apply to the
    experiment's scene; figures (matplotlib) are drawn only when asked. The GIL is released while it
    runs."""
    pairs = [(str(k), format_value(v)) for k, v in (overrides or {}).items()]
    keep = out is not None
    folder = pathlib.Path(out) if keep else pathlib.Path(tempfile.mkdtemp(prefix="cariesim-experiment-"))
    try:
        summary = json.loads(_cariesim.run_experiment(name, str(folder), float(rate), pairs))
        arrays = {p.stem: _read_csv(p) for p in sorted(folder.glob("*.csv"))}
        drawn = _draw(folder, name) if figures else []
        return {"summary": summary, "arrays": arrays, "figures": drawn, "out": str(folder) if keep else None}
    finally:
        if not keep:
            shutil.rmtree(folder, ignore_errors=True)


def friction(**kwargs):
    """Figs. 9-11: sliding with friction on the friction block (run_experiment("friction", ...))."""
    return run_experiment("friction", **kwargs)


def boundary(**kwargs):
    """Figs. 12-13: lesion boundaries felt by sliding across them."""
    return run_experiment("boundary", **kwargs)


def insertion(**kwargs):
    """Figs. 14-15: insertion and extraction, with the k_c sweep."""
    return run_experiment("insertion", **kwargs)


def oral(**kwargs):
    """Fig. 16: probing the oral cavity's hidden lesions."""
    return run_experiment("oral", **kwargs)
