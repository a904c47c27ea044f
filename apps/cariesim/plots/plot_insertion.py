# Figure of `cariesim experiment insertion` (matplotlib, Debian's python3-matplotlib): run with the
# experiment's output folder as its argument; lists the figures it made in figures_insertion.txt.
import csv, os, sys
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

# The k_c sweep (docs/penetration.md): felt axial force against apex depth at 2 mm/s.
figures = ["fig14_insertion.png"]
sweep = os.path.join(d, "kc_sweep.csv")
if os.path.exists(sweep):
    runs = {}
    for r in csv.DictReader(open(sweep)):
        runs.setdefault(r["name"], ([], []))
        runs[r["name"]][0].append(float(r["depth"]))
        runs[r["name"]][1].append(float(r["f_axial"]))
    f, ax = plt.subplots(figsize=(8, 5))
    for name, (depth, force) in runs.items():
        style = "--" if "preset" in name else "-"
        ax.plot(depth, force, style, lw=1.2, label=name)
    ax.set_xlabel("apex depth in the lesion (mm)")
    ax.set_ylabel("felt axial force (N)")
    ax.set_title("Insertion at 2 mm/s: force against depth (k_c sweep, presets, layers, gradient)")
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    f.tight_layout()
    f.savefig(os.path.join(d, "kc_sweep.png"), dpi=120)
    figures.append("kc_sweep.png")
open(os.path.join(d, "figures_insertion.txt"), "w").write("".join(x + "\n" for x in figures))
