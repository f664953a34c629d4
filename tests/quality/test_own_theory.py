"""Each target's own theory (sarproc.product.theory): windows, weighted supports, antenna illumination."""

import math

import numpy as np
import pytest
from test_metrics import reference_metrics

from sarproc.product import theory
from sarproc.product.frames import make_frame
from sarproc.product.metadata import RadarMetadata


def test_windows_theory_is_the_fourier_integral_of_their_taper():
    # the unweighted band gives the contract's numbers; every window agrees with an independent dense integral
    flat = theory.window_theory("none")
    assert flat.null == 1.0
    assert flat.irw == pytest.approx(0.8859, abs=2e-4)
    assert flat.pslr_db == pytest.approx(-13.26, abs=0.01) and flat.islr_db == pytest.approx(-10.16, abs=0.01)
    for name in theory.WINDOWS:
        th = theory.window_theory(name)
        ref = reference_metrics(1.0, lambda f, n=name: theory.window_taper(n, f), k=256)
        assert th.irw == pytest.approx(ref["irw"], rel=1e-3), name
        assert th.pslr_db == pytest.approx(ref["pslr_db"], abs=0.05), name
        assert th.islr_db == pytest.approx(ref["islr_db"], abs=0.05), name
    assert theory.window_theory("hamming").factor == pytest.approx(1.30, abs=0.005)


def test_sample_taper_is_numpys_hamming():
    np.testing.assert_allclose(theory.sample_taper("hamming", 257), np.hamming(257), atol=1e-12)
    np.testing.assert_array_equal(theory.sample_taper("none", 5), np.ones(5))


def test_binned_support_matches_the_exact_sum():
    # a long, non-uniform, asymmetric support (a pattern skirt cut by the track end) binned onto 512 cells
    k = np.sort(np.random.default_rng(1).uniform(-0.3, 0.7, 5000))
    w = np.sinc(1.3 * k) ** 2
    binned = theory.response_theory(k, w)
    exact = theory.response_theory(k, w, samples=len(k))
    assert binned.irw == pytest.approx(exact.irw, rel=1e-3)
    assert binned.pslr_db == pytest.approx(exact.pslr_db, abs=0.1)
    assert binned.islr_db == pytest.approx(exact.islr_db, abs=0.1)
    assert binned.null == exact.null == pytest.approx(1 / (k.max() - k.min()))


def test_bad_support_is_refused():
    with pytest.raises(ValueError, match="positive weight"):
        theory.response_theory([0.0, 1.0], [0.0, 0.0])
    with pytest.raises(ValueError, match="extent"):
        theory.response_theory([0.5, 0.5], [1.0, 1.0])


