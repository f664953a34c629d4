"""sarproc.product.linalg: scipy's BLAS and LAPACK extensions loaded without scipy.linalg give scipy.linalg's
results bit for bit (evaluate's least-squares fits go through them)."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
import scipy.linalg

from sarproc.product import linalg


def _spd(rng: np.random.Generator, n: int, dtype: type) -> np.ndarray:
    b = rng.standard_normal((3 * n, n))
    if np.dtype(dtype).kind == "c":
        b = b + 1j * rng.standard_normal((3 * n, n))
    return (b.conj().T @ b).astype(dtype)


@pytest.mark.parametrize("dtype", [np.float64, np.complex128, np.float32, np.complex64])
@pytest.mark.parametrize("lower", [False, True])
def test_cholesky_factor_and_solve_equal_scipys(dtype, lower):
    rng = np.random.default_rng(7)
    for n in (1, 5, 40):
        a = _spd(rng, n, dtype)
        ours, theirs = linalg.cho_factor(a, lower=lower), scipy.linalg.cho_factor(a, lower=lower)
        assert ours[1] == theirs[1] == lower
        assert ours[0].dtype == theirs[0].dtype and np.array_equal(ours[0], theirs[0])
        for b in (rng.standard_normal(n), rng.standard_normal((n, 3)) + 1j * rng.standard_normal((n, 3))):
            x, y = linalg.cho_solve(ours, b), scipy.linalg.cho_solve(theirs, b)
            assert x.dtype == y.dtype and np.array_equal(x, y)


def test_inputs_are_not_overwritten_and_refusals_match():
    rng = np.random.default_rng(8)
    a = _spd(rng, 6, np.float64)
    keep = a.copy()
    c = linalg.cho_factor(a)
    b = rng.standard_normal(6)
    keep_b = b.copy()
    linalg.cho_solve(c, b)
    assert np.array_equal(a, keep) and np.array_equal(b, keep_b)
    with pytest.raises(np.linalg.LinAlgError):
        linalg.cho_factor(-a)
    with pytest.raises(scipy.linalg.LinAlgError):  # the same class scipy raises
        linalg.cho_factor(-a)
    bad = a.copy()
    bad[2, 3] = np.nan
    with pytest.raises(ValueError):
        linalg.cho_factor(bad)


def test_rank_k_updates_equal_scipys():
    rng = np.random.default_rng(9)
    bt = rng.standard_normal((7, 300))
    ours, theirs = linalg.blas.dsyrk(1.0, bt, trans=0, lower=0), scipy.linalg.blas.dsyrk(1.0, bt, trans=0, lower=0)
    assert np.array_equal(ours, theirs)
    bz = bt + 1j * rng.standard_normal((7, 300))
    ours, theirs = linalg.blas.zherk(1.0, bz, trans=0, lower=0), scipy.linalg.blas.zherk(1.0, bz, trans=0, lower=0)
    assert np.array_equal(ours, theirs)


def test_loads_without_importing_scipy_linalg():
    code = "import sys, sarproc.product.linalg as l; assert l.blas.__name__ == '_fblas'; print(sorted(sys.modules))"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert "scipy.linalg" not in done.stdout


def test_evaluates_least_squares_imports_no_scipy_linalg():
    """evaluate's fit (metrics.least_squares) through these wrappers: the Cholesky path without scipy.linalg,
    and the same solution as numpy's SVD solver to rounding."""
    code = (
        "import sys, numpy as np\nfrom sarproc.quality import blas, metrics\n"
        "rng = np.random.default_rng(3)\nB = rng.standard_normal((200, 6)) + 1j * rng.standard_normal((200, 6))\n"
        "y = rng.standard_normal(200) + 0j\n"
        "with blas.one_blas_thread():\n    x = metrics.least_squares(B, y)\n"
        "ref = np.linalg.lstsq(B, y, rcond=None)[0]\n"
        "assert np.allclose(x, ref, rtol=1e-12, atol=0), abs(x - ref).max()\n"
        "print('scipy.linalg' in sys.modules)"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=False)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.strip() == "False"
