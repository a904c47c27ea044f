# Figures of `cariesim report` (matplotlib, Debian's python3-matplotlib): run with the report's folder
# as its argument; reads the tables' CSV files there and lists the figures it made in
# figures_report.txt. A figure whose tables are empty is not drawn.
import csv, os, sys
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
from matplotlib.ticker import MaxNLocator

d = sys.argv[1]
made = []


def rows(name):
    path = os.path.join(d, name + ".csv")
    return list(csv.DictReader(open(path))) if os.path.exists(path) else []


def num(text):
    return float(text) if text not in ("", None) else None


def save(fig, name):
    fig.tight_layout()
    fig.savefig(os.path.join(d, name), dpi=100)
    plt.close(fig)
    made.append(name)


# Tables 1-2: per participant and the cohort, mild against severe, mean ± SD (error bars).
tuning = [("table1_roughness", "mu_s", "μs"), ("table1_roughness", "mu_d", "μd"),
          ("table2_stiffness", "k_c", "k_c (N/mm)"), ("table2_stiffness", "k_e", "k_e (N/mm)")]
panels = [(t, k, label, rows(t)) for t, k, label in tuning]
panels = [p for p in panels if p[3]]
if panels:
    fig, axes = plt.subplots(1, len(panels), figsize=(3.6 * len(panels), 3.4), squeeze=False)
    for ax, (table, key, label, data) in zip(axes[0], panels):
        names = [r["participant"] for r in data]
        x = range(len(names))
        for offset, level, colour in ((-0.18, "mild", "tab:blue"), (0.18, "severe", "tab:red")):
            means = [num(r[level + "_" + key + "_mean"]) for r in data]
            sds = [num(r[level + "_" + key + "_sd"]) or 0.0 for r in data]
            xs = [i + offset for i, m in zip(x, means) if m is not None]
            ys = [m for m in means if m is not None]
            es = [s for s, m in zip(sds, means) if m is not None]
            ax.bar(xs, ys, width=0.34, yerr=es, capsize=3, color=colour, alpha=0.8, label=level)
        ax.set_xticks(list(x))
        ax.set_xticklabels(names, rotation=30, ha="right", fontsize=8)
        ax.set_title(label)
        ax.grid(axis="y", alpha=0.3)
    axes[0][0].legend(fontsize=8)
    fig.suptitle("Tuned values (Tables 1-2): mean ± SD per participant; cohort = mean ± SD of the means",
                 fontsize=9)
    save(fig, "report-tuning.png")

# Boundary shapes: points per participant (per 10 trials) and each shape's share named right.
boundary = [r for r in rows("boundary") if r["participant"] != "cohort"]
if boundary:
    shapes = [k[len("shape_"):-len("_mean")] for k in boundary[0] if k.startswith("shape_") and k.endswith("_mean")]
    fig, (left, right) = plt.subplots(1, 2, figsize=(10, 3.4))
    names = [r["participant"] for r in boundary]
    left.bar(range(len(names)), [num(r["points_per_10_mean"]) for r in boundary], color="tab:green")
    cohort = [r for r in rows("boundary") if r["participant"] == "cohort"]
    if cohort and num(cohort[0]["points_per_10_mean"]) is not None:
        m = num(cohort[0]["points_per_10_mean"])
        sd = num(cohort[0]["points_per_10_sd"])
        left.axhline(m, color="k", ls="--", lw=1,
                     label="cohort %.2f" % m + (" ± %.2f" % sd if sd is not None else ""))
        left.legend(fontsize=8)
    left.set_xticks(range(len(names)))
    left.set_xticklabels(names, rotation=30, ha="right", fontsize=8)
    left.set_ylim(0, 10.5)
    left.set_ylabel("points per 10 trials")
    left.set_title("Boundary score (all three shapes right)")
    width = 0.8 / max(1, len(shapes))
    for i, shape in enumerate(shapes):
        vals = [num(r["shape_" + shape + "_mean"]) for r in boundary]
        right.bar([j - 0.4 + width * (i + 0.5) for j in range(len(names))], [v or 0.0 for v in vals],
                  width=width, label=shape)
    right.set_xticks(range(len(names)))
    right.set_xticklabels(names, rotation=30, ha="right", fontsize=8)
    right.set_ylim(0, 1.2)
    right.set_ylabel("share of trials named right")
    right.set_title("Per shape")
    right.legend(fontsize=8, ncol=len(shapes), loc="upper center")
    for ax in (left, right):
        ax.grid(axis="y", alpha=0.3)
    save(fig, "report-boundary.png")

