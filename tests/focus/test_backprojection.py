"""Backprojection is the reference: it must reach theory on simulated point targets."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from helpers import assert_theory
from sarproc.dsp.rangecomp import range_compress
from sarproc.focus.backprojection import (
    BackprojectParams,
    backproject,
    backproject_points,
    plan_backprojection as bp_plan,
    pulse_set as bp_pulses,
    warn_ambiguities as bp_warn,
)
from sarproc.product.config import load_yaml
from sarproc.product.metadata import SINC_IRW_FACTOR
from sarproc.quality.metrics import evaluate_product
from sarproc.simulation.scene import scene_from_mapping
from sarproc.simulation.simulate import simulate

CONFIGS = Path(__file__).resolve().parents[2] / "configs"
STRIPMAP = load_yaml(CONFIGS / "bp_stripmap.yaml")
SQUINT_SPOTLIGHT = load_yaml(CONFIGS / "bp_squint30.yaml")


@pytest.mark.parametrize(
    "scene,frame",
    [
        (STRIPMAP, "zero_doppler"),
        (SQUINT_SPOTLIGHT, "los"),
        # the 30 deg squinted response rotated in these frames: each target's theory along its own ridges
        # (theory.ridge_directions; an axis' own band alone read IRW/theory cos^2(30 deg) = 0.75 in range)
        (SQUINT_SPOTLIGHT, "zero_doppler"),
        # targets on the ground plane (bp_squint30's are in the slant plane, off it: laid over in a ground image)
        ({**SQUINT_SPOTLIGHT, "targets": {**SQUINT_SPOTLIGHT["targets"], "frame": "ground"}}, "ground"),
    ],
    ids=["broadside-stripmap", "squint30-spotlight", "squint30-zero-doppler", "squint30-ground"],
)
def test_backprojection_reaches_theory(scene, frame):
    raw = simulate(scene_from_mapping(scene))
    image = backproject(raw, BackprojectParams(frame=frame, margin_cells=28))
    assert image.kind == "image" and image.data.dtype == np.complex64
    assert np.all(np.isfinite(image.data))
    report = evaluate_product(image)
    assert_theory(report, irw_tol=0.03, db_tol=0.3, pos_cells=0.05, n_targets=3)
    assert report.false_target.level_db < -30


def test_theoretical_resolution_follows_geometry():
    raw = simulate(scene_from_mapping(SQUINT_SPOTLIGHT))
    image = backproject(raw, BackprojectParams(frame="los", azimuth_extent=20.0, range_extent=20.0))
    az_irw, rg_irw = image.attrs["theoretical_irw"]
    assert rg_irw == pytest.approx(0.886 * 299_792_458 / (2 * 150e6), rel=1e-3)
    # Spotlight cross-range resolution for the design 1 m (x_n) resolution at 30 deg squint is about cos(30 deg).
    assert az_irw == pytest.approx(np.cos(np.radians(30)), rel=0.03)


def test_bistatic_points_match_monostatic_when_receiver_coincides():
    raw = simulate(scene_from_mapping(SQUINT_SPOTLIGHT))
    rc = range_compress(raw.data, raw.radar)
    pos = raw.aux["platform_position"]
    pts = np.array(raw.radar.scene_center)[None, :] + np.array([[0.0, 0.0, 0.0], [3.0, -2.0, 0.0]])
    mono = backproject_points(rc, raw.coords["range_time"], pos, pos, pts, raw.radar.carrier_frequency)
    bi = backproject_points(rc, raw.coords["range_time"], pos, pos + 1e-9, pts, raw.radar.carrier_frequency)
    np.testing.assert_allclose(bi, mono, rtol=1e-4, atol=1e-6)
    assert abs(mono[0]) > 0.9 and abs(mono[1]) < 0.1


def test_upsampling_is_an_accuracy_knob():
    raw = simulate(scene_from_mapping(SQUINT_SPOTLIGHT))
    coarse = evaluate_product(backproject(raw, BackprojectParams(frame="los", upsample=1, interpolation="nearest")))
    fine = evaluate_product(backproject(raw, BackprojectParams(frame="los", upsample=8)))

    def worst(rep):
        return max(abs(a.pslr_db + 13.26) for t in rep.targets for a in t.axes)

    assert worst(fine) < 0.3 < worst(coarse)


def test_the_default_reads_measure_a_weak_targets_side_lobes_as_finer_reads_do():
    """bp_beam_edge's B (partly lit, antenna-weighted side lobes near -31 dB): the default linear reads must not
    add error that a measurement sees. Linear reads on x8 pulses leave -55 dB of error against four-sample
    Lagrange (cubic) reads, which read B's azimuth PSLR / ISLR 0.8 / 1.2 dB high; the default (x16) -67 dB."""
    raw = simulate(scene_from_mapping(load_yaml(CONFIGS / "bp_beam_edge.yaml")))
    base = BackprojectParams(frame="zero_doppler", margin_cells=28)
    default = backproject(raw, base)
    finer = backproject(raw, dataclasses.replace(base, interpolation="cubic", upsample=8))
    error = np.sum(np.abs(default.data - finer.data) ** 2) / np.sum(np.abs(finer.data) ** 2)
    assert 10 * np.log10(error) < -62
    cut, ref = (next(t for t in evaluate_product(im).targets if t.name == "B").axes[0] for im in (default, finer))
    assert cut.axis == "azimuth" and ref.pslr_db < -30
    assert abs(cut.pslr_db - ref.pslr_db) < 0.1 and abs(cut.islr_db - ref.islr_db) < 0.2


