#!/usr/bin/env python3
"""Writes two example study databases, as two stations of a class would (docs/reports.md):

    python3 examples/make_example_study.py OUT_DIR
    cariesim report OUT_DIR/station-a.db OUT_DIR/station-b.db --out OUT_DIR/report

Five dentists D1-D5 (D1-D3 at station-a, D4-D5 at station-b) each do the three built-in studies:
`tuning` (four trials, mild and severe: mu_s, mu_d, k_c, k_e drawn around the paper's per-dentist
means and SDs of Tables 1-2), `boundary-shapes` (ten trials, three shapes) and `diagnosis` (four
runs of its first case, the paper's three lesions, getting better case by case; each case's lesions
and marks in its answers, as a station records them). Station-b also holds one unfinished case. It
also writes OUT_DIR/course.yaml, a course with pass/fail criteria for `cariesim report --course`.
The numbers are made up from a fixed seed; the schema is read from src/training/study_schema.hpp, so
the files are what `cariesim study run` writes. Python's standard library only.
"""
import json
import os
import random
import re
import sqlite3
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
SCHEMA_HPP = os.path.join(HERE, "..", "src", "training", "study_schema.hpp")

# The paper's Tables 1-2: per dentist (mean, SD) of mu_s, mu_d (Table 1) and k_c, k_e (Table 2).
PAPER = {
    "mild": {
        "mu_s": [(0.06, 0.04), (0.28, 0.17), (0.19, 0.05), (0.17, 0.07), (0.19, 0.03)],
        "mu_d": [(0.08, 0.04), (0.24, 0.09), (0.19, 0.07), (0.21, 0.06), (0.15, 0.04)],
        "k_c": [(0.38, 0.08), (0.68, 0.04), (0.61, 0.07), (0.60, 0.07), (0.62, 0.04)],
        "k_e": [(0.30, 0.00), (0.58, 0.16), (0.53, 0.08), (0.70, 0.14), (0.53, 0.04)],
    },
    "severe": {
        "mu_s": [(0.21, 0.16), (0.51, 0.16), (0.54, 0.09), (0.65, 0.02), (0.64, 0.08)],
        "mu_d": [(0.16, 0.08), (0.47, 0.15), (0.52, 0.08), (0.60, 0.02), (0.52, 0.09)],
        "k_c": [(0.20, 0.10), (0.18, 0.04), (0.18, 0.08), (0.13, 0.04), (0.30, 0.00)],
        "k_e": [(0.37, 0.11), (0.33, 0.04), (0.43, 0.08), (0.50, 0.00), (0.30, 0.08)],
    },
}
UNITS = {"mu_s": "", "mu_d": "", "k_c": "N/mm", "k_e": "N/mm"}


def schema():
    """The CREATE statements and constants of study_schema.hpp (its C++ string literals joined)."""
    text = open(SCHEMA_HPP).read()
    body = text[text.index("kStudySchemaSql"):]
    body = body[: body.index(";\n")]
    sql = "".join(re.findall(r'"((?:[^"\\]|\\.)*)"', body))
    version = int(re.search(r"kStudySchemaVersion = (\d+);", text).group(1))
    app_id = int(re.search(r"kStudyApplicationId = (0x[0-9A-Fa-f]+);", text).group(1), 16)
    application = re.search(r'kStudyApplication = "([^"]+)";', text).group(1)
    return sql, version, app_id, application