# Diagnosis: detection rate and time to detection per participant.
diagnosis = [r for r in rows("diagnosis") if r["participant"] != "cohort"]
if diagnosis:
    fig, (left, right) = plt.subplots(1, 2, figsize=(10, 3.4))
    names = [r["participant"] for r in diagnosis]
    x = list(range(len(names)))
    left.bar(x, [num(r["detection_rate_mean"]) or 0.0 for r in diagnosis],
             yerr=[num(r["detection_rate_sd"]) or 0.0 for r in diagnosis], capsize=3, color="tab:purple")
    left.set_ylim(0, 1.05)
    left.set_ylabel("detection rate")
    left.set_title("Lesions found (mean ± SD over cases)")
    # A severity is drawn (and named in the legend) only where someone found a lesion of it; a
    # participant without such a time gets no bar, not a bar of height 0.
    for offset, key, colour in ((-0.18, "time_to_detection_mild_s", "tab:blue"),
                                (0.18, "time_to_detection_severe_s", "tab:red")):
        pts = [(i + offset, num(r[key + "_mean"]), num(r[key + "_sd"]) or 0.0)
               for i, r in zip(x, diagnosis) if num(r[key + "_mean"]) is not None]
        if pts:
            right.bar([p[0] for p in pts], [p[1] for p in pts], yerr=[p[2] for p in pts], width=0.34,
                      capsize=3, color=colour, label=key.split("_")[-2])
    right.set_ylabel("time to detection (s)")
    right.set_title("Time to detection by severity")
    right.axhline(30, color="k", ls=":", lw=1, label="expert: under 30 s (§5.3)")
    right.legend(fontsize=8)
    for ax in (left, right):
        ax.set_xticks(x)
        ax.set_xticklabels(names, rotation=30, ha="right", fontsize=8)
        ax.grid(axis="y", alpha=0.3)
    save(fig, "report-diagnosis.png")

# The case pictures: per trainee, each case seen from above: the teeth's outlines (from the scene's
# meshes), the case's lesions (circles the lesion's size: blue mild, red severe; filled when found,
# hollow when missed) and the marks (+ mild, x severe; green found a lesion, grey again on a found one,
# black false). One figure per trainee, one small panel per case.
outline_rows = rows("case_outlines")
point_rows = rows("case_points")
if point_rows:
    from matplotlib.patches import Circle, Polygon
    teeth = {}
    for r in outline_rows:
        teeth.setdefault(r["study"], {}).setdefault(r["tooth"], []).append((num(r["x_mm"]), num(r["y_mm"])))
    trainees = []
    for r in point_rows:
        if r["participant"] not in trainees:
            trainees.append(r["participant"])
    severity_colour = {"mild": "tab:blue", "severe": "tab:red"}
    mark_colour = {"found": "tab:green", "again": "0.5", "false": "k"}
    for number, who in enumerate(trainees, 1):
        mine = [r for r in point_rows if r["participant"] == who]
        cases = []
        for r in mine:
            if (r["study"], r["case"]) not in cases:
                cases.append((r["study"], r["case"]))
        cols = min(3, len(cases))
        nrows = (len(cases) + cols - 1) // cols
        fig, axes = plt.subplots(nrows, cols, figsize=(4.6 * cols, 4.0 * nrows + 0.4), squeeze=False)
        for ax, (study, case) in zip(axes.flat, cases):
            for outline in teeth.get(study, {}).values():
                ax.add_patch(Polygon(outline, closed=True, facecolor="0.93", edgecolor="0.6", lw=0.6))
            here = [r for r in mine if r["study"] == study and r["case"] == case]
            lesions = [r for r in here if r["what"] == "lesion"]
            marks = [r for r in here if r["what"] == "mark"]
            for r in lesions:
                colour = severity_colour.get(r["grade"], "tab:purple")
                found = r["result"] == "found"
                ax.add_patch(Circle((num(r["x_mm"]), num(r["y_mm"])), max(0.6, (num(r["size_mm"]) or 1.2) / 2),
                                    facecolor=colour if found else "none", edgecolor=colour, lw=1.5,
                                    alpha=0.6 if found else 1.0))
            for r in marks:
                ax.plot([num(r["x_mm"])], [num(r["y_mm"])], ls="none",
                        marker="+" if r["grade"] == "mild" else "x", ms=8, mew=2,
                        color=mark_colour.get(r["result"], "k"))
            found = sum(1 for r in lesions if r["result"] == "found")
            false = sum(1 for r in marks if r["result"] == "false")
            title = "case %s: " % case
            title += ("%d of %d found" % (found, len(lesions))) if lesions else "lesions not drawn"
            ax.set_title(title + (", %d false" % false if false else ""), fontsize=8)
            ax.set_aspect("equal")
            ax.autoscale_view()
            ax.tick_params(labelsize=6)
        for ax in list(axes.flat)[len(cases):]:
            ax.axis("off")
        fig.suptitle("%s: each case from above (circles: lesions, blue mild, red severe, filled when found; "
                     "marks: + mild, x severe, green found, black false)" % who.replace("$", r"\$"), fontsize=8)
        save(fig, "report-cases-%d.png" % number)

