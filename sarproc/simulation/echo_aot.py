"""The echo kernels (:mod:`sarproc.simulation.echo_kernel`) compiled ahead of time, for small simulations.

A small scene's echoes (the demo: ~1e8 target-samples) take a few hundredths of a second serially, less than
numba's start-up (~0.3 s a process); such a simulation runs the kernels compiled ahead of time
(:mod:`sarproc.product.aot`, serial: prange as range) without importing numba, once the module is built (in
the background, on the first small run). Pulses are independent rows and each sums its targets in order, so the
echoes equal numba's bit for bit (tested in tests/product/test_aot_kernels.py). They did not while the builder
wrote its own compiles of the kernels' callees into numba's cache (1 ulp, 2.9e-15 relative in complex128); it
now builds with a private cache (:func:`sarproc.product.aot.private_numba_cache`). Importing this module imports
no numba.
"""

from __future__ import annotations

from types import ModuleType

import numpy as np

from sarproc.product.aot import Kernels

_ACCUMULATE = (
    "(c8[:, ::1], f8[:, ::1], c16[:, ::1], f8[::1], f8, f8, f8, f8, f8, c16[::1])",
    "(c16[:, ::1], f8[:, ::1], c16[:, ::1], f8[::1], f8, f8, f8, f8, f8, c16[::1])",
)
ECHO = Kernels(
    name="echo",
    module="sarproc.simulation.echo_kernel",
    sources=("simulation/echo_kernel.py", "simulation/echo_aot.py"),
    exports={
        "window_chirp": "c16[::1](i8, f8, f8)",
        "_accumulate_echoes": "void" + _ACCUMULATE[0],
        "accumulate_echoes_c16": ("_accumulate_echoes", "void" + _ACCUMULATE[1]),
    },
    owner="sarproc.simulation.echo_aot:ECHO",
    slp=True,
)
# Serial target-samples (one pulse, one target, one window sample) per second of the echo kernel: an estimate,
# not a measurement (docs/performance.md, fifth round).
SERIAL_RATE = 4e8


def kernels(target_samples: float) -> ModuleType:
    """The module to run a simulation of ``target_samples`` (pulses x targets x samples per pulse, all channels)
    with: the compiled one where that pays and it is built, else numba's (:meth:`Kernels.pick`)."""
    return ECHO.pick(target_samples / SERIAL_RATE)


def window_chirp(k: ModuleType, n_range: int, fs: float, chirp_rate: float) -> np.ndarray:
    """:func:`sarproc.simulation.echo_kernel.window_chirp` from module ``k`` (from :func:`kernels`)."""
    return k.window_chirp(int(n_range), float(fs), float(chirp_rate))


def accumulate_echoes(k: ModuleType, out: np.ndarray, *args: object) -> None:
    """:func:`sarproc.simulation.echo_kernel.accumulate_echoes` from module ``k`` (same arguments; ``out``
    C-contiguous complex64 or complex128, the others as echo_block passes them)."""
    if not ECHO.is_compiled(k):
        k.accumulate_echoes(out, *args)
    elif out.dtype == np.complex64:
        k._accumulate_echoes(out, *args)
    else:
        k.accumulate_echoes_c16(out, *args)
