"""sarproc.product.fft: scipy.fft's pocketfft without importing scipy.fft, bit for bit scipy.fft's results."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
import scipy.fft

from sarproc.product import fft as sfft

RNG = np.random.default_rng(7)
C64 = (RNG.standard_normal((6, 40)) + 1j * RNG.standard_normal((6, 40))).astype(np.complex64)
C128 = RNG.standard_normal((5, 7, 33)) + 1j * RNG.standard_normal((5, 7, 33))
F32 = RNG.standard_normal((8, 30)).astype(np.float32)
F64 = RNG.standard_normal(45)
INT = np.arange(24).reshape(4, 6)

CASES_1D = [
    (C64, {}),
    (C64, {"axis": 0}),
    (C64, {"n": 64}),  # zero padding
    (C64, {"n": 25, "axis": -1}),  # truncation
    (C64[:, ::3], {"workers": -1}),  # strided input
    (C128, {"axis": 1, "norm": "ortho"}),
    (C128, {"norm": "forward", "workers": 2}),
    (F32, {}),  # real input, float32 stays single precision
    (F64, {"n": 50}),
    (INT, {"axis": 0}),
    (C64.T, {}),  # Fortran order
]


@pytest.mark.parametrize(("x", "kw"), CASES_1D)
@pytest.mark.parametrize("name", ["fft", "ifft"])
def test_one_dimensional_transforms_are_scipys_bit_for_bit(name, x, kw):
    got = getattr(sfft, name)(x, **kw)
    want = getattr(scipy.fft, name)(x, **kw)
    assert got.dtype == want.dtype and got.shape == want.shape
    assert got.tobytes() == want.tobytes()


CASES_ND = [
    (C64, {}),
    (C64, {"s": (8, 48)}),
    (C128, {"axes": (0, 2)}),
    (C128, {"s": (4, 40), "axes": (-1, 0), "norm": "ortho", "workers": -1}),
    (F32, {}),
]


@pytest.mark.parametrize(("x", "kw"), CASES_ND)
@pytest.mark.parametrize("name", ["fft2", "ifft2", "fftn", "ifftn"])
def test_multidimensional_transforms_are_scipys_bit_for_bit(name, x, kw):
    if name.endswith("2") and "axes" not in kw and x.ndim < 2:
        pytest.skip("2-D transform of a 1-D array")
    got = getattr(sfft, name)(x, **kw)
    want = getattr(scipy.fft, name)(x, **kw)
    assert got.dtype == want.dtype and got.shape == want.shape
    assert got.tobytes() == want.tobytes()


@pytest.mark.parametrize(
    ("box_shape", "start", "shape"),
    [
        ((65, 53, 21), (33, 26, 10), (131, 105, 41)),  # paper 004's windowed chip: prime sizes
        ((3, 9), (0, 20), (14, 29)),  # the box at an edge
        ((12, 13), (4, 5), (40, 42)),  # a 2D chip zero-padded 2x
        ((7,), (2,), (16,)),
    ],
)
@pytest.mark.parametrize("workers", [None, -1])
def test_fftn_of_a_box_is_fftn_of_the_zero_filled_array_bit_for_bit(box_shape, start, shape, workers):
    x = RNG.standard_normal(box_shape) + 1j * RNG.standard_normal(box_shape)
    full = np.zeros(shape, dtype=complex)
    full[tuple(slice(s, s + n) for s, n in zip(start, box_shape))] = x
    got = sfft.fftn_of_box(x, start, shape, workers=workers)
    assert got.dtype == np.complex128
    np.testing.assert_array_equal(got, sfft.fftn(full, workers=workers))


@pytest.mark.parametrize(
    "shape",
    [
        (12000, 33),  # reconstruct's null fit: 4 channels x 3000 pulses, a 33-cell window
        (9000, 17),  # 3 channels, a window cut at the swath's edge
        (12004, 31),  # 3001 (prime) pulses: Bluestein
        (97, 13),  # primes both ways
        (64, 1),
    ],
)
@pytest.mark.parametrize("dtype", [np.complex64, np.complex128])
@pytest.mark.parametrize("workers", [None, -1])
def test_ifft2_rows_are_the_rows_of_ifft2_bit_for_bit(shape, dtype, workers):
    """Ifft2Rows: ifft2's normalisation is applied in its first (axis 0) pass, each line transformed on its own."""
    x = (RNG.standard_normal(shape) + 1j * RNG.standard_normal(shape)).astype(dtype)
    want = scipy.fft.ifft2(x, workers=workers)
    rows = sfft.Ifft2Rows(x, workers=workers)
    for pick in (np.arange(-12, 13) % shape[0], np.array([shape[0] - 1, 0, 0]), slice(3, 9)):
        got = rows[pick]
        assert got.dtype == want.dtype
        assert got.tobytes() == want[pick].tobytes()
    with pytest.raises(ValueError, match="2-D complex"):
        sfft.Ifft2Rows(x.real)


def test_overwrite_x_transforms_in_place_like_scipy():
    a, b = C64.copy(), C64.copy()
    got = sfft.fft(a, overwrite_x=True)
    want = scipy.fft.fft(b, overwrite_x=True)
    assert got.tobytes() == want.tobytes()
    assert np.shares_memory(got, a) == np.shares_memory(want, b)


def test_helpers_and_errors_match_scipy():
    for n in (1, 7, 1001, 6483, 17287, np.int64(2161)):
        assert sfft.next_fast_len(n) == scipy.fft.next_fast_len(n)
        assert sfft.next_fast_len(n, True) == scipy.fft.next_fast_len(n, True)
    assert np.array_equal(sfft.fftfreq(9, 0.5), scipy.fft.fftfreq(9, 0.5))
    assert np.array_equal(sfft.fftshift(C64, axes=1), scipy.fft.fftshift(C64, axes=1))
    assert np.array_equal(sfft.ifftshift(F64), scipy.fft.ifftshift(F64))
    for call in (lambda m: m.fft(C64, n=0), lambda m: m.fft(C64, norm="bad"), lambda m: m.fft(C64, workers=0)):
        with pytest.raises(ValueError):
            call(scipy.fft)
        with pytest.raises(ValueError):
            call(sfft)


def test_importing_it_leaves_scipy_fft_unimported():
    code = "import sys, sarproc.product.fft as f; f.fft([1, 2, 3]); print('scipy.fft' in sys.modules, f._pfft.__name__)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.split() == ["False", "pypocketfft"]


def test_extension_loaded_from_its_file_not_through_scipy_fft():
    # the wrappers under test call the directly loaded extension even though scipy.fft is imported here
    assert sfft._pfft is not scipy.fft._pocketfft.pypocketfft and sfft._pfft.__name__ == "pypocketfft"


def test_self_check_accepts_this_scipy_and_rejects_a_changed_extension(monkeypatch):
    """The private extension is used only while it reproduces numpy's transforms (else: public scipy.fft)."""
    import sarproc.product.fft as sfft_mod

    assert sfft_mod._agrees_with_numpy()

    class Changed:  # an extension whose c2c takes other arguments, as a future scipy might
        @staticmethod
        def c2c(*args, **kwargs):
            raise TypeError("c2c() got an unexpected keyword argument")

        good_size = staticmethod(sfft_mod._pfft.good_size)

    monkeypatch.setattr(sfft_mod, "_pfft", Changed)
    assert not sfft_mod._agrees_with_numpy()