# Learning curves: each participant's scores per trial in time order, one panel per kind and score.
# Up to kFewLines participants share a panel (each line its own colour and marker); with more, each
# score gets small multiples: one small panel per participant, the others faint grey behind.
kFewLines = 6
curve = rows("learning_curve")
if curve:
    panels = []
    for r in curve:
        if (r["kind"], r["score"]) not in panels:
            panels.append((r["kind"], r["score"]))
    people = sorted({r["participant"] for r in curve})

    def series(kind, score, who):
        pts = [(int(r["index"]), float(r["value"])) for r in curve
               if r["kind"] == kind and r["score"] == score and r["participant"] == who]
        return [p[0] for p in pts], [p[1] for p in pts]

    if len(people) <= kFewLines:
        markers = "osD^vP"
        cols = min(2, len(panels))
        nrows = (len(panels) + cols - 1) // cols
        fig, axes = plt.subplots(nrows, cols, figsize=(5.2 * cols, 3.0 * nrows), squeeze=False)
        for ax, (kind, score) in zip(axes.flat, panels):
            for n, who in enumerate(people):
                xs, ys = series(kind, score, who)
                if xs:
                    ax.plot(xs, ys, marker=markers[n % len(markers)], ms=4, lw=1.2,
                            ls=("-", "--", ":")[n % 3], label=who)
            ax.set_title("%s: %s" % (kind, score.replace("_", " ")), fontsize=9)
            ax.set_xlabel("trial, in time order")
            ax.xaxis.set_major_locator(MaxNLocator(integer=True))
            ax.grid(alpha=0.3)
            ax.legend(fontsize=7)
        for ax in list(axes.flat)[len(panels):]:
            ax.axis("off")
        save(fig, "report-learning.png")
    else:
        for number, (kind, score) in enumerate(panels, 1):
            cols = min(6, len(people))
            nrows = (len(people) + cols - 1) // cols
            fig, axes = plt.subplots(nrows, cols, figsize=(2.2 * cols, 1.9 * nrows), squeeze=False,
                                     sharex=True, sharey=True)
            everyone = [series(kind, score, who) for who in people]
            for ax, who, (xs, ys) in zip(axes.flat, people, everyone):
                for oxs, oys in everyone:
                    ax.plot(oxs, oys, color="0.85", lw=0.8)
                ax.plot(xs, ys, color="tab:blue", marker="o", ms=3, lw=1.4)
                ax.set_title(who, fontsize=8)
                ax.xaxis.set_major_locator(MaxNLocator(integer=True))
                ax.tick_params(labelsize=7)
                ax.grid(alpha=0.3)
            for ax in list(axes.flat)[len(people):]:
                ax.axis("off")
            fig.suptitle("Learning curve, %s: %s (each trainee in blue, the others grey; trials in time order)"
                         % (kind, score.replace("_", " ")), fontsize=9)
            save(fig, "report-learning-%d.png" % number)

open(os.path.join(d, "figures_report.txt"), "w").write("".join(m + "\n" for m in made))
