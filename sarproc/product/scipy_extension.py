"""One of scipy's compiled extensions loaded from its file, without importing the scipy subpackage around it.

scipy's Python layers cost a process 0.2-0.4 s of start-up (``scipy.linalg`` ~0.2 s, ``scipy.special`` 0.2-0.4 s:
docs/performance.md), more than a small image's evaluate besides them, while the calls evaluate makes live in a
few extensions (pocketfft, BLAS/LAPACK, the special ufuncs). Loading the extension itself takes a few ms and gives
scipy's own compiled functions, so every value is scipy's bit for bit. The callers fall back to the subpackage where
this returns None (another scipy layout).
"""

from __future__ import annotations

import os
from types import ModuleType

__all__ = ["load_extension"]


def load_extension(subpackage: str, name: str, needs: tuple[str, ...] = ()) -> ModuleType | None:
    """scipy's extension module ``name`` from the folder ``subpackage`` of its install ("linalg", "fft/_pocketfft"),
    loaded from its file; None where it cannot be found or loaded, or lacks one of the attributes ``needs``."""
    try:
        import importlib.machinery
        import importlib.util

        spec = importlib.util.find_spec("scipy")  # locates the package without importing it
        if spec is None or spec.origin is None:
            return None
        where = os.path.join(os.path.dirname(spec.origin), *subpackage.split("/"))
        suffixes = tuple(importlib.machinery.EXTENSION_SUFFIXES)
        path = next(
            os.path.join(where, f) for f in os.listdir(where) if f.startswith(name + ".") and f.endswith(suffixes)
        )
        loader = importlib.machinery.ExtensionFileLoader(name, path)
        ext_spec = importlib.util.spec_from_file_location(name, path, loader=loader)
        if ext_spec is None:
            return None
        module = importlib.util.module_from_spec(ext_spec)
        loader.exec_module(module)
    except Exception:  # any other layout or loader failure: the caller's fallback
        return None
    return module if all(hasattr(module, f) for f in needs) else None
