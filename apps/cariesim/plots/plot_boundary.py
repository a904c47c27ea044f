# Figure of `cariesim experiment boundary` (matplotlib, Debian's python3-matplotlib): run with the
# experiment's output folder as its argument; lists the figures it made in figures_boundary.txt.
import csv, glob, os, sys
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt

d = sys.argv[1]
files = sorted(glob.glob(os.path.join(d, "boundary_*.csv")))
f, axes = plt.subplots(len(files), 1, figsize=(8, 2.2 * len(files)), squeeze=False)
for ax, path in zip(axes[:, 0], files):
    rows = list(csv.DictReader(open(path)))
    hx = [float(r["h_x_from_border"]) for r in rows]
    gx = [float(r["g_x_from_border"]) for r in rows]
    fx = [float(r["fx"]) for r in rows]
    ax.plot(hx, fx, lw=0.8, label="F_x vs haptic x")
    ax.plot(gx, fx, lw=0.8, alpha=0.6, label="F_x vs graphic x")
    ax.axvline(0.0, color="k", ls="--", lw=0.8)
    ax.set_title(os.path.basename(path)[len("boundary_"):-4].replace("_", " "), fontsize=9)
    ax.set_ylabel("F_x (N)")
    ax.grid(alpha=0.3)
axes[0, 0].legend(fontsize=8)
axes[-1, 0].set_xlabel("x from the boundary (mm); caries on the + side")
f.suptitle("Fig. 12: tangential force across the boundary")
f.tight_layout()
f.savefig(os.path.join(d, "fig12_boundary.png"), dpi=120)
open(os.path.join(d, "figures_boundary.txt"), "w").write("fig12_boundary.png\n")
