"""Session recordings and study databases as arrays (pandas DataFrames when pandas is installed)."""

import numpy as np

from . import _cariesim

STATE_NAMES = ("free", "sliding", "inserting", "extracting")
"""Interaction states by code (docs/records.md)."""


def _pandas(use_pandas):
    """pandas when asked for (True), or when installed and not refused (None)."""
    if use_pandas is False:
        return None
    try:
        import pandas
    except ImportError:
        if use_pandas:
            raise
        return None
    return pandas


def _table(columns, pandas):
    """Columns (dict of name -> sequence) as a DataFrame, or a dict of numpy arrays."""
    arrays = {name: np.asarray(values) for name, values in columns.items()}
    return pandas.DataFrame(arrays) if pandas is not None else arrays


def read_recording(path, pandas=None):
    """A session recording (a `--record` SQLite file) read through the library (load_recording):
    {"session": dict, "samples": table, "events": table}, tables with the columns of `cariesim
    export`'s samples.csv and events.csv (docs/records.md), `state` by name. Tables are pandas
    DataFrames when pandas is installed (pandas=False: dicts of numpy arrays)."""
    rec = _cariesim.load_recording(str(path))
    samples = dict(rec["samples"])
    samples["state"] = np.array(STATE_NAMES)[samples["state"]]
    pd = _pandas(pandas)
    return {"session": dict(rec["session"]), "samples": _table(samples, pd), "events": _table(rec["events"], pd)}


def read_studies(paths, pandas=None):
    """Study databases merged as `cariesim report` merges them (each trial once): {"trials": table,
    "scores": table}; scores in long form (name, level, value, unit) with the trial's participant,
    study and trial number beside them."""
    if isinstance(paths, (str, bytes)) or hasattr(paths, "__fspath__"):
        paths = [paths]
    merged = _cariesim.read_studies([str(p) for p in paths])
    trials = dict(merged["trials"])
    scores = dict(merged["scores"])
    rows = np.asarray(scores["row"], dtype=np.int64)
    for key in ("participant", "study", "trial", "station", "started_at"):
        scores[key] = np.asarray(trials[key])[rows] if len(rows) else np.asarray([], dtype=object)
    pd = _pandas(pandas)
    return {"trials": _table(trials, pd), "scores": _table(scores, pd), "duplicates": merged["duplicates"]}
