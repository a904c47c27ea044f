"""Parameter sweeps on any concurrent.futures.Executor: a process pool by default, or a Dask
distributed client's executor (``client.get_executor()``), so a sweep that outgrows one machine runs
on a cluster unchanged (docs/python.md, "Sweeps")."""

import concurrent.futures
import itertools
import os

import numpy as np

from ._scene import Scene


def grid_points(grid):
    """The points of a grid: a dict of key -> values gives their Cartesian product (the first key
    varying slowest); a list of dicts is taken as it is."""
    if isinstance(grid, dict):
        keys = list(grid)
        return [dict(zip(keys, values)) for values in itertools.product(*(list(grid[k]) for k in keys))]
    return [dict(point) for point in grid]


def _run_point(function, scene, point):
    """One point: the function of the overridden scene (or of the point when there is no scene)."""
    if scene is None:
        return function(point)
    base = scene if isinstance(scene, Scene) else Scene(scene)
    return function(base.with_overrides(point))


def _as_row(point, result):
    """The point's values, then the result's (a dict's items, else one column `result`)."""
    row = dict(point)
    if isinstance(result, dict):
        for key, value in result.items():
            if key in row:
                raise ValueError(f"sweep: the result's key {key!r} is also a parameter of the grid")
            row[key] = value
    else:
        row["result"] = result
    return row


def sweep(function, grid, executor=None, scene=None, pandas=None):
    """Runs `function` over every point of `grid` and gathers the results into one table.

    `grid`: {key: values} (their product) or a list of {key: value}; keys are override keys such as
    "lesions[0].material.k_c". With `scene` (a Scene or a source name), `function(scene_at_point)` is
    called with the scene overridden at the point; without one, `function(point)`. The function
    returns a dict (one column per key) or one value (column `result`); it must be picklable for
    other processes (a module-level def). `executor`: any concurrent.futures.Executor (a Dask
    client's get_executor()); None: a process pool with a worker per CPU, closed afterwards. Rows
    are in the grid's order; the table is a pandas DataFrame when pandas is installed (pandas=False:
    a dict of numpy arrays)."""
    points = grid_points(grid)
    own = executor is None
    if own:
        executor = concurrent.futures.ProcessPoolExecutor(max_workers=os.cpu_count() or 1)
    try:
        futures = [executor.submit(_run_point, function, scene, point) for point in points]
        rows = [_as_row(point, future.result()) for point, future in zip(points, futures)]
    finally:
        if own:
            executor.shutdown()
    columns = {}
    for row in rows:
        for key in row:
            columns.setdefault(key, None)
    table = {key: [row.get(key) for row in rows] for key in columns}
    try:
        import pandas as pd
    except ImportError:
        pd = None
    if pandas is True and pd is None:
        raise ImportError("sweep(pandas=True): pandas is not installed")
    if pd is not None and pandas is not False:
        return pd.DataFrame(table)
    return {key: np.asarray(values) for key, values in table.items()}
