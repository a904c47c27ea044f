"""The k_c x F_p* sweep (docs/python.md, "Sweeps"): how deep the explorer goes into the friction
block's carious top when pushed down, for each pair of the lesion's penetration
stiffness k_c (N/mm) and insertion threshold F_p* (N), on a process pool; a heat map of the depth.
Usage: kc_fp_sweep.py [OUT_DIR]"""
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import cariesim

QUICK = bool(os.environ.get("CARIESIM_EXAMPLES_QUICK"))
GRID = {
    "lesions[0].material.k_c": [0.2, 0.6, 1.5] if QUICK else [0.2, 0.4, 0.6, 0.9, 1.2, 1.5],
    "lesions[0].material.f_p_star": [1.0, 4.0] if QUICK else [0.25, 0.5, 1.0, 2.0, 4.0],
}


def push(scene):
    """Pushes the explorer straight down 3 mm past the top at 2 mm/s (the coupling's pull grows to
    about 1.5 N), then holds; returns the deepest insertion (mm) and the peak normal force (N)."""
    model = scene.build()
    q = model.tool_home[3:]
    t = np.array([0.0, 0.5, 2.0, 2.5])
    z = np.array([1.0, model.tip_radius, model.tip_radius - 3.0, model.tip_radius - 3.0])
    traj = np.column_stack([t, 0 * t, 0 * t, z, np.tile(q, (4, 1))])
    out = cariesim.Simulator(model, rate=1000.0).run(traj)
    return {"depth_mm": float(out["depth"].max()), "fz_max_N": float(out["fz"].max())}


def heat_map(table, path):
    """The depth over the grid as an image, k_c across, F_p* up."""
    pivot = table.pivot(index="lesions[0].material.f_p_star", columns="lesions[0].material.k_c", values="depth_mm")
    fig, ax = plt.subplots(figsize=(6, 4))
    image = ax.imshow(pivot.to_numpy(), origin="lower", aspect="auto", cmap="viridis")
    ax.set_xticks(range(pivot.shape[1]), [f"{v:g}" for v in pivot.columns])
    ax.set_yticks(range(pivot.shape[0]), [f"{v:g}" for v in pivot.index])
    ax.set_xlabel("k_c (N/mm)")
    ax.set_ylabel("F_p* (N)")
    fig.colorbar(image, label="deepest insertion (mm)")
    fig.tight_layout()
    fig.savefig(path, dpi=120)


if __name__ == "__main__":
    table = cariesim.sweep(push, GRID, scene="friction-block")  # a process pool, one worker per CPU
    print(table.to_string(index=False))
    heat_map(table, os.path.join(sys.argv[1] if len(sys.argv) > 1 else ".", "kc_fp_sweep.png"))
