#!/usr/bin/env python
"""pfa2's two-step sub-images on Dask: same mosaic as the serial run, time on 1 and 2 workers,
per-sub-image cost, and a paper-on-a-cluster estimate.

    python scripts/dask_pfa2.py [--scene configs/nie2016_small.yaml] [--out results/dask-pfa2]

Runs pfa2 (section pfa2: of the scene file) serially (builtin map), then with its sub-images as Dask
tasks on a LocalCluster of 1 and of 2 worker processes (1 thread each), each twice (the first run pays
the workers' imports and kernel compilation: 'cold_s'), and reports the wall times,
the largest mosaic difference from the serial image (dB of its peak), the number of sub-images and
their mean cost (serial sub-image time / count) and the bytes of one task.
"""

from __future__ import annotations

import argparse
import json
import math
import pickle
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from sarproc.cli.dask_map import dask_mapper
from sarproc.focus.pfa.chain import Pfa2Params, pfa2
from sarproc.product.config import build, load_yaml
from sarproc.product.model import Product
from sarproc.simulation.scene import scene_from_mapping
from sarproc.simulation.simulate import simulate

ROOT = Path(__file__).resolve().parents[1]


def timed_serial(raw: Product, params: Pfa2Params) -> tuple[Product, float, list[float], list[int]]:
    """Serial run, timing every sub-image (the builtin map over focus_subimage)."""
    costs, sizes = [], []

    def mapper(func: Callable[[Any], Any], items: Iterable[Any]) -> Iterator[Any]:
        for task in items:
            sizes.append(len(pickle.dumps(task, protocol=5)))
            t0 = time.perf_counter()
            out = func(task)
            costs.append(time.perf_counter() - t0)
            yield out

    t0 = time.perf_counter()
    image = pfa2(raw, params, mapper=mapper)
    return image, time.perf_counter() - t0, costs, sizes


# Table 1 of Nie 2016 (issue 10) against the reduced scene configs/nie2016_small.yaml
TABLE1 = {"resolution_m": 0.1, "target_span_m": 14 * 80.0, "valid_radius_m": 88.8}
SMALL = {"resolution_m": 0.55, "target_span_m": 4 * 80.0}


def cluster_estimate(result: dict, workers: Sequence[int] = (1, 2, 4, 8, 16, 32, 64, 169)) -> dict:
    """Full Table 1 scene on N workers from the measured small-scene costs (stated scalings, not a run).

    Sub-images: one per valid-radius core over the target span (+ margins), each window's sample count
    scaled by (core / resolution)^2 from the small scene's, cost by N log N. Step 1 (range compression,
    first PFA, mosaic) stays on the driver: scaled by its pixel count, N log N. T(N) = step 1 + n_sub x
    cost / N (whole sub-images per worker), plus the windows' transfer at 1 GB/s.
    """
    info = result["pfa2_info"]
    core_small = info["subimage_core"]
    n_small = info["window_shape_max"][0] * info["window_shape_max"][1]
    side = (TABLE1["valid_radius_m"] / core_small) * (SMALL["resolution_m"] / TABLE1["resolution_m"])
    n_full = n_small * side**2
    cost = result["subimage_s_mean"] * (n_full * math.log(n_full)) / (n_small * math.log(n_small))
    n_sub = math.ceil((TABLE1["target_span_m"] + 2 * 24 * TABLE1["resolution_m"]) / TABLE1["valid_radius_m"]) ** 2
    step1_small = info["step1_shape"][0] * info["step1_shape"][1]
    extent_ratio = (TABLE1["target_span_m"] + 1.5 * TABLE1["valid_radius_m"]) / (
        SMALL["target_span_m"] + 1.5 * core_small
    )
    step1_full = step1_small * (extent_ratio * SMALL["resolution_m"] / TABLE1["resolution_m"]) ** 2
    serial_s = result["serial_other_s"] * (step1_full * math.log(step1_full)) / (step1_small * math.log(step1_small))
    transfer_s = n_sub * n_full * 8 / 1e9
    return {
        "subimages": n_sub,
        "window_samples": n_full,
        "subimage_s": cost,
        "step1_pixels": step1_full,
        "driver_s": serial_s,
        "transfer_s": transfer_s,
        "wall_s": {n: serial_s + transfer_s + math.ceil(n_sub / n) * cost for n in workers},
    }


def main(argv: list[str] | None = None) -> None:
    from dask.distributed import Client, LocalCluster

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", type=Path, default=ROOT / "configs" / "nie2016_small.yaml")
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "dask-pfa2")
    ap.add_argument("--estimate-from", type=Path, default=None, help="only recompute the estimate from a saved JSON")
    args = ap.parse_args(argv)
    if args.estimate_from is not None:
        result = json.loads(args.estimate_from.read_text())
        print(json.dumps(cluster_estimate(result), indent=1))
        return
    mapping = load_yaml(args.scene)
    params = build(Pfa2Params, mapping.get("pfa2"), str(args.scene), "pfa2")
    raw = simulate(scene_from_mapping(mapping, str(args.scene)))
    _, t_cold, _, _ = timed_serial(raw, params)  # first run: imports and kernel compilation
    serial, t_serial, costs, sizes = timed_serial(raw, params)
    rows = [{"run": "serial (builtin map)", "workers": 0, "wall_s": t_serial, "cold_s": t_cold, "max_diff_db": None}]
    peak = np.abs(serial.data).max()
    for workers in (1, 2):
        with (
            LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=":0") as cl,
            Client(cl) as client,
        ):
            client.wait_for_workers(workers)  # workers up before the clock starts
            t0 = time.perf_counter()
            pfa2(raw, params, mapper=dask_mapper(client, "pfa2-subimage-cold"))
            cold = time.perf_counter() - t0  # the workers import and compile their kernels
            t0 = time.perf_counter()
            image = pfa2(raw, params, mapper=dask_mapper(client, "pfa2-subimage"))
            wall = time.perf_counter() - t0
        diff = np.abs(image.data - serial.data).max() / peak
        rows.append(
            {
                "run": "Dask LocalCluster",
                "workers": workers,
                "wall_s": wall,
                "cold_s": cold,
                "max_diff_db": 20 * math.log10(max(float(diff), 1e-300)),
            }
        )
    result = {
        "scene": str(args.scene),
        "raw_shape": list(raw.data.shape),
        "image_shape": list(serial.data.shape),
        "n_subimages": len(costs),
        "subimage_s_mean": float(np.mean(costs)),
        "subimage_s_max": float(np.max(costs)),
        "subimage_s_total": float(np.sum(costs)),
        "task_bytes_mean": float(np.mean(sizes)),
        "rows": rows,
        "pfa2_info": {
            k: serial.attrs[k]
            for k in (
                "subimages",
                "subimage_core",
                "valid_radius_eq7",
                "step1_shape",
                "window_shape_max",
                "stage_seconds",
            )
            if k in serial.attrs
        },
    }
    result["serial_other_s"] = t_serial - result["subimage_s_total"]
    result["table1_estimate"] = cluster_estimate(result)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "dask_pfa2.json").write_text(json.dumps(result, indent=1) + "\n")
    print(json.dumps(result, indent=1))


if __name__ == "__main__":
    main()
