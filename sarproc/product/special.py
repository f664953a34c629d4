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

import os
from types import ModuleType
from typing import Any

__all__ = ["fresnel"]


def _load_special_ufuncs() -> ModuleType | None:
    """scipy.special's ``_special_ufuncs`` extension loaded from its file; None if not."""
    try:
        import importlib.machinery
        import importlib.util

        spec = importlib.util.find_spec("scipy")  # locates the package without importing it
        if spec is None or spec.origin is None:
            return None
        where = os.path.join(os.path.dirname(spec.origin), "special")
        suffixes = tuple(importlib.machinery.EXTENSION_SUFFIXES)
        files = [f for f in os.listdir(where) if f.startswith("_special_ufuncs.") and f.endswith(suffixes)]
        path = os.path.join(where, files[0])
        loader = importlib.machinery.ExtensionFileLoader("_special_ufuncs", path)
        ext_spec = importlib.util.spec_from_file_location("_special_ufuncs", path, loader=loader)
        if ext_spec is None:
            return None
        module = importlib.util.module_from_spec(ext_spec)
        loader.exec_module(module)
        return module
    except Exception:  # any other layout or loader failure: scipy.special's
        return None


def _fresnel() -> Any:
    module = _load_special_ufuncs()
    ufunc = getattr(module, "fresnel", None)
    if ufunc is None:  # pragma: no cover - another scipy layout
        import scipy.special

        return scipy.special.fresnel
    return ufunc


fresnel = _fresnel()
"""(S(z), C(z)): scipy.special.fresnel's ufunc."""
