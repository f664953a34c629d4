"""Least squares of evaluate's fits (kept apart from :mod:`sarproc.quality.metrics`, which imports the residual's
module: both take it from here at import time)."""

from __future__ import annotations

import numpy as np

from sarproc.quality.blas import limit_loaded


def least_squares(B: np.ndarray, y: np.ndarray, exact: bool = False) -> np.ndarray:
    """Least-squares solution of B x = y (B tall, full column rank; y one vector or one column per system).

    Through the normal equations of the column-equilibrated B (unit-norm columns, Cholesky) with two
    steps of iterative refinement (which restore the accuracy the squared condition number costs): on the
    tall systems of 3D boxes several times faster than an SVD; ``exact`` (or a Gram matrix that is not
    numerically positive definite) takes numpy's SVD solver, the reference the fast path is tested against.
    The Gram matrix is one BLAS rank-k update of B as stored (no conjugated or scaled copy of B) and the
    columns are equilibrated on it (their norms are its diagonal)."""
    if not exact:
        # scipy's BLAS and LAPACK without importing scipy.linalg (~0.2 s): only where a least-squares fit runs
        from sarproc.product.linalg import blas, cho_factor, cho_solve

        limit_loaded()  # scipy's own BLAS, loaded just now: one thread like numpy's

        B = np.asarray(B)
        y = np.asarray(y)
        complex_ = np.iscomplexobj(B)
        Bt = np.asarray(B.T, dtype=np.complex128 if complex_ else np.float64)
        # B^T conj(B) (upper triangle) from B's rows as they lie in memory; its conjugate is B^H B
        gram = blas.zherk(1.0, Bt, trans=0, lower=0).conj() if complex_ else blas.dsyrk(1.0, Bt, trans=0, lower=0)
        scale = np.sqrt(np.real(np.diagonal(gram)))
        scale[scale == 0] = 1.0
        try:
            factor = cho_factor(gram / np.outer(scale, scale), lower=False)
        except np.linalg.LinAlgError:
            factor = None
        if factor is not None:
            pivots = np.abs(np.diag(factor[0]))
            if not pivots.min() > 1e-7 * pivots.max():  # Gram condition beyond ~1e14 (e.g. equal columns)
                factor = None
        if factor is not None:
            col = scale if y.ndim == 1 else scale[:, None]  # y: one right-hand side or a column per system

            def adjoint(r: np.ndarray) -> np.ndarray:  # B^H r / scale, without conjugating B
                return (Bt @ r.conj()).conj() / col if complex_ else (Bt @ r) / col

            x = cho_solve(factor, adjoint(y))
            for _ in range(2):  # iterative refinement: the normal equations' squared condition number undone
                x = x + cho_solve(factor, adjoint(y - B @ (x / col)))
            return x / col
    return np.linalg.lstsq(B, y, rcond=None)[0]
