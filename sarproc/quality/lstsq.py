"""Least squares of evaluate's fits (kept apart from :mod:`sarproc.quality.metrics`, which imports the residual's
module: both take it from here at import time)."""

from __future__ import annotations

import numpy as np

from sarproc.quality.blas import limit_loaded


class NormalEquations:
    """The least squares of one tall matrix B (full column rank) for any right-hand side, B's Gram matrix formed
    and factorised once: a Gauss-Newton step solves for the same bases as the amplitudes that accepted them.

    Through the normal equations of the column-equilibrated B (unit-norm columns, Cholesky) with two
    steps of iterative refinement (which restore the accuracy the squared condition number costs): on the
    tall systems of 3D boxes several times faster than an SVD; a Gram matrix that is not numerically positive
    definite takes numpy's SVD solver, the reference the fast path is tested against. The Gram matrix is one
    BLAS rank-k update of B as stored (no conjugated or scaled copy of B) and the columns are equilibrated on it
    (their norms are its diagonal)."""

    def __init__(self, B: np.ndarray) -> None:
        # scipy's BLAS and LAPACK without importing scipy.linalg (~0.2 s): only where a least-squares fit runs
        from sarproc.product.linalg import blas, cho_factor

        limit_loaded()  # scipy's own BLAS, loaded just now: one thread like numpy's

        self.B = B = np.asarray(B)
        self.complex = complex_ = np.iscomplexobj(B)
        self.Bt = Bt = np.asarray(B.T, dtype=np.complex128 if complex_ else np.float64)
        # B^T conj(B) (upper triangle) from B's rows as they lie in memory; its conjugate is B^H B
        gram = blas.zherk(1.0, Bt, trans=0, lower=0).conj() if complex_ else blas.dsyrk(1.0, Bt, trans=0, lower=0)
        scale = np.sqrt(np.real(np.diagonal(gram)))
        scale[scale == 0] = 1.0
        self.scale = scale
        factor: tuple[np.ndarray, bool] | None
        try:
            factor = cho_factor(gram / np.outer(scale, scale), lower=False)
        except np.linalg.LinAlgError:
            factor = None
        if factor is not None:
            pivots = np.abs(np.diag(factor[0]))
            if not pivots.min() > 1e-7 * pivots.max():  # Gram condition beyond ~1e14 (e.g. equal columns)
                factor = None
        self.factor = factor

    def solve(self, y: np.ndarray) -> np.ndarray:
        """x minimising |B x - y| (y one vector or one column per system)."""
        from sarproc.product.linalg import cho_solve

        y = np.asarray(y)
        if self.factor is None:
            return np.linalg.lstsq(self.B, y, rcond=None)[0]
        B, Bt, complex_, factor = self.B, self.Bt, self.complex, self.factor
        col = self.scale if y.ndim == 1 else self.scale[:, None]  # y: one right-hand side or a column per system

        def adjoint(r: np.ndarray) -> np.ndarray:  # B^H r / scale, without conjugating B
            return (Bt @ r.conj()).conj() / col if complex_ else (Bt @ r) / col

        x = cho_solve(factor, adjoint(y))
        for _ in range(2):  # iterative refinement: the normal equations' squared condition number undone
            x = x + cho_solve(factor, adjoint(y - B @ (x / col)))
        return x / col


def least_squares(B: np.ndarray, y: np.ndarray, exact: bool = False) -> np.ndarray:
    """Least-squares solution of B x = y (B tall, full column rank; y one vector or one column per system):
    :class:`NormalEquations`, or with ``exact`` numpy's SVD solver."""
    if not exact:
        return NormalEquations(B).solve(y)
    return np.linalg.lstsq(B, y, rcond=None)[0]
