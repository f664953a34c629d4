"""evaluate's 3D kernels (:mod:`sarproc.quality.kernels`) compiled ahead of time, for small cubes.

Several of those kernels are parallel in numba; compiled ahead of time (:mod:`sarproc.product.aot`) they run
serially, so a cube pays for them only where its whole kernel work, serial, finishes before numba's start-up
would have: :func:`reserve` takes that decision once per evaluation from an estimate of the work (a big cube,
e.g. paper 004's, keeps numba's threads), and every call then goes to the module chosen (:func:`kernels`).
Each output element is computed by the same operations in the same order either way (prange as range; no
fast-math), so the results are equal bit for bit (tests/quality/test_kernels_aot.py). Importing this module
imports no numba.
"""

from __future__ import annotations

import os
from types import ModuleType

import numpy as np

from sarproc.product import aot
from sarproc.product.aot import Kernels

_IDEAL = "f8[::1], f8[:, ::1], f8[::1], f8[::1], f8[::1], f8[:, ::1], f8[::1], b1"
QUALITY = Kernels(
    name="quality",
    module="sarproc.quality.kernels",
    sources=("quality/kernels.py", "quality/kernels_aot.py"),
    exports={
        "orientation_density": "f8[::1](f8[:, ::1], f8[:, ::1], f8[::1], f8, i8[::1], i8[::1], f8[:, ::1], f8[::1])",
        "gradient_norms": ("_gradient_norms", "f8[:, :, ::1](f8[:, :, ::1], f8[::1])"),
        "strong_from_norms": (
            "_strong_from_norms",
            "Tuple((f8[:, ::1], f8[::1]))(f8[:, :, ::1], f8[::1], f8[:, :, ::1], f8)",
        ),
        "ideal_response": f"c16[::1](f8[:, ::1], {_IDEAL})",
        "ideal_response_serial": f"c16[::1](f8[:, ::1], {_IDEAL})",
        "ideal_response_box": f"c16[:, :, ::1](f8[::1], f8[::1], i8[::1], {_IDEAL})",
        "ideal_response_boxes": f"c16[::1](f8[:, ::1], f8[::1], i8[:, ::1], i8[::1], i8, {_IDEAL})",
        "ideal_response_boxes_slopes": f"c16[:, ::1](f8[:, ::1], f8[::1], i8[:, ::1], i8[::1], i8, {_IDEAL})",
        "spread": "c16[::1](c16[::1], f8[::1], i8, i8, f8, i8)",
        "cone_sum": "f8[::1](f8[:, ::1], f8[:, ::1], f8[::1], f8)",
    },
    owner="sarproc.quality.kernels_aot:QUALITY",
)
# The 3D orientation density leaves out a term whose unit vector lies farther from the candidate than
# 1 - cos^2 > DENSITY_PRUNE * sigma^2, i.e. below exp(-DENSITY_PRUNE / 2) = 3.7e-6 of its weight (the 2D densities:
# 80, exp(-40)). The density only locates its peaks (metrics._orientation_peaks): on paper 004's 14 chips the
# peaks, in order, are those of the unpruned density, and the 14 densities take 0.15 s instead of 0.32 s
# (session 37: the reach 20 deg -> 11 deg, a third of the pairs).
DENSITY_PRUNE = 25.0
# Serial seconds of the kernels per target and chip sample of a cube's evaluation: paper 004's cube (7 targets,
# chips of 131 x 105 x 41) runs 0.89 s of them through this module on the shared 2-core machine (session 25: the
# orientation density 0.41 s, the neighbours' boxes 0.23 s, the group fit's slopes 0.14 s; 1.1e-6 before the
# density's blocks and the boxes' tables); it only decides whether a cube runs them without numba.
SERIAL_S_PER_SAMPLE = 2.3e-7
# What a cube's evaluation pays to run these kernels through numba (session 25, a process with numpy, h5py and
# evaluate's modules loaded): numba's import 0.26 s, the first two kernels' loads with numba's BLAS check (scipy's
# linalg) and its threads 0.45 s, three more loads 0.03 s each. More than the 0.3 s :func:`aot.serial_pays` weighs
# for a stage's few kernels, so the estimate is scaled to it.
STARTUP_S = 0.8


def serial_estimate(targets: int, chip_samples: int) -> float:
    """The serial seconds :func:`reserve` weighs for ``targets`` chips of ``chip_samples``, scaled from
    :data:`STARTUP_S` to the start-up :func:`aot.serial_pays` weighs."""
    return SERIAL_S_PER_SAMPLE * targets * chip_samples * aot.NUMBA_STARTUP_S / STARTUP_S


def reserve(targets: int, chip_samples: int) -> ModuleType:
    """Choose, once for a cube's evaluation of ``targets`` chips of ``chip_samples``, the module its kernels run
    from (:meth:`Kernels.pick` with the whole estimate, weighed against :data:`STARTUP_S`: later calls keep that
    choice). Paper 004's cube runs them compiled on two CPUs (0.89 s serial against 0.5 s on two threads and
    numba's 0.8 s start), through numba on 16."""
    return QUALITY.pick(serial_estimate(targets, chip_samples))


def runs_compiled(targets: int, chip_samples: int) -> bool:
    """Whether a fresh process's :func:`reserve` would choose the compiled module (for a plan, before any run):
    it pays and it is built. Loads the module where built; imports no numba."""
    return aot.serial_pays(serial_estimate(targets, chip_samples)) and QUALITY.load() is not None


def kernels() -> ModuleType:
    """The module to call the 3D kernels from: the one :func:`reserve` chose (the compiled one while its serial
    budget lasts and numba's kernels are not loaded, else numba's)."""
    return QUALITY.pick(0.0)


def threads(k: ModuleType) -> int:
    """The chunks :func:`sarproc.quality.kernels.spread` sums separately: numba's thread count, also for the
    compiled module (the same sums in the same order), read without starting numba there."""
    if not QUALITY.is_compiled(k):
        import numba

        return int(numba.get_num_threads())
    return int(os.environ.get("NUMBA_NUM_THREADS") or aot.available_threads())


def strong_gradients(mag: np.ndarray, h: np.ndarray, fraction: float) -> tuple[np.ndarray, np.ndarray]:
    """:func:`sarproc.quality.kernels.strong_gradients` from the module :func:`kernels` gives (the compiled one
    runs its two parts in turn)."""
    k = kernels()
    mag, h = f8(mag), f8(h)
    if QUALITY.is_compiled(k):
        return k.strong_from_norms(mag, h, k.gradient_norms(mag, h), float(fraction))
    return k.strong_gradients(mag, h, float(fraction))


def f8(x: object) -> np.ndarray:
    return np.ascontiguousarray(x, dtype=np.float64)


def i8(x: object) -> np.ndarray:
    return np.ascontiguousarray(x, dtype=np.int64)
