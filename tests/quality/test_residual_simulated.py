"""The residual false-target search on a simulated, backprojected image (issue 20 item 1).

A short chirp (2 us) sampled at 1.2 B: simulated as a band-limited waveform (`simulation.waveform:
band_limited`) its echoes compress without the aliasing pedestal, so the residual image of a clean scene
is below -50 dB, and weak scatterers left out of the truth table are found at their place and level
(measured: floor -55.0 dB; ghosts at -40/-45/-50 dB read -40.09/-45.08/-50.07 dB, 0.22 cells off). A and
C share a range ridge 60 cells long, as the demo's C, N and S do: the continuous chirp's pedestal there
leaves -43.9 dB, and every ghost is then missed for a -40 dB ridge residue 60 cells away.
The ghost's image is simulated and backprojected on its own (same grid) and added at each level.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from sarproc.focus.backprojection import BackprojectParams, backproject
from sarproc.quality.metrics import EvaluateParams, evaluate_product
from sarproc.simulation.scene import scene_from_mapping
from sarproc.simulation.simulate import simulate

GHOST = (-14.0, 16.0)  # azimuth, range (m): off both targets' ridges, inside their extent


def _scene(points: list[dict], waveform: str) -> dict:
    return {
        "radar": {
            "carrier_frequency": "10 GHz",
            "bandwidth": "150 MHz",
            "pulse_duration": "2 us",
            "range_sampling_rate": "180 MHz",
            "prf": "400 Hz",
        },
        "platform": {"velocity": "150 m/s", "altitude": "2 km"},
        "geometry": {"reference_range": "5 km", "squint": "20 deg"},
        "acquisition": {"mode": "spotlight", "azimuth_resolution": "1 m"},
        "targets": {"frame": "los", "origin": "scene_center", "points": points},
        "simulation": {"waveform": waveform},
    }


TARGETS = [
    {"name": "A", "azimuth": "0 m", "range": "0 m"},
    {"name": "B", "azimuth": "-20 m", "range": "-18 m", "amplitude": 0.7, "phase": "40 deg"},
    {"name": "C", "azimuth": "0 m", "range": "50 m", "amplitude": 0.9},  # on A's range ridge, 60 cells away
]
PARAMS = BackprojectParams(frame="los", margin_cells=24)


@pytest.fixture(scope="module")
def images():
    clean = backproject(simulate(scene_from_mapping(_scene(TARGETS, "band_limited"))), PARAMS)
    ghost_scene = _scene(
        TARGETS + [{"name": "G", "azimuth": f"{GHOST[0]} m", "range": f"{GHOST[1]} m"}], "band_limited"
    )
    both = backproject(simulate(scene_from_mapping(ghost_scene)), PARAMS, grid_targets=["A", "B", "C"])
    assert both.data.shape == clean.data.shape
    return clean, both.data.astype(np.complex128) - clean.data


def test_clean_simulated_scene_floor_is_below_minus_50_db(images):
    clean, _ = images
    rep = evaluate_product(clean, EvaluateParams(residual=True))
    assert rep.residual.floor_db <= -50.0
    assert rep.false_target.level_db <= -50.0
    assert rep.false_target_guard.level_db > -40.0  # the guard window sees the targets' own side lobes


@pytest.mark.parametrize("level", [-40.0, -45.0, -50.0])
def test_injected_ghost_found_at_its_place_and_level(images, level):
    clean, ghost = images
    ref = max(abs(clean.data.ravel()))
    k = np.unravel_index(np.argmax(np.abs(ghost)), ghost.shape)
    a = 10 ** (level / 20) * ref / abs(ghost[k])  # ghost's peak pixel `level` below the strongest pixel
    image = dataclasses.replace(clean, data=(clean.data + a * ghost).astype(np.complex64))
    rep = evaluate_product(image, EvaluateParams(residual=True))
    ft = rep.false_target
    assert ft.level_db == pytest.approx(level, abs=1.0)
    cells = dict(zip(clean.dims, clean.attrs["theoretical_irw"]))
    for d, i in zip(clean.dims, k):
        assert abs(ft.position[d] - clean.coords[d][i]) <= 2 * cells[d]


def test_continuous_chirp_pedestal_lifts_the_same_scene_above_minus_50_db():
    """The cause the band-limited waveform removes: the continuous chirp sampled between samples leaves a
    pedestal on the shared range ridge of A and C (-44 dB measured), which no response model follows."""
    raw = simulate(scene_from_mapping(_scene(TARGETS, "continuous")))
    rep = evaluate_product(backproject(raw, PARAMS), EvaluateParams(residual=True))
    assert rep.residual.floor_db > -50.0
