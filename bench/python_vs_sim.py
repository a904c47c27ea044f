#!/usr/bin/env python3
"""Simulator.run through Python against `cariesim sim` on the same 10 000-step trajectory
(docs/python.md, "Speed"): medians and percentiles of both, over repeated runs.

    PYTHONPATH=build/python /usr/bin/python3 bench/python_vs_sim.py [--exe build/apps/cariesim] [--runs 15]

Measured: `cariesim sim` end to end (a process: start, scene, model from the tree cache, the run,
the CSV), Python's load + build (tree cache) + run, and Simulator.run alone; the run both call is
bench/sim_run_bench.cpp's. Also `--set`-free: the friction block as shipped.
"""

import argparse
import os
import pathlib
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

import cariesim


def trajectory(steps=10000, rate=1000.0):
    """Down onto the carious top, then along it and back (bench/sim_run_bench.cpp's)."""
    span = (steps - 1) / rate
    time_s = np.linspace(0.0, span, 101)
    phase = time_s / span
    z = np.where(phase < 0.05, 1.0 - 1.6 * phase / 0.05, -0.6)
    x = -20.0 + 15.0 * np.sin(np.pi * np.maximum(0.0, phase - 0.05))
    angle = np.deg2rad(-50.0)
    q = np.tile([np.cos(angle / 2), 0.0, np.sin(angle / 2), 0.0], (time_s.size, 1))
    return np.column_stack([time_s, x, np.zeros_like(x), z, q])


def summary(name, samples):
    """One line: median and percentiles in ms."""
    ms = np.array(samples) * 1e3
    p = np.percentile(ms, [10, 90])
    print(f"{name:38s} median {np.median(ms):8.2f} ms   p10 {p[0]:8.2f}   p90 {p[1]:8.2f}   "
          f"min {ms.min():8.2f}   (n={ms.size})")
    return float(np.median(ms))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--exe", default=str(pathlib.Path(__file__).resolve().parent.parent / "build/apps/cariesim"))
    parser.add_argument("--runs", type=int, default=15)
    args = parser.parse_args()

    traj = trajectory()
    with tempfile.TemporaryDirectory(prefix="cariesim-bench-") as folder:
        folder = pathlib.Path(folder)
        lines = ["t,px,py,pz,qw,qx,qy,qz"] + [",".join(repr(float(v)) for v in row) for row in traj]
        (folder / "traj.csv").write_text("\n".join(lines) + "\n")
        command = [args.exe, "sim", "--scene", "friction-block", "--trajectory", str(folder / "traj.csv"),
                   "--out", str(folder / "out.csv"), "--quiet"]
        subprocess.run(command, check=True)  # fills the tree cache
        model = cariesim.load_scene("friction-block").build()
        sim = cariesim.Simulator(model)
        steps = sim.run(traj).shape[0]

        cli, full, run = [], [], []
        for _ in range(args.runs):
            start = time.perf_counter()
            subprocess.run(command, check=True)
            cli.append(time.perf_counter() - start)
            start = time.perf_counter()
            cariesim.Simulator(cariesim.load_scene("friction-block").build()).run(traj)
            full.append(time.perf_counter() - start)
            start = time.perf_counter()
            sim.run(traj)
            run.append(time.perf_counter() - start)

    print(f"{steps} steps at {sim.rate:g} Hz on friction-block, {args.runs} runs each")
    m_cli = summary("cariesim sim (process, build, CSV)", cli)
    m_full = summary("python: load + build + run", full)
    m_run = summary("python: Simulator.run", run)
    print(f"python load+build+run / cariesim sim: {m_full / m_cli:.3f}; Simulator.run / cariesim sim: "
          f"{m_run / m_cli:.3f}")


if __name__ == "__main__":
    sys.exit(main())
