"""A class's study databases (one per station, `cariesim study run` or trainee mode) read into pandas,
and a learning curve: each score's mean over the participants by trial number (docs/python.md,
"Records"). Usage: class_learning_curve.py OUT_DIR DB..."""
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

import cariesim

out_dir, databases = sys.argv[1], sys.argv[2:]
study = cariesim.read_studies(databases)                   # each trial once, as `cariesim report` counts
trials, scores = study["trials"], study["scores"]
print(trials[["participant", "study", "trial", "finished"]].to_string(index=False))
curve = scores.groupby(["name", "trial"])["value"].mean().unstack("name")
print(curve)
ax = curve.plot(marker="o", figsize=(7, 4), title="Learning curve: mean score by trial")
ax.set_xlabel("trial")
ax.figure.tight_layout()
ax.figure.savefig(os.path.join(out_dir, "learning_curve.png"), dpi=120)
