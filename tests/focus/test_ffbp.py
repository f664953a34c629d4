"""Fast factorised backprojection: the exact image within its predicted error, targets at theory, the knob."""

import copy
import dataclasses
from pathlib import Path

import numpy as np
import pytest

from helpers import assert_theory
from sarproc.focus.backprojection import BackprojectParams, backproject
from sarproc.focus.ffbp import (
    error_bound,
    ffbp_points,
    interpolation_error,
    predicted_error,
    predicted_image_error,
    pulse_oversample,
)
from sarproc.product.config import load_yaml
from sarproc.product.errors import InputError
from sarproc.product.frames import make_frame
from sarproc.quality.metrics import evaluate_product
from sarproc.simulation.scene import scene_from_mapping
from sarproc.simulation.simulate import simulate

CONFIGS = Path(__file__).resolve().parents[2] / "configs"
STRIPMAP = load_yaml(CONFIGS / "bp_stripmap.yaml")
SQUINT30 = load_yaml(CONFIGS / "bp_squint30.yaml")
# Broadside spotlight on a wobbling track (tests/simulation/test_effects.py): 0.5 m cross-track, 0.2 m vertical.
MOTION = {
    **copy.deepcopy(SQUINT30),
    "geometry": {"reference_range": "6 km", "squint": "0 deg"},
    "effects": {
        "platform_motion": {
            "cross_track_amplitude": "0.5 m",
            "cross_track_period": "0.2 s",
            "cross_track_phase": "30 deg",
            "vertical_amplitude": "0.2 m",
            "vertical_period": "0.3 s",
            "along_track_velocity_error": "0.5 m/s",
        }
    },
}


def pulses_q(raw, upsample=8):
    """The upsampled pulses' rate over the bandwidth (linear reads of them: the exact image's own artefacts)."""
    r = raw.radar
    return pulse_oversample(raw.data.shape[1], upsample, r.range_sampling_rate, r.bandwidth)


def grid_points(raw, image, frame):
    """The image's pixels as points (n, 3) and its grid shape."""
    az, rg = np.meshgrid(image.coords["azimuth"], image.coords["range"], indexing="ij")
    return make_frame(frame, raw.radar).to_xyz(az.ravel(), rg.ravel()), az.shape


def predicted(raw, image, p, **changes):
    """predicted_image_error of ffbp with params p (and ``changes`` to them) on the image's grid."""
    p = dataclasses.replace(p, **changes)
    pts, shape = grid_points(raw, image, p.frame)
    r = raw.radar
    return predicted_image_error(
        raw.aux["platform_position"],
        pts,
        r.carrier_frequency,
        r.bandwidth,
        grid_shape=shape,
        factor=p.ffbp_factor,
        first_factor=p.ffbp_first_factor,
        oversample=p.ffbp_oversample,
        ffbp_interpolation=p.ffbp_interpolation,
        ffbp_taps=p.ffbp_taps,
        pulse_oversample=pulses_q(raw, p.range_upsample),
        pulse_interpolation=p.interpolation,
    )


def nmse(image, exact):
    return float(np.sum(np.abs(image - exact) ** 2) / np.sum(np.abs(exact) ** 2))


@pytest.fixture(
    scope="module",
    params=[(STRIPMAP, "zero_doppler"), (SQUINT30, "los"), (MOTION, "los")],
    ids=["broadside-stripmap", "squint30-spotlight", "curved-track"],
)
def case(request):
    scene, frame = request.param
    raw = simulate(scene_from_mapping(scene))
    params = BackprojectParams(frame=frame, margin_cells=28)
    return raw, params, backproject(raw, params)


# the first version's reads (cubic Lagrange, factor 4 from the pulses on) and the default Knab reads
CUBIC = {"ffbp_interpolation": "cubic", "ffbp_first_factor": 4}
KNAB = {"ffbp_interpolation": "knab", "ffbp_taps": 8, "ffbp_first_factor": 16}
KNAB10 = {"ffbp_interpolation": "knab", "ffbp_taps": 10, "ffbp_first_factor": 16}  # the defaults until 2026-12-02
KNAB12 = {"ffbp_interpolation": "knab", "ffbp_taps": 12, "ffbp_first_factor": 16}  # the defaults (q = 1.5)


@pytest.mark.parametrize(
    "reads, oversamples",
    [(CUBIC, (2.0, 3.0, 4.0)), (KNAB, (1.5, 2.0)), (KNAB10, (1.75,)), (KNAB12, (1.5,))],
    ids=["cubic", "knab8-first16", "knab10-first16", "knab12-first16"],
)
def test_ffbp_error_against_the_exact_image_is_the_predicted_one(case, reads, oversamples):
    raw, params, exact = case
    for q in oversamples:
        p = dataclasses.replace(params, engine="ffbp", ffbp_oversample=q, **reads)
        measured = nmse(backproject(raw, p).data, exact.data)
        expected = predicted(raw, exact, p)
        # below the bound (the model + 4 dB) and no more than 6 dB under the model: the prediction means something
        assert expected / 4 < measured < error_bound(expected), (q, 10 * np.log10(measured), 10 * np.log10(expected))


