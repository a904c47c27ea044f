"""The k_c x F_p* sweep of kc_fp_sweep.py on a Dask cluster (docs/python.md, "Sweeps"): the same
call with a Dask client's executor. Here a LocalCluster on this machine; for a real cluster start
`dask scheduler` and `dask worker tcp://HOST:8786` on the machines (each with cariesim on its
PYTHONPATH) and use Client("tcp://HOST:8786") instead. Usage: dask_sweep.py [OUT_DIR]"""
import os
import sys

from distributed import Client, LocalCluster

import cariesim
from kc_fp_sweep import GRID, heat_map, push

if __name__ == "__main__":
    with LocalCluster(n_workers=2, threads_per_worker=1, dashboard_address=None) as cluster, Client(cluster) as client:
        table = cariesim.sweep(push, GRID, executor=client.get_executor(), scene="friction-block")
    print(table.to_string(index=False))
    heat_map(table, os.path.join(sys.argv[1] if len(sys.argv) > 1 else ".", "dask_sweep.png"))
