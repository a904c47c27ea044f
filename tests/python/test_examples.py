"""The examples of examples/python and the code of docs/python.md run as written (quick settings:
CARIESIM_EXAMPLES_QUICK=1, smaller grids and shorter runs)."""

import os
import pathlib
import re
import subprocess
import sys

import pytest

from conftest import run_cariesim

SOURCE = pathlib.Path(os.environ.get("CARIESIM_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[2]))
EXAMPLES = SOURCE / "examples" / "python"


def _run_example(name, *args):
    env = dict(os.environ, CARIESIM_EXAMPLES_QUICK="1",
               PYTHONPATH=os.pathsep.join([str(EXAMPLES), os.environ.get("PYTHONPATH", "")]))
    r = subprocess.run([sys.executable, str(EXAMPLES / name), *map(str, args)], capture_output=True, text=True,
                       env=env, cwd=EXAMPLES)
    assert r.returncode == 0, f"{name}: {r.stdout}\n{r.stderr}"
    return r.stdout


def test_fig10(tmp_path):
    _run_example("fig10_friction.py", tmp_path)
    assert (tmp_path / "fig10.png").stat().st_size > 10000


def test_kc_fp_sweep_on_a_process_pool_and_on_dask(tmp_path):
    pooled = _run_example("kc_fp_sweep.py", tmp_path)
    clustered = _run_example("dask_sweep.py", tmp_path)
    assert (tmp_path / "kc_fp_sweep.png").exists() and (tmp_path / "dask_sweep.png").exists()
    assert pooled == clustered  # the same table either way
    # Softer, easier lesions let the explorer in deeper: the table says so.
    rows = [line.split() for line in pooled.strip().splitlines()[1:]]
    depth = {(float(r[0]), float(r[1])): float(r[2]) for r in rows}
    assert depth[(0.2, 1.0)] > depth[(1.5, 4.0)]


def test_class_learning_curve(tmp_path, cariesim_exe):
    answers = tmp_path / "answers.yaml"
    answers.write_text("trials:\n  - shapes: [square, circle, triangle]\n  - shapes: [circle, square, triangle]\n")
    study = SOURCE / "studies" / "examples" / "boundary-small.yaml"
    for participant, station in (("P01", "s1"), ("P02", "s2")):
        run_cariesim(cariesim_exe, "study", "run", study, "--participant", participant, "--station", station,
                     "--answers", answers, "--duration", "0.05", "--quiet", "--out", tmp_path / f"{station}.db")
    out = _run_example("class_learning_curve.py", tmp_path, tmp_path / "s1.db", tmp_path / "s2.db")
    assert "P01" in out and "P02" in out
    assert (tmp_path / "learning_curve.png").exists()


def test_the_docs_code_runs(tmp_path, monkeypatch):
    text = (SOURCE / "docs" / "python.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, re.S)
    assert len(blocks) >= 4
    monkeypatch.chdir(tmp_path)
    namespace = {"__name__": "__docs__"}
    for block in blocks:
        exec(compile(block, "docs/python.md", "exec"), namespace)  # noqa: S102 (the docs' own code)