@pytest.mark.parametrize(
    "reads, q", [(CUBIC, 4.0), (KNAB10, 1.75), (KNAB12, 1.5)], ids=["cubic-q4", "knab10-q1.75", "knab12-q1.5"]
)
def test_ffbp_targets_reach_theory(case, reads, q):
    raw, params, _ = case
    image = backproject(raw, dataclasses.replace(params, engine="ffbp", ffbp_oversample=q, **reads))
    report = evaluate_product(image)
    assert_theory(report, irw_tol=0.03, db_tol=0.3, pos_cells=0.05, n_targets=3)


def test_ffbp_oversample_trades_error_for_work():
    raw = simulate(scene_from_mapping(SQUINT30))
    params = BackprojectParams(frame="los", azimuth_extent=60.0, range_extent=60.0)
    exact = backproject(raw, params).data
    from sarproc.dsp.rangecomp import range_compress
    from sarproc.product.frames import make_frame

    frame = make_frame("los", raw.radar)
    img = backproject(raw, params)
    az, rg = np.meshgrid(img.coords["azimuth"], img.coords["range"], indexing="ij")
    pts = frame.to_xyz(az.ravel(), rg.ravel())
    rc = range_compress(raw.data, raw.radar)
    errors, work = [], []
    for q in (1.5, 2.0, 3.0, 4.0):
        info = {}
        out = ffbp_points(
            rc,
            raw.coords["range_time"],
            raw.aux["platform_position"],
            pts,
            raw.radar.carrier_frequency,
            raw.radar.bandwidth,
            oversample=q,
            ffbp_interpolation="cubic",
            grid_shape=az.shape,
            info=info,
        )
        errors.append(nmse(out.reshape(az.shape), exact))
        work.append(sum(info["samples"]))
    assert all(a > 4 * b for a, b in zip(errors, errors[1:])), errors  # each step: > 6 dB better
    assert all(a < b for a, b in zip(work, work[1:])), work
    assert errors[-1] < 10**-4  # -40 dB at 4x oversampling


def test_a_fine_output_grid_is_read_on_a_coarse_one_and_upsampled():
    """Pixels 6 per IRW: the top image is read on a grid at its own bandwidth (far fewer points) and upsampled;
    the image stays within the predicted error of the exact one."""
    raw = simulate(scene_from_mapping(SQUINT30))
    params = BackprojectParams(frame="los", azimuth_extent=40.0, range_extent=40.0, oversample=6.0)
    img = backproject(raw, params)
    exact = img.data
    from sarproc.dsp.rangecomp import range_compress
    from sarproc.product.frames import make_frame

    frame = make_frame("los", raw.radar)
    az, rg = np.meshgrid(img.coords["azimuth"], img.coords["range"], indexing="ij")
    pts = frame.to_xyz(az.ravel(), rg.ravel())
    rc = range_compress(raw.data, raw.radar)
    info = {}
    out = ffbp_points(
        rc,
        raw.coords["range_time"],
        raw.aux["platform_position"],
        pts,
        raw.radar.carrier_frequency,
        raw.radar.bandwidth,
        oversample=2.0,
        first_factor=16,
        ffbp_taps=8,
        grid_shape=az.shape,
        info=info,
    )
    assert np.prod(info["cartesian"]) * 4 < az.size  # the coarse grid: over 4x fewer points than the output
    measured = nmse(out.reshape(az.shape), exact)
    expected = predicted(raw, img, params, ffbp_oversample=2.0, ffbp_first_factor=16, ffbp_taps=8)
    assert expected / 4 < measured < error_bound(expected), (10 * np.log10(measured), 10 * np.log10(expected))