def _stripmap(pattern, prf=1000.0):
    radar = RadarMetadata(
        carrier_frequency=10e9,
        bandwidth=100e6,
        pulse_duration=5e-6,
        chirp_rate=2e13,
        range_sampling_rate=120e6,
        prf=prf,
        velocity=100.0,
        altitude=500.0,
        squint=0.0,
        reference_range=2000.0,
        scene_center=(0.0, math.sqrt(2000.0**2 - 500.0**2), 0.0),
        mode="stripmap",
        azimuth_beamwidth=math.radians(2),
        antenna_pattern=pattern,
    )
    t = (np.arange(int(prf)) - int(prf) // 2) / prf
    pos = np.stack([100.0 * t, 0 * t, np.full_like(t, 500.0)], axis=1)
    return radar, pos, make_frame("zero_doppler", radar)


def test_rect_beam_target_theory_is_the_lit_aperture():
    # a rect beam lights a flat stretch of aperture: 0.886 / (k extent of the lit pulses), sinc side lobes;
    # the k of each pulse along the azimuth ridge (where the range band's phase, the line of sight at the
    # illumination centre, stands still; here all but the azimuth axis: 4e-5 off it at 40 m)
    radar, pos, frame = _stripmap("rect")
    for az in (0.0, 40.0):
        centre = frame.from_xyz(np.asarray(radar.scene_center))
        coords = (az, float(centre[1]))
        p0 = frame.to_xyz(*coords).reshape(3)
        lit = theory.illumination(radar, pos, p0).in_beam
        u = (p0 - pos) / np.linalg.norm(p0 - pos, axis=1)[:, None]
        e = (frame.to_xyz(az + 1e-3, coords[1]).reshape(3) - p0) / 1e-3
        e_r = (frame.to_xyz(az, coords[1] + 1e-3).reshape(3) - p0) / 1e-3
        u_c = u[int(np.round(np.flatnonzero(lit).mean()))]
        k = 2 * (u[lit] @ (e - (u_c @ e) / (u_c @ e_r) * e_r)) / radar.wavelength
        th = theory.target_theory(radar, pos, pos, frame, coords)
        cell = np.median(np.diff(np.sort(k)))  # each lit pulse a cell of the band
        assert th[0].null == pytest.approx(1 / (k.max() - k.min() + cell), rel=1e-9)
        assert th[0].irw == pytest.approx(0.886 / (k.max() - k.min()), rel=0.005)
        assert th[0].pslr_db == pytest.approx(-13.26, abs=0.1)
        assert th[1].irw == pytest.approx(0.8859 * 3e8 / (2 * 100e6), rel=0.01)  # near broadside


@pytest.mark.parametrize("prf", [20.0, 55.0])
def test_rect_beam_null_is_the_first_null_of_the_lit_pulses_response(prf):
    # N lit pulses respond as a Dirichlet kernel, zero 1 / (N dk) from the peak; the band between the end pulses,
    # (N - 1) dk, put the null 1 / (N - 1) of a null too far (paper 004's 39 pulses: 2.6 %, and neighbour models
    # drawn with it misplaced side lobes a third of a lobe twelve nulls out)
    radar, pos, frame = _stripmap("rect", prf=prf)
    centre = frame.from_xyz(np.asarray(radar.scene_center))
    coords = (0.0, float(centre[1]))
    p0 = frame.to_xyz(*coords).reshape(3)
    lit = theory.illumination(radar, pos, p0).in_beam
    u = (p0 - pos[lit]) / np.linalg.norm(p0 - pos[lit], axis=1)[:, None]
    e = (frame.to_xyz(1e-3, coords[1]).reshape(3) - p0) / 1e-3
    k = 2 * (u @ e) / radar.wavelength
    th = theory.target_theory(radar, pos, pos, frame, coords)

    def response(x: float) -> float:
        return abs(np.exp(2j * np.pi * k * x).sum()) / len(k)

    assert 10 <= len(k) <= 40
    assert response(th[0].null) < 0.01
    assert response(-th[0].null) < 0.01


def test_hamming_azimuth_taper_and_range_window_broaden_by_their_factor():
    radar, pos, frame = _stripmap(None)  # no pattern recorded: flat over the -3 dB beam
    radar = radar.replace(azimuth_beamwidth=0.0)  # and here no beam at all: every pulse, flat
    coords = tuple(frame.from_xyz(np.asarray(radar.scene_center)))
    plain = theory.target_theory(radar, pos, pos, frame, coords)
    ham = theory.target_theory(radar, pos, pos, frame, coords, azimuth_window="hamming", range_window="hamming")
    # the flat aperture's band counts its N pulses as cells, the window's spans its end pulses (sample_band)
    n = len(pos)
    assert ham[0].null == pytest.approx(plain[0].null * n / (n - 1), rel=1e-6)
    assert ham[1].null == pytest.approx(plain[1].null, rel=1e-6)
    for a in range(2):
        assert ham[a].irw / plain[a].irw == pytest.approx(1.3030 / 0.8859, rel=0.003)
        assert ham[a].pslr_db == pytest.approx(-42.7, abs=0.2)


def test_unweighted_image_theory_is_the_targets_median():
    th = [[theory.ResponseTheory(irw=1.3 * n, null=n, pslr_db=-42.0, islr_db=-36.0)] for n in (1.0, 1.1, 9.0)]
    assert theory.unweighted_irw(th, [5.0]) == [pytest.approx(0.886 * 1.1)]
    assert theory.unweighted_irw([], [5.0]) == [5.0]


@pytest.mark.parametrize("n", [2, 3, 8, 32])
def test_array_elevation_theory_is_the_array_factor_seen_from_the_target(n):
    # array3d's per-target elevation theory: the receivers' array factor (its own -3 dB width, eq. 26) at
    # nadir, widened by 1 / cos(theta) off nadir (the array resolves sin(theta)); short arrays keep their
    # grating lobes (0 dB within +-10 nulls)
    from sarproc.focus.array3d.linear_array import elevation_irw, target_theory_3d

    v, lam = np.arange(n) * 0.1, 0.03
    nadir, off = target_theory_3d(v, lam, [0.0, 0.3], [1.0, 2.0])
    assert nadir[0].irw == pytest.approx(elevation_irw(v, lam), rel=2e-3)
    assert off[0].irw * math.cos(0.3) == pytest.approx(nadir[0].irw, rel=1e-9)
    assert nadir[0].null == pytest.approx(lam / (n * 0.1), rel=1e-9)
    assert (nadir[0].pslr_db == pytest.approx(0.0, abs=1e-6)) == (n < 10)
    assert nadir[1].irw == pytest.approx(0.8859 / 0.886, rel=1e-3) and nadir[2].irw == pytest.approx(
        2 * 0.8859 / 0.886, rel=1e-3
    )
