"""fine_focus's compiled block copies and the fused Stolt phase equal the numpy sequences they replace, bit for bit."""

import numpy as np
import pytest

from sarproc.dsp.interp import resample_rows
from sarproc.dsp.phasor import multiply_phase
from sarproc.focus.squint_deramp.block_copies import (
    copy_rows,
    gather_columns,
    pad_rows,
    pad_spectrum,
    scale_rows,
)
from sarproc.focus.squint_deramp.compiled import crop_columns
from sarproc.focus.squint_deramp.stolt import SpectrumModel


def _cx(rng, shape, dtype=np.complex64):
    return (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)).astype(dtype)


def _alt(x, start):
    y = x.copy()
    if start >= 0:
        y[..., start::2] *= -1
    return y


DTYPES = [np.complex64, np.complex128]


@pytest.mark.parametrize("dtype", DTYPES)
@pytest.mark.parametrize("start", [-1, 0, 1])
def test_pad_copy_and_scale_rows(dtype, start):
    rng = np.random.default_rng(start + 5)
    x = _cx(rng, (9, 13), dtype)
    dst = np.full((9, 20), 7 + 7j, dtype)
    pad_rows(x, dst, start)
    want = np.zeros((9, 20), dtype)
    want[:, :13] = _alt(x, start)
    assert np.array_equal(dst, want)
    pad_rows(np.asfortranarray(x), dst, start)  # any layout of the input
    assert np.array_equal(dst, want)

    f = _cx(rng, 9, dtype)
    y = x.copy()
    scale_rows(y, f, start)
    if dtype is np.complex64:
        assert np.array_equal(y, _alt(x * f[:, None], start))  # numpy's rounding of the product
    else:  # numpy fuses the complex128 product
        np.testing.assert_allclose(y, _alt(x * f[:, None], start), rtol=1e-15)

    out = np.empty_like(x)
    copy_rows(x, out, start)
    assert np.array_equal(out, _alt(x, start))


@pytest.mark.parametrize("n, m", [(8, 8), (8, 13), (7, 12), (7, 7)])
@pytest.mark.parametrize("scaled", [False, True])
def test_pad_spectrum_keeps_both_halves(n, m, scaled):
    rng = np.random.default_rng(n * m)
    x = _cx(rng, (5, n))
    ref = _cx(rng, n) if scaled else np.ones(0, np.complex64)
    for start in (-1, 1):
        y = _alt(x, start) * (ref if scaled else 1)
        want = np.zeros((5, m), np.complex64)
        want[:, : (n + 1) // 2] = y[:, : (n + 1) // 2]
        if n // 2:
            want[:, m - n // 2 :] = y[:, n - n // 2 :]
        dst = np.full((5, m), 3j, np.complex64)
        pad_spectrum(x, dst, ref, start)
        assert np.array_equal(dst, want)


def test_gather_columns_and_crop():
    rng = np.random.default_rng(3)
    img = _cx(rng, (6, 11))
    cols = np.array([4, 0, 10, 7])
    out = np.zeros((4, 15), np.complex64)
    gather_columns(img, cols, out, 5)
    want = np.zeros((4, 15), np.complex64)
    want[:, 5:11] = img[:, cols].T
    assert np.array_equal(out, want)

    c, finite = crop_columns(img.astype(np.complex128), 2, 9)
    assert c.dtype == np.complex64 and c.flags.c_contiguous and finite
    assert np.array_equal(c, img.astype(np.complex128)[:, 2:9].astype(np.complex64))
    img[3, 8] = np.nan
    assert not crop_columns(img, 2, 9)[1]
    assert crop_columns(img, 2, 8)[1]  # the NaN lies outside the kept columns
    img[0, 2] = complex(0, np.inf)
    assert not crop_columns(img, 2, 8)[1]
    assert crop_columns(img, 0, 0)[0].shape == (6, 0)


@pytest.mark.parametrize("model", ["exact", "paper"])
@pytest.mark.parametrize("dtype", DTYPES)
def test_rotate_equals_multiply_phase_of_G(model, dtype):
    m = SpectrumModel(10e9, 7000.0, np.radians(30), model)
    rng = np.random.default_rng(1)
    f = 10e9 + np.linspace(-90e6, 90e6, 257)
    f_a = np.linspace(-1.05, 1.05, 33) * m.f_aM  # rows past the square-root limit included
    x = _cx(rng, (len(f_a), len(f)), dtype)
    pre = _cx(rng, len(f), dtype)
    g, ok = m.G(f[None, :], f_a[:, None])
    assert not ok.all()
    want = multiply_phase(x * pre[None, :], g, ok, scale=3e5)
    got = m.rotate(x.copy(), f, f_a, 3e5, pre=pre)
    if dtype is np.complex64:
        assert np.array_equal(got, want)
    else:  # numpy fuses the complex128 product
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-14 * np.abs(want).max())
    assert np.array_equal(m.rotate(x.copy(), f, f_a, 3e5), multiply_phase(x.copy(), g, ok, scale=3e5))
    with pytest.raises(ValueError):
        m.rotate(np.asfortranarray(x), f, f_a, 1.0)


def test_resample_rows_into_a_buffer():
    rng = np.random.default_rng(2)
    x = _cx(rng, (4, 40))
    pos = rng.uniform(-2, 42, (4, 40))
    want = resample_rows(x, pos, "knab", 8)
    buf = np.empty_like(x)
    assert resample_rows(x, pos, "knab", 8, out=buf) is buf
    assert np.array_equal(buf, want)
    with pytest.raises(ValueError):
        resample_rows(x, pos, "knab", 8, out=x)
    with pytest.raises(ValueError):
        resample_rows(x, pos, "knab", 8, out=np.empty((4, 39), np.complex64))


# --- review: the compiled copies do no bounds checks, so their shapes are checked up front ------------------------


def test_pad_spectrum_refuses_a_shorter_destination():
    """m < n used to write both halves over each other (silently wrong), docstring said '(or crop)'."""
    src = np.ones((2, 8), np.complex64)
    with pytest.raises(ValueError):
        pad_spectrum(src, np.zeros((2, 6), np.complex64), np.ones(0, np.complex64), -1)
    with pytest.raises(ValueError):
        pad_spectrum(src, np.zeros((3, 8), np.complex64), np.ones(0, np.complex64), -1)
    with pytest.raises(ValueError):
        pad_spectrum(src, np.zeros((2, 8), np.complex64), np.ones(5, np.complex64), -1)


def test_pad_rows_refuses_a_shorter_destination():
    """n > m used to write past the end of each row (here into the parent's spare columns)."""
    big = np.zeros((2, 10), np.complex64)
    with pytest.raises(ValueError):
        pad_rows(np.ones((2, 8), np.complex64), big[:, :6], -1)
    assert not big.any()
    with pytest.raises(ValueError):
        pad_rows(np.ones((1, 4), np.complex64), np.zeros((2, 6), np.complex64), -1)  # rows read past src


def test_copy_and_gather_refuse_mismatched_shapes():
    with pytest.raises(ValueError):
        copy_rows(np.ones((2, 4), np.complex64), np.zeros((2, 3), np.complex64), -1)
    with pytest.raises(ValueError):
        gather_columns(np.ones((4, 3), np.complex64), np.array([0, 3]), np.zeros((2, 8), np.complex64), 0)
    with pytest.raises(ValueError):
        gather_columns(np.ones((4, 3), np.complex64), np.array([0, 2]), np.zeros((2, 8), np.complex64), 5)