def test_two_runs_give_identical_images():
    """ffbp's sums do not depend on the run (thread timing, buffers): the coarse-grid path and the polar one,
    each called twice in one process, give the same image bit for bit."""
    from sarproc.dsp.rangecomp import range_compress
    from sarproc.product.frames import make_frame

    raw = simulate(scene_from_mapping(SQUINT30))
    rc = range_compress(raw.data, raw.radar)
    frame = make_frame("los", raw.radar)
    for oversample in (6.0, 2.0):  # pixels per IRW: 6 takes the coarse grid, 2 reads the top image at each pixel
        params = BackprojectParams(frame="los", azimuth_extent=40.0, range_extent=40.0, oversample=oversample)
        img = backproject(raw, dataclasses.replace(params, engine="compiled"))
        az, rg = np.meshgrid(img.coords["azimuth"], img.coords["range"], indexing="ij")
        pts = frame.to_xyz(az.ravel(), rg.ravel())
        runs = []
        for _ in range(2):
            info: dict = {}
            runs.append(
                ffbp_points(
                    rc,
                    raw.coords["range_time"],
                    raw.aux["platform_position"],
                    pts,
                    raw.radar.carrier_frequency,
                    raw.radar.bandwidth,
                    grid_shape=az.shape,
                    info=info,
                )
            )
        assert (info.get("cartesian") is not None) == (oversample == 6.0), info.get("cartesian")
        np.testing.assert_array_equal(runs[0], runs[1])


def test_interpolation_error_falls_with_oversampling_and_order():
    cubic = [interpolation_error(q, "cubic") for q in (1.5, 2, 3, 4)]
    linear = [interpolation_error(q, "linear") for q in (1.5, 2, 3, 4)]
    assert all(a > b for a, b in zip(cubic, cubic[1:])) and all(c < li for c, li in zip(cubic, linear))
    # Lagrange cubic error ~ f^4: twice the oversampling, ~ 2^8 less power (24 dB)
    assert 10 * np.log10(cubic[1] / cubic[3]) == pytest.approx(24, abs=2)


def test_ffbp_refuses_a_bistatic_product():
    raw = simulate(scene_from_mapping(SQUINT30))
    bistatic = dataclasses.replace(raw, aux={**raw.aux, "rx_offset": np.array([[0.0, 1.0, 0.0]])})
    with pytest.raises(InputError, match="engine: ffbp needs a monostatic"):
        backproject(bistatic, BackprojectParams(frame="los", engine="ffbp", azimuth_extent=10.0, range_extent=10.0))


def test_plan_prints_the_predicted_error_and_the_cli_runs_ffbp(tmp_path):
    import subprocess
    import sys

    import yaml

    from sarproc.product.io import read_product

    scene = {
        **copy.deepcopy(SQUINT30),
        "backproject": {
            "frame": "los",
            "azimuth_extent": "20 m",
            "range_extent": "20 m",
            "engine": "ffbp",
            "ffbp_oversample": 3,
            "ffbp_interpolation": "cubic",
            "ffbp_first_factor": 4,
        },
    }
    (tmp_path / "s.yaml").write_text(yaml.safe_dump(scene))
    cmd = [sys.executable, "-m", "sarproc"]
    subprocess.run(
        cmd + ["simulate", str(tmp_path / "s.yaml"), "-o", str(tmp_path / "r.h5"), "--no-progress"],
        check=True,
        capture_output=True,
    )
    out = subprocess.run(
        cmd
        + [
            "-v",
            "backproject",
            str(tmp_path / "r.h5"),
            "--config",
            str(tmp_path / "s.yaml"),
            "-o",
            str(tmp_path / "i.h5"),
            "--no-progress",
        ],
        capture_output=True,
        text=True,
    )
    assert out.returncode == 0, out.stderr
    raw, image = read_product(tmp_path / "r.h5"), read_product(tmp_path / "i.h5")
    p = BackprojectParams(
        frame="los",
        engine="ffbp",
        ffbp_oversample=3,
        ffbp_interpolation="cubic",
        ffbp_first_factor=4,
    )
    # the plan predicts on the grid the run writes, with the geometry's own tree (not the broadside model)
    on_grid = 10 * np.log10(predicted(raw, image, p))
    broadside = 10 * np.log10(predicted_error(212, 4, 3.0, "cubic", first_factor=4, pulse_oversample=pulses_q(raw)))
    assert abs(on_grid - broadside) > 0.1
    assert (
        f"ffbp: 4 levels of 4, oversample 3, cubic; predicted error against the exact image {on_grid:.1f} dB"
        in out.stderr
    )
    assert image.history[-1]["parameters"]["engine"] == "ffbp"


def test_ffbp_refuses_points_off_a_plane():
    pts = np.array([[0.0, 0, 0], [10, 0, 0], [0, 10, 0], [10, 10, 1.0]])
    rc = np.zeros((4, 16), np.complex64)
    pos = np.array([[0.0, -1000, 500]] * 4) + np.arange(4)[:, None] * [1.0, 0, 0]
    with pytest.raises(ValueError, match="ffbp needs the points on a plane"):
        ffbp_points(rc, np.arange(16) * 1e-8, pos, pts, 10e9, 100e6)


