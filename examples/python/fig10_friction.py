"""Fig. 10 of the paper: the friction force as mu_s changes (mu_d 0.3), sliding 0.59 mm deep along
the friction block's carious top at 10 mm/s (docs/python.md). Usage: fig10_friction.py [OUT_DIR]"""
import os, sys
import matplotlib; matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import cariesim

model = cariesim.load_scene("friction-block").build()
q = model.tool_home[3:]                                   # the scene's explorer posture
z = model.tip_radius - 0.59                                # tip centre: the tip 0.59 mm under z = 0
slide = 3.0 if not os.environ.get("CARIESIM_EXAMPLES_QUICK") else 0.6  # s at 10 mm/s
t = np.array([0.0, 0.5, 0.5 + slide, 1.0 + slide])
x = np.array([-15.0, -15.0, -15.0 + 10.0 * slide, -15.0 + 10.0 * slide])
traj = np.column_stack([t, x, 0 * t, [2.0, z, z, 2.0], np.tile(q, (4, 1))])
fig, axes = plt.subplots(4, 1, figsize=(8, 8), sharex=True)
for ax, mu_s in zip(axes, [0.2, 0.4, 0.6, 0.8]):
    sim = cariesim.Simulator(model, rate=1000.0)
    sim.params.set(0, "mu_s", mu_s); sim.params.set(0, "mu_d", 0.3)
    out = sim.run(traj)
    ax.plot(out["t"], out["fx"], lw=0.8); ax.set_ylabel("F_x (N)"); ax.set_title(f"mu_s {mu_s}, mu_d 0.3")
axes[-1].set_xlabel("t (s)"); fig.suptitle("Fig. 10: friction force as mu_s changes"); fig.tight_layout()
fig.savefig(os.path.join(sys.argv[1] if len(sys.argv) > 1 else ".", "fig10.png"), dpi=120)
