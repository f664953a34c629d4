"""Where numba keeps the compiled kernels: :mod:`sarproc.product.kernel_cache` (moved there so that every
layer, quality included, can decorate its kernels with ``cache=CACHE``); re-exported for the dsp, focus and
simulation kernels that import it from here."""

from __future__ import annotations

from sarproc.product.kernel_cache import (
    CACHE,
    default_locator_works,
    lean_cache_loads,
    private_temp_cache,
    slp_vectorized,
)

__all__ = ["CACHE", "default_locator_works", "lean_cache_loads", "private_temp_cache", "slp_vectorized"]
