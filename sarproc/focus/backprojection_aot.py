"""The compiled backprojection's linear path without numba: the kernels of
:mod:`sarproc.focus.backprojection_kernel` compiled ahead of time (:mod:`sarproc.product.aot`), for small images.

pycc compiles no parallel loops, so each call runs serially; the calls release the GIL, and the caller spreads
them over threads (tables by pulses, sums by groups of tiles: sarproc.focus.backprojection). It serves images
up to a few seconds of work (:func:`compiled_pays`), where it saves numba's start-up (~0.3 s a process:
import, kernel loads, threads); bigger images, the other interpolations and runs where the module is missing
keep the numba kernels. Both run the same Python source (prange as range here), so the images agree to float
rounding (equal in the tests). Run as ``python -m sarproc.focus.backprojection_aot KEY`` it builds the module
(started in the background by :func:`request_build`).

Importing this module imports no numba.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path
from types import ModuleType

import numpy as np

from sarproc.product import aot

NAME = "backprojection"
BUILDER = "sarproc.focus.backprojection_aot"
SOURCES = [
    Path(__file__).with_name("backprojection_kernel.py"),
    Path(__file__).parents[1] / "dsp" / "phasor_kernels.py",  # its phasor polynomials are inlined into the kernel
    Path(__file__),  # EXPORTS: a module built before an export was added lacks it
]
# Export name -> (kernel in backprojection_kernel, signature): the argument types _backproject_compiled passes
# (C-contiguous arrays). A call with other types raises TypeError in the compiled module.
EXPORTS = {
    "bounds": ("bounds", "UniTuple(f8[::1], 2)(f8[:, ::1])"),
    "tile_layout": (
        "_tile_layout",
        "Tuple((i8[::1], i8[::1], f8[:, ::1], f4[:, ::1], i8[::1]))(f8[:, ::1], f8[::1], f8[::1], f8[::1], f8, i8, i8)",
    ),
    "pulse_windows": (
        "pulse_windows",
        "UniTuple(i8[::1], 2)(f8[::1], f8, f8[:, ::1], f8[:, ::1], b1, f8[:, ::1], f8[::1], i8, i8)",
    ),
    "pair_table": ("pair_table", "void(c8[:, ::1], i8[::1], f4[:, :, ::1])"),
    "backproject_tiles": (
        "backproject_tiles",
        "void(c8[:, ::1], f4[:, :, ::1], f8[::1], f8, f8, f8[:, ::1], f8[:, ::1], b1, f8[:, ::1], i8[::1], "
        "i8[::1], f4[:, ::1], i8, f4[:, ::1], i8, c16[::1])",
    ),
    "scatter_scaled": ("scatter_scaled", "void(c16[::1], i8[::1], f8, c16[::1])"),
}

# Serial pixel-pulses per second of the linear kernel (measured on the reference machine, 2.3-2.6e8: the
# per-process table in docs/performance.md) and numba's start-up a process saves without it, s.
SERIAL_RATE = 2.5e8
NUMBA_STARTUP_S = 0.3
# Longest expected run of the compiled module on threads, s: it ran at numba's parallel rate on 256^2 to 1024^2
# grids here (2 threads; docs/performance.md, tenth round), where numba's start-up is >= 15 % of the work;
# beyond, the numba kernels (rates on more cores and bigger grids not measured).
COMPILED_MAX_S = 2.0


def available_threads() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def compiled_pays(pixel_pulses: float, workers: int | None = None) -> bool:
    """Whether to run the compiled module on ``workers`` threads (default: the CPUs this process may use)
    rather than numba's parallel kernel: on one thread always (numba's threads would save nothing), else while
    its expected time (serial rate, 90 % efficient threads) is at most :data:`COMPILED_MAX_S`."""
    threads = int(workers) if workers else available_threads()
    return threads <= 1 or pixel_pulses / (SERIAL_RATE * 0.9 * threads) <= COMPILED_MAX_S


def load() -> ModuleType | None:
    """The compiled module, or None while it is not built (or building is off, or it failed)."""
    return aot.load(NAME, SOURCES)


def request_build() -> bool:
    """Start building the module in the background (once; see :func:`sarproc.product.aot.request_build`)."""
    return aot.request_build(NAME, SOURCES, BUILDER)


def make_tiles(
    points: np.ndarray, tile_size: float, k: ModuleType, max_tile: int = 1024, block: int = 1
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`sarproc.focus.backprojection_kernel.make_tiles` on the compiled module ``k`` (the same steps;
    tested equal)."""
    points = np.ascontiguousarray(np.asarray(points, float).reshape(-1, 3))
    if len(points) == 0:
        return (
            np.zeros(0, np.int64),
            np.zeros(1, np.int64),
            np.zeros((0, 3)),
            np.zeros(3),
            np.zeros((4, 0), np.float32),
            np.zeros(1, np.int64),
        )
    if not np.isfinite(points).all():
        raise ValueError("points must be finite")
    lo, hi = k.bounds(points)
    origin = 0.5 * (lo + hi)
    order, tile_start, centres, d, block_start = k.tile_layout(
        points, origin, lo - origin, hi - origin, float(tile_size), int(max_tile), int(block)
    )
    return order, tile_start, centres, origin, d, block_start


def build(key: str) -> Path:
    """Compile the module for ``key`` (which must be the current sources' key)."""
    if key != aot.module_key(SOURCES):
        aot.release_lock()
        raise RuntimeError(f"stale build request {key}: the kernels' sources changed")
    from sarproc.focus import backprojection_kernel as bk

    return aot.build(NAME, key, {export: (getattr(bk, kernel), sig) for export, (kernel, sig) in EXPORTS.items()})


if __name__ == "__main__":  # pragma: no cover - the background builder (run by the tests as a command)
    # numba's cache in a throwaway directory: the callees the build compiles differ in the last bits from a plain
    # process's, and written to the user's cache they would change later numba images (aot.private_numba_cache)
    with aot.private_numba_cache():
        build(sys.argv[1])
