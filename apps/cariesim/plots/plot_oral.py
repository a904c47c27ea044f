# Figure of `cariesim experiment oral` (matplotlib, Debian's python3-matplotlib): run with the
# experiment's output folder as its argument; lists the figures it made in figures_oral.txt.
import csv, glob, os, sys
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt

d = sys.argv[1]
colors = {"free": "#999999", "sliding": "#1f77b4", "inserting": "#d62728", "extracting": "#2ca02c"}
files = sorted(glob.glob(os.path.join(d, "oral_lesion*.csv")))
f, axes = plt.subplots(len(files), 1, figsize=(9, 2.6 * len(files)), squeeze=False)
for ax, path in zip(axes[:, 0], files):
    rows = list(csv.DictReader(open(path)))
    t = [float(r["t"]) for r in rows]
    fn = [float(r["normal_force"]) for r in rows]
    st = [r["state"] for r in rows]
    for name, c in colors.items():
        ax.scatter([x for x, s in zip(t, st) if s == name], [y for y, s in zip(fn, st) if s == name], s=1, c=c, label=name)
    ax2 = ax.twinx()
    ax2.plot(t, [float(r["depth"]) for r in rows], "k", lw=0.8)
    ax2.set_ylabel("depth (mm)")
    ax.set_ylabel("normal force (N)")
    ax.set_title(os.path.basename(path)[len("oral_"):-4].replace("_", " "), fontsize=9)
    ax.grid(alpha=0.3)
axes[0, 0].legend(fontsize=7, markerscale=6, loc="upper left")
axes[-1, 0].set_xlabel("t (s)")
f.suptitle("Fig. 16: normal force over the interaction states")
f.tight_layout()
f.savefig(os.path.join(d, "fig16_oral.png"), dpi=120)
open(os.path.join(d, "figures_oral.txt"), "w").write("fig16_oral.png\n")
