#!/usr/bin/env python3
"""FastSAR's exact former on a phase history saved by scripts/bench.py; runs in the bench-only venv.

    .venv-bench/bin/python scripts/bench_fastsar.py CASE.npz OUT.npz [--calls 2]

CASE.npz: S (P, K) complex64 phase history (FastSAR's convention, S = exp(-j 4 pi f (R - ref) / c)), ant (P, 3),
ref (P,), fmin, df, nx, ny, spx, spy, e1, e2, center. For each interpolation (linear, cubic) the former is
built once and called ``--calls`` times; the best call time and the last image go to OUT.npz, the times
to stdout as JSON. Imports only numpy and fastsar, so it runs without sarproc.
"""

import argparse
import json
import time
from typing import Any

import numpy as np


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("case")
    ap.add_argument("out")
    ap.add_argument("--calls", type=int, default=2)
    ap.add_argument("--upsample", type=int, default=8)
    ap.add_argument(
        "--factorised",
        type=float,
        nargs="*",
        default=[],
        help="also FastSAR's factorised ImageFormer at these target_db values (key imageformer<db>)",
    )
    a = ap.parse_args()
    import fastsar

    c = np.load(a.case)
    result: dict[str, Any] = {"version": fastsar.__version__}
    images: dict[str, Any] = {}  # Any: numpy's savez stub would match an array to allow_pickle
    for interp in ("linear", "cubic"):
        former = fastsar.ExactFormer(
            c["ant"],
            float(c["fmin"]),
            float(c["df"]),
            c["S"].shape[1],
            int(c["nx"]),
            int(c["ny"]),
            float(c["spx"]),
            float(c["spy"]),
            c["e1"],
            c["e2"],
            backend="cpu",
            window=False,
            interp=interp,
            upsample=a.upsample,
            ref=c["ref"],
            center=c["center"],
        )
        best = np.inf
        for _ in range(a.calls):
            t = time.perf_counter()
            img = former(c["S"])
            best = min(best, time.perf_counter() - t)
        result[interp] = {"time_s": best, "tile": list(former.tile), "predicted_error_db": former.predicted_error_db}
        images[interp] = np.asarray(img)
    for db in a.factorised:
        former = fastsar.ImageFormer(
            c["ant"],
            float(c["fmin"]),
            float(c["df"]),
            c["S"].shape[1],
            int(c["nx"]),
            int(c["ny"]),
            float(c["spx"]),
            float(c["spy"]),
            c["e1"],
            c["e2"],
            backend="cpu",
            window=False,
            target_db=db,
            ref=c["ref"],
        )
        best = np.inf
        for _ in range(a.calls):
            t = time.perf_counter()
            img = former(c["S"])
            best = min(best, time.perf_counter() - t)
        key = f"imageformer{db:g}"
        result[key] = {"time_s": best, "target_db": db}
        images[key] = np.asarray(img)
    np.savez(a.out, **images)
    print(json.dumps(result))


if __name__ == "__main__":
    main()