def test_hard_case_800_km_squint_60_deg_complex64():
    """Spaceborne range, extreme squint, complex64 raw storage: float64 geometry keeps BP exact."""
    scene = {
        "radar": {
            "carrier_frequency": "10 GHz",
            "bandwidth": "50 MHz",
            "pulse_duration": "2 us",
            "range_sampling_rate": "60 MHz",
            "prf": "300 Hz",
        },
        "platform": {"velocity": "7 km/s", "altitude": "0 m"},
        "geometry": {"reference_range": "800 km", "squint": "60 deg"},
        "acquisition": {"mode": "spotlight", "azimuth_resolution": "3 m"},
        "targets": {
            "frame": "los",
            "points": [
                {"name": "O"},
                {"name": "P", "azimuth": "60 m", "range": "-70 m"},
                {"name": "Q", "azimuth": "-70 m", "range": "80 m", "amplitude": 0.5},
            ],
        },
    }
    raw = simulate(scene_from_mapping(scene))
    assert raw.data.dtype == np.complex64
    image = backproject(raw, BackprojectParams(frame="los", margin_cells=28))
    assert np.all(np.isfinite(image.data))
    assert_theory(evaluate_product(image), irw_tol=0.03, db_tol=0.3, pos_cells=0.05)


def _four_point_progress(**kw):
    """Progress bars of a reference-engine run on 4 points of the squint scene, and its pulse count."""
    from helpers import progress_recorder

    raw = simulate(scene_from_mapping(SQUINT_SPOTLIGHT))
    rc = range_compress(raw.data, raw.radar)
    pos = raw.aux["platform_position"]
    pts = np.array(raw.radar.scene_center)[None, :] + np.zeros((4, 3))
    bars = []
    backproject_points(
        rc, raw.coords["range_time"], pos, pos, pts, raw.radar.carrier_frequency, progress=progress_recorder(bars), **kw
    )
    return bars, len(pos)


