#!/usr/bin/env python3
"""FastSAR's formers on a phase history saved by scripts/bench.py; runs in the bench-only venv.

    .venv-bench/bin/python scripts/bench_fastsar.py CASE.npz OUT.npz [--calls 2] [--factorised -40 -50]
    .venv-bench/bin/python scripts/bench_fastsar.py CASE.npz OUT.npz --serve [--factorised -50] [--lanes 8]

CASE.npz: S (P, K) complex64 phase history (FastSAR's convention, S = exp(-j 4 pi f (R - ref) / c)), ant (P, 3),
ref (P,), fmin, df, nx, ny, spx, spy, e1, e2, center. Every former (exact linear and cubic x8, ImageFormer at each
--factorised target) is built once and called once untimed (its kernels compiled and loaded, its buffers
touched), so every timed call is warm. Without --serve each former is then called ``--calls`` times and the
best time goes to stdout as JSON, the images to OUT.npz. With --serve it waits for former names on stdin (one
per line: linear, cubic, imageformer-50, ...; "save" writes OUT.npz, "quit" ends) and answers each with one JSON
line: that call's wall, user and system seconds, so the caller can interleave FastSAR's calls with its own.

The threads: OMP_NUM_THREADS if set (the caller sets it to its own thread count), else all cores.
--lanes 8 also builds the factorised former with FastSAR's 16-float vector type cut to 8 floats (one AVX2
register; key suffix " lanes8"): FastSAR's C++ is written for one AVX-512 register per vector and spills on a
CPU without AVX-512 (docs/performance.md). Warnings (a MemoryWarning: a slower fallback for lack of memory) go
to the JSON. Imports only numpy and fastsar, so it runs without sarproc.
"""

import argparse
import json
import os
import resource
import sys
import tempfile
import time
import warnings
from typing import Any

import numpy as np


def _cpu() -> tuple[float, float]:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime, r.ru_stime


# the factorised formers' shared library by former (fastsar.ffbp_cpu keeps one, module-wide, that its stages
# load at call time: with --lanes each former's is put back before its call)
LIBS: dict[int, Any] = {}


def timed_call(former: Any, S: np.ndarray) -> tuple[np.ndarray, dict]:
    """former(S) and its wall, user and system seconds; a factorised former's also by stage (ffbp_cpu.PROFILE:
    range and pulse filters of each level, final tiles)."""
    from fastsar import ffbp_cpu

    factorised = id(former) in LIBS
    if factorised:
        ffbp_cpu._lib = LIBS[id(former)]
        ffbp_cpu.PROFILE.clear()
        ffbp_cpu.PROFILE["on"] = True
    u0, s0 = _cpu()
    t = time.perf_counter()
    img = former(S)
    wall = time.perf_counter() - t
    u1, s1 = _cpu()
    info: dict[str, Any] = {"time_s": wall, "user_s": u1 - u0, "sys_s": s1 - s0}
    if factorised:
        info["stages_s"] = {k: round(v, 4) for k, v in ffbp_cpu.PROFILE.items() if k != "on"}
        ffbp_cpu.PROFILE.clear()
    return img, info


def with_lanes(lanes: int) -> None:
    """Point fastsar.ffbp_cpu at a copy of its own C++ source with ``lanes`` floats per vector (next to the
    original, so par.hpp is found), compiled on first use into FastSAR's kernel cache like the original."""
    from fastsar import ffbp_cpu

    with open(ffbp_cpu._SRC) as fh:
        src = fh.read()
    old = "constexpr int VL = 16;"
    if old not in src:
        raise SystemExit(f"fastsar's ffbp_cpu.cpp has no '{old}': --lanes does not apply to this version")
    path = os.path.join(tempfile.mkdtemp(prefix="fastsar-lanes"), "ffbp_cpu.cpp")
    with open(path, "w") as fh:
        fh.write(src.replace(old, f"constexpr int VL = {lanes};"))
    # _build.shared_object adds -I of the package directory (par.hpp) whatever the source's path
    ffbp_cpu._SRC = path
    ffbp_cpu._lib = None


