// Figure scripts for the experiments (matplotlib, from Debian's python3-matplotlib). Each is written
// next to the data as plot_<name>.py, so a researcher can re-run or edit it; it takes the folder as
// its argument and lists the figures it made in figures_<name>.txt.
#include "experiment/common.hpp"

namespace cariesim::experiment {

const std::string_view kFrictionPlot = R"PY(import csv, glob, os, sys
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt

d = sys.argv[1]
made = []
for group, fig, title in (("static", "fig10_static_friction.png", "Fig. 10: friction force as mu_s changes (mu_d = 0.3)"),
                          ("dynamic", "fig11_dynamic_friction.png", "Fig. 11: friction force as mu_d changes (mu_s = 0.5)")):
    files = sorted(glob.glob(os.path.join(d, "friction_%s_*.csv" % group)))
    if not files:
        continue
    f, axes = plt.subplots(len(files), 1, figsize=(8, 2.0 * len(files)), sharex=True, squeeze=False)
    for ax, path in zip(axes[:, 0], files):
        rows = list(csv.DictReader(open(path)))
        t = [float(r["t"]) for r in rows]
        fx = [float(r["fx"]) for r in rows]
        label = os.path.basename(path)[len("friction_%s_" % group):-4].replace("mus", "mu_s ").replace("_mud", ", mu_d ")
        ax.plot(t, fx, lw=0.8)
        ax.set_ylabel("F_x (N)")
        ax.set_title(label, fontsize=9)
        ax.grid(alpha=0.3)
    axes[-1, 0].set_xlabel("t (s)")
    f.suptitle(title)
    f.tight_layout()
    f.savefig(os.path.join(d, fig), dpi=120)
    made.append(fig)
open(os.path.join(d, "figures_friction.txt"), "w").write("\n".join(made) + "\n")
)PY";

const std::string_view kBoundaryPlot = R"PY(import csv, glob, os, sys
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
)PY";

const std::string_view kInsertionPlot = R"PY(import csv, os, sys
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt

d = sys.argv[1]
rows = list(csv.DictReader(open(os.path.join(d, "insertion.csv"))))
t = [float(r["t"]) for r in rows]
names = ["no contact", "contact", "insertion", "insertion + contact", "extraction", "free"]
colors = ["#eeeeee", "#cfe8ff", "#ffe0b3", "#ffc2c2", "#d6f5d6", "#eeeeee"]
f, (a1, a2) = plt.subplots(2, 1, figsize=(9, 6), sharex=True)
start = 0
for i in range(1, len(rows) + 1):
    if i == len(rows) or rows[i]["phase"] != rows[start]["phase"]:
        p = int(float(rows[start]["phase"]))
        for ax in (a1, a2):
            ax.axvspan(t[start], t[i - 1], color=colors[p], lw=0)
        a1.text(0.5 * (t[start] + t[i - 1]), 0.2, names[p], ha="center", fontsize=7, rotation=90)
        start = i
a1.plot(t, [float(r["depth"]) for r in rows], "k", lw=1.2, label="insertion depth")
a1.plot(t, [float(r["haptic_apex_depth"]) for r in rows], "b--", lw=0.8, label="haptic tip depth")
a1.set_ylabel("depth (mm)")
a1.legend(fontsize=8)
a2.plot(t, [float(r["f_z"]) for r in rows], "r", lw=1.0, label="F along the axis")
a2.set_ylabel("F_z (N)")
a2.set_xlabel("t (s)")
a2.axhline(0, color="k", lw=0.5)
a2.legend(fontsize=8)
f.suptitle("Fig. 14: insertion and extraction with an additional contact")
f.tight_layout()
f.savefig(os.path.join(d, "fig14_insertion.png"), dpi=120)
open(os.path.join(d, "figures_insertion.txt"), "w").write("fig14_insertion.png\n")
)PY";

const std::string_view kOralPlot = R"PY(import csv, glob, os, sys
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
)PY";

}  // namespace cariesim::experiment
