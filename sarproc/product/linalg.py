"""scipy's BLAS and LAPACK wrappers for evaluate's least-squares fits, without importing ``scipy.linalg``.

``import scipy.linalg`` costs ~0.2 s of a process's start after numpy and the JIT compiler (measured: `python -c` with
``time.perf_counter()`` around the import, three runs 0.20-0.27 s), more than the fits it serves on a small
image. What the fits call are four routines of scipy's f2py extensions (``scipy/linalg/_fblas*.so`` and
``_flapack*.so``): the Gram matrix's rank-k update (``dsyrk`` / ``zherk``) and the Cholesky factorisation and
solve (``potrf`` / ``potrs``). This module loads those two extensions from scipy's install directly (a few ms,
as :mod:`sarproc.product.fft` loads pocketfft) and wraps the two LAPACK calls as ``scipy.linalg.cho_factor``
and ``cho_solve`` do (scipy 1.17 ``_decomp_cholesky.py``: finiteness check, prefix from the arrays' types, the
same arguments), so the results are scipy's bit for bit (tests/product/test_linalg.py). Where the extensions
cannot be found or loaded (another scipy layout), ``scipy.linalg``'s own are used.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from sarproc.product.scipy_extension import load_extension

__all__ = ["blas", "cho_factor", "cho_solve", "lapack"]


def _modules() -> tuple[Any, Any]:
    fblas, flapack = load_extension("linalg", "_fblas"), load_extension("linalg", "_flapack")
    if fblas is None or flapack is None or not hasattr(flapack, "dpotrf"):  # pragma: no cover - other layout
        from scipy.linalg import _fblas, _flapack

        return _fblas, _flapack
    return fblas, flapack


blas, lapack = _modules()

# scipy.linalg.blas.find_best_blas_type's scores and prefixes (scipy/linalg/blas.py)
_SCORE = {**dict.fromkeys("?bBhHef", 1), **dict.fromkeys("iIlLqQdg", 2), "F": 3, "D": 4, "G": 4}
_PREFIX = {1: "s", 2: "d", 3: "c", 4: "z"}


def _prefix(*arrays: np.ndarray) -> str:
    """The LAPACK prefix scipy picks for ``arrays`` (the most generic type; complex64 with float64: 'z')."""
    scores = [_SCORE.get(a.dtype.char, 5) for a in arrays]
    best = max(scores)
    if best == 3 and 2 in scores:
        best = 4
    return _PREFIX.get(best, "d")


def _copied(arr: np.ndarray, original: Any) -> bool:
    """scipy.linalg._misc._datacopied: ``arr`` (= asarray(original)) shares no data with ``original``."""
    if arr is original or (not isinstance(original, np.ndarray) and hasattr(original, "__array__")):
        return False
    return arr.base is None


def cho_factor(a: Any, lower: bool = False) -> tuple[np.ndarray, bool]:
    """``scipy.linalg.cho_factor(a, lower)`` of a square 2-D array (the triangle not referenced is left as
    it was); raises ``numpy.linalg.LinAlgError`` where ``a`` is not positive definite, ``ValueError`` where it
    holds a NaN or infinity."""
    a1 = np.atleast_2d(np.asarray_chkfinite(a))
    if a1.ndim != 2 or a1.shape[0] != a1.shape[1] or a1.size == 0:
        raise ValueError(f"cho_factor needs a non-empty square matrix, not shape {a1.shape}")
    potrf = getattr(lapack, _prefix(a1) + "potrf")
    c, info = potrf(a1, lower=lower, overwrite_a=_copied(a1, a), clean=False)
    if info > 0:
        raise np.linalg.LinAlgError(f"{info}-th leading minor of the array is not positive definite")
    if info < 0:
        raise ValueError(f'LAPACK reported an illegal value in {-info}-th argument on entry to "POTRF".')
    return c, lower


def cho_solve(c_and_lower: tuple[np.ndarray, bool], b: Any) -> np.ndarray:
    """``scipy.linalg.cho_solve((c, lower), b)``: x with A x = b for b of shape (n,) or (n, k)."""
    c, lower = c_and_lower
    b1 = np.asarray_chkfinite(b)
    c = np.asarray_chkfinite(c)
    if c.ndim != 2 or c.shape[0] != c.shape[1]:
        raise ValueError("The factored matrix c is not square.")
    if c.shape[1] != b1.shape[0] or b1.size == 0:
        raise ValueError(f"incompatible or empty dimensions ({c.shape} and {b1.shape})")
    potrs = getattr(lapack, _prefix(c, b1) + "potrs")
    x, info = potrs(c, b1, lower=lower, overwrite_b=_copied(b1, b))
    if info != 0:
        raise ValueError(f"illegal value in {-info}th argument of internal potrs")
    return x
