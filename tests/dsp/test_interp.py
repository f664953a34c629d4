"""resample_rows (Stolt, RCMC, flow-1 resampling) against a direct, unvectorised evaluation of its kernels."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from sarproc.dsp.interp import KERNELS, TABULATED, kernel_length, kernel_weights, resample_rows


def direct(row, positions, kernel, taps, oversampling):
    """One output at a time: taps around floor(p) (nearest: round(p)), zeros outside the row, tabulated
    kernels renormalised to unit DC gain, NaN or far-outside positions give 0."""
    n = len(row)
    pad = taps + 1
    out = np.zeros(len(positions), complex)
    for k, p in enumerate(positions):
        if not np.isfinite(p) or p < -pad / 2 or p > n - 1 + pad / 2:
            continue
        if kernel == "nearest":
            idx = np.array([int(np.floor(p + 0.5))])
        else:
            idx = int(np.floor(p)) + np.arange(-(taps // 2) + 1, taps // 2 + 1)
        w = kernel_weights(p - idx, kernel, taps, oversampling=oversampling)
        vals = np.array([row[i] if 0 <= i < n else 0.0 for i in idx])
        total = w.sum()
        out[k] = (w * vals).sum() / (total if kernel in TABULATED and total > 0 else 1.0)
    return out


@settings(max_examples=40, deadline=None)
@given(
    kernel=st.sampled_from(KERNELS),
    taps=st.sampled_from([4, 8, 16]),
    seed=st.integers(0, 2**31 - 1),
    n_in=st.integers(3, 40),
    oversampling=st.floats(1.1, 3.0),
)
def test_vectorised_rows_match_the_direct_sum(kernel, taps, seed, n_in, oversampling):
    rng = np.random.default_rng(seed)
    taps = kernel_length(kernel, taps if kernel in TABULATED else None)
    data = (rng.standard_normal((3, n_in)) + 1j * rng.standard_normal((3, n_in))).astype(np.complex64)
    # inside, at integers, near and beyond both edges, and NaN
    pos = rng.uniform(-taps, n_in - 1 + taps, (3, 12))
    pos[:, 0] = np.round(pos[:, 0])
    pos[0, 1] = np.nan
    got = resample_rows(data, pos, kernel, taps, oversampling=oversampling)
    assert got.dtype == np.complex64
    want = np.array([direct(data[i].astype(complex), pos[i], kernel, taps, oversampling) for i in range(3)])
    # the table is linearly interpolated (2048 steps a sample) and the arithmetic is float32
    np.testing.assert_allclose(got, want, atol=2e-5 * np.abs(data).max() * taps)


@pytest.mark.parametrize("dtype", [np.complex64, np.float32])
def test_precision_follows_the_data(dtype):
    """Single-precision data stay single (no silent complex128 temporaries in the output) and agree
    with the double-precision result to float32 accuracy."""
    n = np.arange(64)
    x = np.cos(2 * np.pi * 0.05 * n) + (0.5j * np.sin(2 * np.pi * 0.11 * n) if np.iscomplexobj(dtype(0)) else 0)
    pos = np.linspace(-2.0, 65.0, 301)[None, :]
    lo = resample_rows(x.astype(dtype)[None, :], pos, "knab", 8)
    hi = resample_rows(x[None, :], pos, "knab", 8)
    assert lo.dtype == dtype and hi.dtype == x.dtype
    np.testing.assert_allclose(lo, hi, atol=1e-6)
