"""The compiled (numba, tiled, float32-offset) backprojection against the float64 reference and theory."""

from pathlib import Path

import numpy as np
import pytest

from sarproc.dsp.rangecomp import range_compress
from sarproc.focus import backprojection_kernel as bk
from sarproc.focus.backprojection import BackprojectParams, backproject, backproject_points
from sarproc.product.config import load_yaml
from sarproc.product.errors import InputError
from sarproc.quality.metrics import evaluate_product
from sarproc.simulation.scene import scene_from_mapping
from sarproc.simulation.simulate import simulate

from helpers import assert_theory

CONFIGS = Path(__file__).resolve().parents[2] / "configs"


@pytest.fixture(scope="module")
def squint_raw():
    return simulate(scene_from_mapping(load_yaml(CONFIGS / "bp_squint30.yaml")))


def db(a, ref):
    return 20 * np.log10(np.linalg.norm(a - ref) / np.linalg.norm(ref))


def test_compiled_image_matches_float64_reference(squint_raw):
    """Same knobs (linear on the x8 upsampled pulse): only float32 offsets and phasors differ."""
    ref = backproject(squint_raw, BackprojectParams(frame="los", engine="reference"))
    fast = backproject(squint_raw, BackprojectParams(frame="los", engine="compiled"))
    assert fast.data.shape == ref.data.shape
    assert db(fast.data, ref.data) < -60


def test_compiled_bistatic_and_nearest_match_reference(squint_raw):
    rc = range_compress(squint_raw.data, squint_raw.radar)
    pos = squint_raw.aux["platform_position"]
    rx = pos + np.array([0.0, 40.0, -15.0])                    # a receiver 43 m away: a real second leg
    centre = np.asarray(squint_raw.radar.scene_center)
    g = np.arange(-24, 24) * 0.4
    pts = centre + np.stack([np.repeat(g, len(g)), np.tile(g, len(g)), np.zeros(len(g) ** 2)], 1)
    args = (rc, squint_raw.coords["range_time"], pos, rx, pts, squint_raw.radar.carrier_frequency)
    for interp in ("linear", "nearest"):
        ref = backproject_points(*args, interpolation=interp, engine="reference")
        fast = backproject_points(*args, interpolation=interp, engine="compiled")
        assert db(fast, ref) < -60, interp


@pytest.mark.parametrize("kernel,upsample", [("knab", 2), ("linear", 8)])
def test_compiled_kernels_reach_theory(squint_raw, kernel, upsample):
    image = backproject(squint_raw, BackprojectParams(frame="los", margin_cells=28, interpolation=kernel,
                                                      upsample=upsample))
    assert_theory(evaluate_product(image), irw_tol=0.03, db_tol=0.3, pos_cells=0.05, n_targets=3)


def test_knab_on_twice_oversampled_samples_is_closer_to_truth_than_linear_x8(squint_raw):
    """Against a x32 linear reference (closest to the exact sum), a Knab kernel on the x2 pulse beats linear x8."""
    truth = backproject(squint_raw, BackprojectParams(frame="los", engine="reference", upsample=32)).data
    knab = backproject(squint_raw, BackprojectParams(frame="los", interpolation="knab", upsample=2)).data
    lin = backproject(squint_raw, BackprojectParams(frame="los", interpolation="linear", upsample=8)).data
    assert db(knab, truth) < db(lin, truth) - 3


@pytest.mark.parametrize("r0", [1_000.0, 800_000.0])
def test_float32_offset_from_tile_centre_is_micrometre_exact(r0):
    rng = np.random.default_rng(3)
    antenna = np.array([0.0, -r0 * 0.8, r0 * 0.6])
    centre = np.array([12.0, 5.0, 0.0])
    w = centre - antenna
    r = np.linalg.norm(w)
    u = (w / r).astype(np.float32)
    for d in rng.uniform(-30, 30, (200, 3)):
        exact = np.linalg.norm(centre + d - antenna) - r
        d32 = d.astype(np.float32)
        got = bk._offset(u[0], u[1], u[2], np.float32(1 / r), np.float32(r), d32[0], d32[1], d32[2],
                         np.float32(d @ d))
        assert abs(got - exact) < 1e-5


def test_tiles_partition_the_points():
    rng = np.random.default_rng(1)
    pts = rng.uniform(-50, 50, (5000, 3)) + [1e5, 2e5, 0]
    order, start, centres, origin, d = bk.make_tiles(pts, 10.0, max_tile=64)
    assert np.array_equal(np.sort(order), np.arange(len(pts)))
    assert start[0] == 0 and start[-1] == len(pts) and np.all(np.diff(start) >= 1) and np.diff(start).max() <= 64
    tile_of = np.repeat(np.arange(len(start) - 1), np.diff(start))
    np.testing.assert_allclose(pts[order] - origin, centres[tile_of] + d[:3].T.astype(float), atol=1e-5)
    assert np.abs(d[:3]).max() <= 10.0


def test_reference_engine_refuses_windowed_sinc_kernels(squint_raw):
    with pytest.raises(InputError, match="engine"):
        backproject(squint_raw, BackprojectParams(frame="los", engine="reference", interpolation="knab"))


def test_odd_kernel_length_is_refused_with_its_key(squint_raw):
    with pytest.raises(InputError, match="kernel_length"):
        backproject(squint_raw, BackprojectParams(frame="los", interpolation="knab", kernel_length=7))