def test_reference_engine_progress_has_a_total():
    from helpers import assert_bars_complete

    bars, n_pulses = _four_point_progress(block_elements=4 * 50)
    assert_bars_complete(bars, count=1)
    assert bars[0]["total"] == -(-n_pulses // 50)


def test_reference_engine_upsamples_at_most_64_pulses_at_a_time_for_few_points():
    """With 4 points a memory block would hold 32768 pulses; blocks and upsampled chunks stay at 64 pulses."""
    bars, n_pulses = _four_point_progress()
    assert n_pulses > 64
    assert bars[0]["total"] == -(-n_pulses // 64)


def test_hamming_windows_are_written_as_each_targets_own_theory():
    # every target's table row carries its Hamming theory (IRW 1.303 / B, side lobes of the window); the image
    # attribute keeps the unweighted 0.886 / B; evaluate then reads the target at its own theory
    import copy

    from sarproc.product.theory import window_theory

    scene = copy.deepcopy(SQUINT_SPOTLIGHT)
    scene["targets"]["points"] = scene["targets"]["points"][:1]
    raw = simulate(scene_from_mapping(scene))
    image = backproject(
        raw,
        BackprojectParams(
            frame="los", margin_cells=28, engine="reference", range_window="hamming", azimuth_window="hamming"
        ),
    )
    ham, t = window_theory("hamming"), image.targets[0]
    for a, ax in enumerate(("azimuth", "range")):
        assert t[f"null_{ax}"] == pytest.approx(image.attrs["theoretical_irw"][a] / SINC_IRW_FACTOR, rel=1e-6)
        assert t[f"irw_{ax}"] / t[f"null_{ax}"] == pytest.approx(ham.factor, rel=0.003)
        assert t[f"pslr_{ax}"] == pytest.approx(ham.pslr_db, abs=0.1)
        assert t[f"islr_{ax}"] == pytest.approx(ham.islr_db, abs=0.1)
    for m in evaluate_product(image).targets[0].axes:
        assert m.theory == "target" and abs(m.irw_ratio - 1) < 0.01, m
        assert abs(m.pslr_db - m.pslr_theory_db) < 0.3 and abs(m.islr_db - m.islr_theory_db) < 0.3, m


def test_row_blocks_cover_the_grid_once_in_whole_rows():
    from sarproc.focus.backprojection import row_blocks

    for shape, block in (((100, 37), 370), ((100, 37), 371), ((5, 1000), 10), ((7, 3), 10**9)):
        blocks = row_blocks(shape, block)
        rows = np.concatenate([np.arange(shape[0])[b] for b in blocks])
        assert np.array_equal(rows, np.arange(shape[0]))
        assert all((b.stop - b.start) * shape[1] <= max(block, shape[1]) for b in blocks)


def test_image_in_blocks_is_as_exact_as_the_image_in_one_block(scene_mapping):
    """Blocks of rows sum the same pulses onto the same pixels. The compiled kernel's per-pixel offsets are
    float32 relative to tiles that depend on the block, so blocks differ from the one-block image by the
    kernel's own error, never by more: both stay within the kernel's -70 dB of the float64 reference engine
    (test_backprojection_kernel). Measured on this scene with the grid scaled by 1, 1 +- 1e-5, 1 +- 1e-4 and
    1 + 1e-3: one block -75.6...-82.2 dB, blocks -73.8...-85.0 dB, blocks against one block -69.7...-76.5 dB;
    so the blocks' error is not within 3 dB of the one block's (8.4 dB apart at 1 + 1e-5), only as small."""
    import dataclasses

    from sarproc.focus.backprojection import BackprojectParams, backproject, row_blocks

    raw = simulate(scene_from_mapping(scene_mapping()))
    whole = backproject(raw, BackprojectParams())
    reference = backproject(raw, BackprojectParams(engine="reference")).data
    n_az, n_rg = whole.data.shape
    params = dataclasses.replace(BackprojectParams(), block_pixels=3 * n_rg + 1)
    assert len(row_blocks(whole.data.shape, params.block_pixels)) > 3
    parts = backproject(raw, params)
    peak = np.abs(reference).max()

    def error_db(img):
        return 20 * np.log10(np.abs(img - reference).max() / peak)

    assert error_db(whole.data) < -70 and error_db(parts.data) < -70
    assert np.array_equal(parts.targets, whole.targets) and parts.attrs == whole.attrs


def test_a_grid_wider_than_the_prf_in_doppler_names_each_targets_ghost(caplog):
    """Paper 000's small scene folds at its 800 Hz PRF (the squint deramp chain unfolds it); backprojected over
    the default grid, four targets' echoes focus a second time one PRF away, inside the grid, at full strength.
    The warning names each, at the level the image really has there; a grid whose Doppler fits the PRF warns of
    nothing."""
    import logging

    from sarproc.focus import backprojection_alias as ba

    raw = simulate(scene_from_mapping(load_yaml(CONFIGS / "an2012_exp1_small.yaml")))
    params = BackprojectParams(frame="squint")
    plan = bp_plan(raw, params)
    pulses = bp_pulses(raw, params)
    amb = ba.grid_ambiguity(plan, pulses, np.asarray(raw.coords["azimuth_time"], float), raw.radar)
    assert amb is not None and amb.doppler_span > amb.prf == 800.0
    assert sorted(a.target for a in amb.aliases) == ["E", "NE", "SW", "W"]
    image = backproject(raw, params)
    az, rg = image.coords["azimuth"], image.coords["range"]
    peak = np.abs(image.data).max()
    # NE's ghost peaks inside the grid; E's, W's and SW's just beyond its azimuth edges, read there
    assert [a.target for a in amb.aliases if not a.beyond_edge] == ["NE"]
    for a in amb.aliases:
        assert a.beyond_edge or abs(a.level_db) < 0.5  # a full-strength ghost
        i, j = np.argmin(np.abs(az - a.azimuth)), np.argmin(np.abs(rg - a.range))
        box = np.abs(image.data[max(0, i - 1) : i + 2, max(0, j - 1) : j + 2])
        seen = 20 * np.log10(box.max() / peak)
        # the image holds it there (at the edge, on the ghost's steep skirt: at least as strong as said)
        assert seen > a.level_db - 1.0 if a.beyond_edge else seen == pytest.approx(a.level_db, abs=1.0)
    caplog.clear()
    with caplog.at_level(logging.WARNING):
        bp_warn(raw, plan, pulses)
    (text,) = [r.getMessage() for r in caplog.records if "Doppler" in r.getMessage()]
    assert "800 Hz" in text and all(f"target {n}'s ghost" in text for n in ("E", "NE", "SW", "W"))
    caplog.clear()
    squint30 = simulate(scene_from_mapping(SQUINT_SPOTLIGHT))
    los = BackprojectParams(frame="los")
    with caplog.at_level(logging.WARNING):
        bp_warn(squint30, bp_plan(squint30, los), bp_pulses(squint30, los))
    assert not [r for r in caplog.records if "Doppler" in r.getMessage()]


def test_a_wideband_apertures_azimuth_theory_is_its_keystoned_support():
    """nie2016_small (15 % fractional bandwidth, 7.8 deg aperture): each pulse's support is a segment of the
    range band along its line of sight, so the azimuth ridge sees the edge pulses' segments reach past the
    carrier's band, a taper. The carrier's samples alone gave ISLR -10.10 dB against -10.81 measured (PSLR
    -13.22 against -13.38); the keystoned support's theory lands on the measurement."""
    scene = load_yaml(CONFIGS / "nie2016_small.yaml")
    scene["targets"] = {"frame": "ground_los", "points": [{"name": "C"}]}
    image = backproject(simulate(scene_from_mapping(scene)), BackprojectParams(margin_cells=28))
    cut = evaluate_product(image).target("C").axis("azimuth")
    assert cut.theory == "target" and abs(cut.irw_ratio - 1) < 0.003, cut
    assert abs(cut.pslr_db - cut.pslr_theory_db) < 0.05 and abs(cut.islr_db - cut.islr_theory_db) < 0.05, cut
    assert cut.islr_db < -10.6  # the flat band's -10.16 would be 0.5 dB off
