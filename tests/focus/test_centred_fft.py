"""fine_focus's centred DFTs (in-place (-1)^n modulations for even lengths) equal the shift-FFT-shift form."""

import numpy as np
import pytest
import scipy.fft as sfft

from sarproc.focus.squint_deramp.fine_focus import cfft, cifft


@pytest.mark.parametrize("shape", [(8, 6), (10, 12), (7, 9), (6, 5)])
@pytest.mark.parametrize("axis", [0, 1])
def test_centred_transforms_match_the_shifted_ones(shape, axis):
    rng = np.random.default_rng(sum(shape) + axis)
    x = (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)).astype(np.complex64)
    want = sfft.fftshift(sfft.fft(sfft.ifftshift(x, axes=axis), axis=axis), axes=axis)
    want_i = sfft.fftshift(sfft.ifft(sfft.ifftshift(x, axes=axis), axis=axis), axes=axis)
    keep = x.copy()
    np.testing.assert_allclose(cfft(x, axis), want, atol=1e-5)
    np.testing.assert_allclose(cifft(x, axis), want_i, atol=1e-6)
    assert np.array_equal(x, keep)  # not overwritten unless asked
    np.testing.assert_allclose(cfft(x.copy(), axis, overwrite=True), want, atol=1e-5)
