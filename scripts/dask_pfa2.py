#!/usr/bin/env python
"""pfa2's two-step sub-images on Dask: same mosaic as the serial run, time on 1 and 2 workers,
per-sub-image cost, and a paper-on-a-cluster estimate.

    python scripts/dask_pfa2.py [--scene configs/nie2016_small.yaml] [--out results/dask-pfa2]

Runs pfa2 (section pfa2: of the scene file) serially (builtin map), then with its sub-images as Dask
tasks on a LocalCluster of 1 and of 2 worker processes (1 thread each), and reports the wall times,
the largest mosaic difference from the serial image (dB of its peak), the number of sub-images and
their mean cost (serial sub-image time / count) and the bytes of one task.
"""

from __future__ import annotations

import argparse
import json
import math
import pickle
import time
from pathlib import Path

import numpy as np

from sarproc.cli.dask_map import dask_mapper
from sarproc.focus.pfa import two_step
from sarproc.focus.pfa.chain import Pfa2Params, pfa2
from sarproc.product.config import build, load_yaml
from sarproc.simulation.scene import scene_from_mapping
from sarproc.simulation.simulate import simulate

ROOT = Path(__file__).resolve().parents[1]


def timed_serial(raw, params):
    """Serial run, timing every sub-image (the builtin map over focus_subimage)."""
    costs, sizes = [], []

    def mapper(func, items):
        for task in items:
            sizes.append(len(pickle.dumps(task, protocol=5)))
            t0 = time.perf_counter()
            out = func(task)
            costs.append(time.perf_counter() - t0)
            yield out

    t0 = time.perf_counter()
    image = pfa2(raw, params, mapper=mapper)
    return image, time.perf_counter() - t0, costs, sizes


def main(argv=None):
    from dask.distributed import Client, LocalCluster

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", type=Path, default=ROOT / "configs" / "nie2016_small.yaml")
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "dask-pfa2")
    args = ap.parse_args(argv)
    mapping = load_yaml(args.scene)
    params = build(Pfa2Params, mapping.get("pfa2"), str(args.scene), "pfa2")
    raw = simulate(scene_from_mapping(mapping, str(args.scene)))
    serial, t_serial, costs, sizes = timed_serial(raw, params)
    rows = [{"run": "serial (builtin map)", "workers": 0, "wall_s": t_serial, "max_diff_db": None}]
    peak = np.abs(serial.data).max()
    for workers in (1, 2):
        with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None) as cl, \
                Client(cl) as client:
            client.wait_for_workers(workers)           # workers up before the clock starts
            t0 = time.perf_counter()
            image = pfa2(raw, params, mapper=dask_mapper(client, "pfa2-subimage"))
            wall = time.perf_counter() - t0
        diff = np.abs(image.data - serial.data).max() / peak
        rows.append({"run": f"Dask LocalCluster", "workers": workers, "wall_s": wall,
                     "max_diff_db": 20 * math.log10(max(diff, 1e-300))})
    result = {"scene": str(args.scene), "raw_shape": list(raw.data.shape), "image_shape": list(serial.data.shape),
              "n_subimages": len(costs), "subimage_s_mean": float(np.mean(costs)), "subimage_s_max": float(np.max(costs)),
              "subimage_s_total": float(np.sum(costs)), "task_bytes_mean": float(np.mean(sizes)), "rows": rows}
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "dask_pfa2.json").write_text(json.dumps(result, indent=1) + "\n")
    print(json.dumps(result, indent=1))


if __name__ == "__main__":
    main()