def build(c: Any, targets: list[float], lanes: int | None) -> dict[str, Any]:
    import fastsar

    common = (
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
    )
    formers: dict[str, Any] = {}
    for interp in ("linear", "cubic"):
        formers[interp] = fastsar.ExactFormer(
            *common,
            backend="cpu",
            window=False,
            interp=interp,
            upsample=8,
            ref=c["ref"],
            center=c["center"],
        )
    from fastsar import ffbp_cpu

    for suffix in ("", f" lanes{lanes}") if lanes else ("",):
        if lanes and suffix:
            with_lanes(lanes)
        for db in targets:
            former = fastsar.ImageFormer(*common, backend="cpu", window=False, target_db=db, ref=c["ref"])
            formers[f"imageformer{db:g}{suffix}"] = former
            LIBS[id(former)] = ffbp_cpu._lib
    return formers


def describe() -> dict[str, Any]:
    import fastsar
    from fastsar import ffbp_cpu

    flags, model = "", ""
    with open("/proc/cpuinfo") as fh:
        for line in fh:
            if line.startswith("model name") and not model:
                model = line.split(":", 1)[1].strip()
            if line.startswith("flags"):
                flags = line
                break
    return {
        "version": fastsar.__version__,
        "threads": int(ffbp_cpu.lib().ffbp_cpu_threads()),
        "omp_num_threads": os.environ.get("OMP_NUM_THREADS"),
        "cpu": model,
        "avx512f": " avx512f" in flags,
    }


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("case")
    ap.add_argument("out")
    ap.add_argument("--calls", type=int, default=2)
    ap.add_argument(
        "--factorised",
        type=float,
        nargs="*",
        default=[],
        help="also FastSAR's factorised ImageFormer at these target_db values (key imageformer<db>)",
    )
    ap.add_argument("--serve", action="store_true", help="time one call per former name read from stdin")
    ap.add_argument("--lanes", type=int, help="also the factorised former with this many floats per vector")
    a = ap.parse_args()

    c = np.load(a.case)
    S = c["S"]
    caught: list[str] = []
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        formers = build(c, a.factorised, a.lanes)
        images: dict[str, Any] = {}  # Any: numpy's savez stub would match an array to allow_pickle
        warm: dict[str, float] = {}
        for key, former in formers.items():  # untimed first calls: kernels compiled and loaded, buffers touched
            images[key], info = timed_call(former, S)
            warm[key] = info["time_s"]
        caught += [str(w.message) for w in rec]
    head: dict[str, Any] = describe()
    head.update(warnings=caught, first_call_s=warm)
    for key, former in formers.items():
        head.setdefault("predicted_error_db", {})[key] = former.predicted_error_db
        if hasattr(former, "T"):
            head.setdefault("final_tile", {})[key] = former.T
    if a.serve:
        print(json.dumps(head), flush=True)
        for line in sys.stdin:
            key = line.strip()
            if key == "quit":
                break
            if key == "save":
                np.savez(a.out, **images)
                print(json.dumps({"saved": a.out}), flush=True)
                continue
            with warnings.catch_warnings(record=True) as rec:
                warnings.simplefilter("always")
                images[key], info = timed_call(formers[key], S)
            info["warnings"] = [str(w.message) for w in rec]
            print(json.dumps(info), flush=True)
        return
    result: dict[str, Any] = dict(head)
    for key, former in formers.items():
        best: dict[str, Any] = {"time_s": np.inf}
        for _ in range(a.calls):
            images[key], info = timed_call(former, S)
            if info["time_s"] < best["time_s"]:
                best = info
        result[key] = best
    np.savez(a.out, **images)
    print(json.dumps(result))


if __name__ == "__main__":
    main()