class Station:
    def __init__(self, path, name):
        sql, version, app_id, application = schema()
        if os.path.exists(path):
            os.remove(path)
        self.db = sqlite3.connect(path)
        self.db.execute("PRAGMA journal_mode=WAL")  # as cariesim study run writes it
        self.db.executescript(sql)
        self.db.execute("PRAGMA application_id=%d" % app_id)
        self.db.execute("INSERT INTO schema_version (version, application) VALUES (?, ?)", (version, application))
        self.name = name

    def trial(self, who, study, number, seed, start, seconds, scores, finished=True, answers="{}", kind=None):
        started = "2026-11-%02dT%02d:%02d:%02d.000Z" % start
        day, hour, minute, second = start
        total = hour * 3600 + minute * 60 + second + int(seconds)
        ended = "2026-11-%02dT%02d:%02d:%02d.000Z" % (day, total // 3600, total // 60 % 60, total % 60)
        cur = self.db.execute(
            "INSERT INTO trials (station, participant, study, kind, trial, seed, started_at, ended_at,"
            " recording, answers, scores) VALUES (?, ?, ?, ?, ?, ?, ?, ?, NULL, ?, '{}')",
            (self.name, who, study, kind or study, number, seed, started, ended if finished else None, answers))
        for name, level, value, unit in scores:
            self.db.execute("INSERT INTO scores (trial_id, name, level, value, unit) VALUES (?, ?, ?, ?, ?)",
                            (cur.lastrowid, name, level, value, unit))

    def close(self):
        self.db.commit()
        self.db.close()


# The built-in diagnosis-paper study's first case (studies/diagnosis-paper.yaml, the paper's #1-#3), and where
# model places each lesion (world mm, as `cariesim report` rebuilds it from the scene): the marks of
# the example land on them.
PAPER_CASE = [{"site": "46-occlusal-fossa", "severity": "severe", "size": 2.2, "width": 1.0, "depth": 2.5},
              {"site": "46-mesial", "severity": "severe", "size": 2.0, "width": 1.4, "depth": 1.3},
              {"site": "36-occlusal-fossa", "severity": "mild", "size": 3.0, "width": 0.8, "depth": 1.2}]
CENTRES = [[-20.209, -0.328, 7.94], [-19.26, -4.375, 2.44], [19.654, 0.431, 8.07]]
# A false mark's place: the occlusal surface of 45 or 47, away from every lesion.
ELSEWHERE = [[-16.743, -7.567, 7.928], [-24.163, 8.25, 7.774]]

COURSE = """# course.yaml: the example class (docs/reports.md); `cariesim report --course` grades with its criteria.
format: 1
course: Example class
study: diagnosis-paper
records: records
station: station-a
instructor: pbkdf2-sha256$600000$ba9f44571da1cd87db4514d1c8529d2c$507309be11afaf095e2d9b42fbb6b0639f9e4c686035c1eb08d477ec3a119722
criteria:
  detection_rate: 0.9     # of the lesions over all cases (the paper's expert found all, section 5.3)
  false_marks: 0          # in any one case
  time_per_lesion: 30     # s, mean (the paper's expert: under 30 s)
  soft_tissue_time: 1.5   # s in any one case
"""


def case_answers(rng, found, graded, times, false_marks):
    """trials.answers of a diagnosis case (docs/training.md): its lesions and the marks, in time order."""
    marks = []
    for k, lesion in enumerate(PAPER_CASE):
        if found[k]:
            right = lesion["severity"]
            grade = right if graded[k] else ("mild" if right == "severe" else "severe")
            tip = [c + rng.uniform(-0.2, 0.2) for c in CENTRES[k]]
            marks.append({"t": round(times[k], 1), "grade": grade, "contact": True, "tip": tip,
                          "lesion": k + 1, "distance": 0.0, "first": True})
    for _ in range(false_marks):
        where = ELSEWHERE[rng.randrange(len(ELSEWHERE))]
        marks.append({"t": round(rng.uniform(5, 60), 1), "grade": "mild", "contact": True, "tip": where,
                      "lesion": None, "distance": 3.0, "first": False})
    marks.sort(key=lambda m: m["t"])
    return json.dumps({"lesions": PAPER_CASE, "marks": marks, "ended_at": None}, separators=(",", ":"))


def main():
    if len(sys.argv) != 2:
        sys.exit("usage: make_example_study.py OUT_DIR")
    out = sys.argv[1]
    os.makedirs(out, exist_ok=True)
    rng = random.Random(2016)
    stations = {"station-a": Station(os.path.join(out, "station-a.db"), "station-a"),
                "station-b": Station(os.path.join(out, "station-b.db"), "station-b")}
    for i in range(5):
        who = "D%d" % (i + 1)
        station = stations["station-a" if i < 3 else "station-b"]
        day = 20 + i

        # Tuning: four trials, mild and severe each time (slider values, two decimals).
        for t in range(1, 5):
            scores = []
            for level in ("mild", "severe"):
                for name in ("mu_s", "mu_d", "k_c", "k_e"):
                    mean, sd = PAPER[level][name][i]
                    value = round(max(0.01, rng.gauss(mean, sd)), 2)
                    scores.append((name, level, value, UNITS[name]))
            station.trial(who, "tuning", t, rng.randrange(1 << 31), (day, 9, 6 * t, 0), 300, scores)

        # Boundary shapes: ten trials; each shape named right with a probability that grows a little.
        for t in range(1, 11):
            p = 0.82 + 0.015 * t
            right = {shape: int(rng.random() < p) for shape in ("square", "triangle", "circle")}
            scores = [("boundary_point", "", float(all(right.values())), "")]
            scores += [("shape_correct", shape, float(v), "") for shape, v in right.items()]
            station.trial(who, "boundary-shapes", t, rng.randrange(1 << 31), (day, 10, 4 * t, 0), 200, scores)

        # Diagnosis: four runs of the paper's case, lesions #1 (severe), #2 (severe), #3 (mild); better
        # case by case.
        for t in range(1, 5):
            severities = [lesion["severity"] for lesion in PAPER_CASE]
            found = [rng.random() < 0.55 + 0.12 * t + (0.1 if s == "severe" else 0.0) for s in severities]
            graded = [f and rng.random() < 0.6 + 0.1 * t for f in found]
            false_marks = int(rng.random() < 0.5 - 0.1 * t)
            times = [max(4.0, rng.gauss(45.0 - 7.0 * t, 6.0)) for _ in severities]
            detected = sum(found)
            scores = [("lesions", "", 3.0, "count"), ("detected", "", float(detected), "count"),
                      ("missed", "", float(3 - detected), "count"),
                      ("false_marks", "", float(false_marks), "count"),
                      ("detection_rate", "", detected / 3.0, "fraction"),
                      ("severity_accuracy", "", (sum(graded) / detected) if detected else 0.0, "fraction")]
            scores += [("time_to_detection", s, round(tt, 1), "s")
                       for s, f, tt in zip(severities, found, times) if f]
            case_time = round(max(times) + rng.uniform(10, 30), 1)
            scores += [("case_time", "", case_time, "s"),
                       ("soft_tissue_time", "", round(max(0.0, rng.gauss(1.2 - 0.25 * t, 0.3)), 2), "s"),
                       ("soft_tissue_peak_force", "", round(rng.uniform(0.5, 2.5), 2), "N"),
                       ("enamel_excess_force_time", "", round(max(0.0, rng.gauss(0.8 - 0.15 * t, 0.2)), 2), "s"),
                       ("enamel_peak_force", "", round(rng.uniform(2.0, 5.0), 2), "N"),
                       ("blocked_insertions", "", float(rng.randrange(0, 3)), "count")]
            answers = case_answers(rng, found, graded, times, false_marks)
            station.trial(who, "diagnosis-paper", 1, rng.randrange(1 << 31), (day, 11, 5 * t, 0), case_time, scores,
                          answers=answers, kind="diagnosis")

    # A case abandoned at station-b (no end time): listed, not counted.
    stations["station-b"].trial("D5", "diagnosis-paper", 5, 7, (24, 11, 30, 0), 0,
                                [("lesions", "", 3.0, "count")], finished=False, kind="diagnosis")
    for s in stations.values():
        s.close()
    with open(os.path.join(out, "course.yaml"), "w") as f:
        f.write(COURSE)
    print("wrote %s, %s and %s" % (os.path.join(out, "station-a.db"), os.path.join(out, "station-b.db"),
                                   os.path.join(out, "course.yaml")))


if __name__ == "__main__":
    main()