def test_a_regular_grid_is_read_from_its_lattice_and_any_other_point_set_point_by_point():
    """A regular grid takes its plane coordinates from its lattice (no pass over all points); the same points
    without their grid shape (read point by point, plane fitted) give the same image, and a grid with one point
    off its lattice falls back to reading every point where it is."""
    from sarproc.dsp.rangecomp import range_compress
    from sarproc.focus.backprojection import backproject_points
    from sarproc.product.frames import make_frame

    raw = simulate(scene_from_mapping(SQUINT30))
    img = backproject(raw, BackprojectParams(frame="los", azimuth_extent=30.0, range_extent=30.0))
    az, rg = np.meshgrid(img.coords["azimuth"], img.coords["range"], indexing="ij")
    pts = make_frame("los", raw.radar).to_xyz(az.ravel(), rg.ravel())
    rc = range_compress(raw.data, raw.radar)
    args = (rc, raw.coords["range_time"], raw.aux["platform_position"])
    common = dict(first_factor=16, ffbp_taps=10, oversample=1.75)
    fc, bw = raw.radar.carrier_frequency, raw.radar.bandwidth
    lattice = ffbp_points(*args, pts, fc, bw, grid_shape=az.shape, **common)
    loose = ffbp_points(*args, pts, fc, bw, **common)
    predicted = predicted_error(raw.data.shape[0], 4, 1.75, "knab", 10, 16, pulses_q(raw))
    # the two polar trees span slightly different sectors (grid edges, convex hull): their reads differ, the
    # pulses' artefacts (most of the prediction) are common
    assert nmse(lattice, loose) < predicted / 10
    moved = pts.copy()
    k = az.size // 2 + az.shape[1] // 3
    moved[k] += 0.4 * (pts[1] - pts[0]) + 0.3 * (pts[az.shape[1]] - pts[0])  # in the plane, off the lattice
    out = ffbp_points(*args, moved, fc, bw, grid_shape=az.shape, **common)
    exact = backproject_points(rc, args[1], args[2], args[2], moved[k - 2 : k + 3], fc, engine="compiled")
    assert nmse(out[k - 2 : k + 3], exact) < error_bound(predicted)
    assert nmse(out[k - 2 : k + 3], lattice[k - 2 : k + 3]) > 100 * error_bound(predicted)  # it did move


def test_ffbp_reads_the_pulses_cubic_as_the_exact_engine_does():
    """interpolation: cubic (four-sample Lagrange on the x8 pulses) in both engines: ffbp's error against that
    exact image is the predicted one, far below the linear reads' floor."""
    raw = simulate(scene_from_mapping(SQUINT30))
    params = BackprojectParams(frame="los", azimuth_extent=40.0, range_extent=40.0, interpolation="cubic", upsample=8)
    exact = backproject(raw, params)
    image = backproject(raw, dataclasses.replace(params, engine="ffbp")).data
    measured = nmse(image, exact.data)
    expected = predicted(raw, exact, params)
    linear_floor = predicted(raw, exact, params, interpolation="linear")
    assert expected / 4 < measured < error_bound(expected), (10 * np.log10(measured), 10 * np.log10(expected))
    assert measured < linear_floor / 4


def test_the_lattice_read_samples_the_range_band_of_the_range_grid():
    """With range oversampling below the angle's (range_oversample), the coarse Cartesian grid the lattice is read
    on must sample the radial band of the range grid: sized by the angle's oversampling it undersamples it and
    the lattice's image parts from the point-by-point read of the same points."""
    from sarproc.dsp.rangecomp import range_compress
    from sarproc.product.frames import make_frame

    raw = simulate(scene_from_mapping(SQUINT30))
    img = backproject(raw, BackprojectParams(frame="los", azimuth_extent=10.0, range_extent=10.0))
    # four times the default grid's density: fine enough for the coarse grid to pay
    fine = [np.linspace(c[0], c[-1], 4 * len(c)) for c in (img.coords["azimuth"], img.coords["range"])]
    az, rg = np.meshgrid(*fine, indexing="ij")
    pts = make_frame("los", raw.radar).to_xyz(az.ravel(), rg.ravel())
    args = (range_compress(raw.data, raw.radar), raw.coords["range_time"], raw.aux["platform_position"])
    common = dict(first_factor=16, ffbp_taps=10, oversample=3.0, range_oversample=1.25)
    fc, bw = raw.radar.carrier_frequency, raw.radar.bandwidth
    info: dict = {}
    lattice = ffbp_points(*args, pts, fc, bw, grid_shape=az.shape, info=info, **common)
    assert "cartesian" in info  # read on the coarse grid
    loose = ffbp_points(*args, pts, fc, bw, **common)
    assert nmse(lattice, loose) < 1e-4, 10 * np.log10(nmse(lattice, loose))
