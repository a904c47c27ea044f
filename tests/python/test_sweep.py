"""Sweeps: the default process pool and a Dask LocalCluster's executor give the same table."""

import concurrent.futures

import numpy as np
import pytest

import cariesim
from sweep_functions import peak_forces, square

GRID = {"lesions[0].material.mu_s": [0.2, 0.6], "lesions[0].material.stiffness": [0.5, 1.5]}


def test_grid_points():
    points = cariesim.grid_points(GRID)
    assert len(points) == 4
    assert points[0] == {"lesions[0].material.mu_s": 0.2, "lesions[0].material.stiffness": 0.5}
    assert points[1] == {"lesions[0].material.mu_s": 0.2, "lesions[0].material.stiffness": 1.5}
    assert cariesim.grid_points([{"a": 1}, {"a": 2}]) == [{"a": 1}, {"a": 2}]


def test_process_pool_and_local_cluster_agree():
    pd = pytest.importorskip("pandas")
    distributed = pytest.importorskip("distributed")
    pooled = cariesim.sweep(peak_forces, GRID, scene="friction-block")
    assert isinstance(pooled, pd.DataFrame)
    assert list(pooled.columns) == list(GRID) + ["fz_max", "fx_min", "steps"]
    assert len(pooled) == 4
    # The physics shows: stiffer presses harder, more friction drags harder.
    low, high = pooled.iloc[0], pooled.iloc[1]
    assert high["fz_max"] > low["fz_max"]
    assert pooled.iloc[3]["fx_min"] < pooled.iloc[1]["fx_min"]
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        clustered = cariesim.sweep(peak_forces, GRID, executor=client.get_executor(),
                                   scene=cariesim.load_scene("friction-block"))
    pd.testing.assert_frame_equal(pooled, clustered, check_exact=True)


def test_any_executor_and_plain_tables():
    with concurrent.futures.ThreadPoolExecutor(2) as pool:
        table = cariesim.sweep(square, {"x": [1, 2, 3]}, executor=pool, pandas=False)
    assert list(table) == ["x", "result"]
    assert np.array_equal(table["result"], [1, 4, 9])


def test_bad_points_raise_the_scenes_error():
    with pytest.raises(cariesim.Error, match=r"override lesions\[0\]\.material\.mu_s"):
        cariesim.sweep(peak_forces, {"lesions[0].material.mu_s": [-1.0]}, scene="friction-block",
                       executor=concurrent.futures.ThreadPoolExecutor(1))
