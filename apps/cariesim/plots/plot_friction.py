# Figure of `cariesim experiment friction` (matplotlib, Debian's python3-matplotlib): run with the
# experiment's output folder as its argument; lists the figures it made in figures_friction.txt.
import csv, glob, os, sys
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

# The frictionless slide over scanned enamel (real arch, 46's buccal surface, 0.6 N, 5 mm/s): the
# tangential force with the sphere pairs' own normals and with force shading (docs/step.md).
path = os.path.join(d, "enamel_slide.csv")
if os.path.exists(path):
    rows = list(csv.DictReader(open(path)))
    f, axes = plt.subplots(2, 1, figsize=(8, 4.5), sharex=True, sharey=True)
    for ax, shaded, label in ((axes[0], "0", "sphere normals (before)"), (axes[1], "1", "force shading (after)")):
        part = [r for r in rows if r["shaded"] == shaded]
        s = [float(r["s_mm"]) for r in part]
        ax.plot(s, [float(r["f_along"]) for r in part], lw=0.8, label="along the slide")
        ax.plot(s, [float(r["f_across"]) for r in part], lw=0.8, label="across the slide")
        ax.set_ylabel("tangential F (N)")
        ax.set_title(label, fontsize=9)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8, loc="upper right")
    axes[-1].set_xlabel("graphic tip along the slide (mm)")
    f.suptitle("Frictionless scanned enamel (46 buccal), 0.6 N, 5 mm/s: tangential force")
    f.tight_layout()
    f.savefig(os.path.join(d, "enamel_ripple.png"), dpi=120)
    made.append("enamel_ripple.png")
    open(os.path.join(d, "figures_friction.txt"), "w").write("\n".join(made) + "\n")
