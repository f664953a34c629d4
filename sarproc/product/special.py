"""scipy.special's Fresnel integrals without importing ``scipy.special``.

``import scipy.special`` costs 0.2-0.4 s of a process's CPU (its array-API layer clones numpy's namespace,
loading numpy.testing, f2py and friends, and its ``xp_capabilities`` decorator parses docstrings): more than a
small image's whole evaluate besides it (docs/performance.md, "evaluate against the stage that made the image",
session 33). evaluate's bow fit calls one ufunc, ``fresnel``, which lives in scipy's extension
``scipy/special/_special_ufuncs`` (``scipy.special.fresnel`` is that ufunc object). This module loads that
extension from scipy's install directly (a few ms, as :mod:`sarproc.product.fft` loads pocketfft), so every value
is scipy's bit for bit (tests/product/test_special.py). Where the extension cannot be found or loaded (another
scipy layout, or a scipy whose extension lacks ``fresnel``), the ufunc is taken through ``import scipy.special``.
"""

from __future__ import annotations

from typing import Any

from sarproc.product.scipy_extension import load_extension

__all__ = ["fresnel"]


def _fresnel() -> Any:
    module = load_extension("special", "_special_ufuncs")
    ufunc = getattr(module, "fresnel", None)
    if ufunc is None:  # pragma: no cover - another scipy layout
        import scipy.special

        return scipy.special.fresnel
    return ufunc


fresnel = _fresnel()
"""(S(z), C(z)): scipy.special.fresnel's ufunc."""
