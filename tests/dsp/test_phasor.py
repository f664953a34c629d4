"""Compiled phasors and fused phase fields against numpy's float64 complex exponential."""

import numpy as np
import pytest

from sarproc.dsp.phasor import multiply_phase, multiply_separable_phase, unit_phasor
from sarproc.dsp.phasor_kernels import cis_cycles32, cis_cycles32_short


def test_quarter_cycle_polynomial_is_float32_exact():
    c = np.linspace(-0.5, 0.5, 2001).astype(np.float32)
    co, si = np.array([cis_cycles32(x) for x in c]).T
    assert np.abs(co + 1j * si - np.exp(2j * np.pi * c.astype(float))).max() < 5e-7


def test_short_polynomial_is_within_a_micro_radian_over_the_whole_cycle():
    """The backprojection's phasor: every float32 argument of [-1/2, 1/2] (quarter-cycle folds included)."""
    c = np.concatenate([np.linspace(-0.5, 0.5, 20001), [-0.25, 0.25, -0.5, 0.5, 0.0, 1e-9, -1e-9]]).astype(np.float32)
    co, si = np.array([cis_cycles32_short(x) for x in c]).T
    err = np.abs(co + 1j * si - np.exp(2j * np.pi * c.astype(float)))
    assert err.max() < 1e-6
    assert err.max() > 1e-8  # it is the shorter fit, not the exact one (the test can tell)


@pytest.mark.parametrize("dtype", [np.complex64, np.complex128])
def test_separable_phase_field_matches_numpy(dtype):
    rng = np.random.default_rng(0)
    x = (rng.standard_normal((37, 53)) + 1j * rng.standard_normal((37, 53))).astype(dtype)
    rows = rng.uniform(-1e3, 1e3, (3, 37))  # phases up to ~1e6 rad: float64 matters
    cols = rng.uniform(-1e3, 1e3, (3, 53))
    want = x * np.exp(1j * np.einsum("ki,kj->ij", rows, cols))
    got = multiply_separable_phase(x.copy(), rows, cols)
    assert got.dtype == dtype
    np.testing.assert_allclose(got, want, atol=2e-6 * np.abs(x).max())


def test_phase_field_with_mask_and_scale():
    rng = np.random.default_rng(1)
    x = (rng.standard_normal((20, 30)) + 1j * rng.standard_normal((20, 30))).astype(np.complex64)
    phase = rng.uniform(-1e5, 1e5, (20, 30))
    mask = rng.random((20, 30)) > 0.3
    want = np.where(mask, x * np.exp(1j * 2.5 * phase), 0)
    np.testing.assert_allclose(multiply_phase(x.copy(), phase, mask, scale=2.5), want, atol=2e-6 * np.abs(x).max())
    np.testing.assert_allclose(
        multiply_phase(x.copy(), phase / (2 * np.pi), cycles=True),
        x * unit_phasor(np.mod(phase / (2 * np.pi), 1.0)),
        atol=3e-6 * np.abs(x).max(),
    )


def test_shape_mismatch_is_refused():
    with pytest.raises(ValueError, match="do not match"):
        multiply_separable_phase(np.zeros((3, 4), np.complex64), np.zeros((1, 4)), np.zeros((1, 4)))
