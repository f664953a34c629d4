"""simulate warns about targets outside the main beam or lit over only part of their aperture (issue 20),
with the fraction and the expected resolution, and stays silent when every target is fully lit.

Base scene (tests/conftest.py): 10 GHz, v = 100 m/s, R = 2 km; here a 0.5 s stripmap (a 50 m track) with a
2 deg sinc beam, whose -3 dB footprint (70 m) is longer than the track: the scene centre is lit over all of it.
"""

from __future__ import annotations

import logging
import math
import re

import numpy as np

from sarproc.product.beam import one_way_amplitude
from sarproc.simulation.scene import scene_from_mapping
from sarproc.simulation.simulate import illumination_warnings, plan_simulation


def warnings_of(caplog, mapping):
    caplog.clear()
    scene = scene_from_mapping(mapping, source="scene.yaml")
    with caplog.at_level(logging.WARNING, logger="sarproc.simulation.simulate"):
        lines = illumination_warnings(scene, plan_simulation(scene))
    assert [r.getMessage() for r in caplog.records] == lines
    return lines


def stripmap(scene_mapping, *points, pattern="sinc"):
    return scene_mapping(
        acquisition={"mode": "stripmap", "aperture_time": "0.5 s"},
        effects={"antenna": {"pattern": pattern, "azimuth_beamwidth": "2 deg"}},
        targets={"frame": "squint", "points": list(points)},
    )


def test_silent_when_every_target_is_fully_lit(scene_mapping, caplog):
    assert warnings_of(caplog, stripmap(scene_mapping, {"name": "A"}, {"name": "B", "azimuth": "5 m"})) == []
    assert warnings_of(caplog, scene_mapping()) == []  # spotlight, no pattern


def test_partly_lit_and_side_lobe_lit_targets_are_named_with_fraction_and_resolution(scene_mapping, caplog):
    lines = warnings_of(
        caplog,
        stripmap(scene_mapping, {"name": "A"}, {"name": "P", "azimuth": "40 m"}, {"name": "S", "azimuth": "200 m"}),
    )
    assert len(lines) == 2, lines
    partly, side = lines
    # P: in the -3 dB beam (|x_P - x| <= R tan 1 deg = 34.9 m) from x = 5.1 m to the track end at 25 m,
    # against the scene centre's whole 50 m track: 40 %
    assert "'P' is only partly illuminated: 40 %" in partly
    irw, full = (float(v) for v in re.findall(r"IRW ([\d.]+) m instead of ([\d.]+) m", partly)[0])
    assert irw > 1.1 * full  # 40 % of the aperture: a coarser response (1.22x)
    # S never enters the main beam; its strongest two-way gain is the sinc pattern's at the nearest track end
    x = np.linspace(-25, 25, 201)
    angle = np.arctan((200 - x) / 2000)
    gain = 40 * np.log10(np.abs(one_way_amplitude(angle, math.radians(2), "sinc")).max())
    assert "'S' is outside the main beam" in side and "0 % of its full -3 dB aperture" in side
    assert f"strongest two-way gain {gain:.1f} dB" in side


def test_a_beam_that_never_sees_a_target_says_so(scene_mapping, caplog):
    (line,) = warnings_of(
        caplog, stripmap(scene_mapping, {"name": "A"}, {"name": "F", "azimuth": "200 m"}, pattern="rect")
    )
    assert "'F' is outside the beam over the whole aperture" in line and "never lit" in line


def test_a_response_without_side_lobes_is_said_so_not_minus_300_db(caplog):
    """Session 41 new-user trial: C-band stripmap, 3 deg sinc beam, 150 m track at 4 km; BEYOND at +400 m sees
    only the pattern's first side lobe, from near its peak at the track's end down to its null: a one-sided
    aperture whose response falls off monotonically. The warning said 'PSLR -300.0 dB instead of -15.4 dB' (the
    theory's floor) and evaluate's table '(-300.00)'."""
    mapping = {
        "radar": {
            "carrier_frequency": "5.4 GHz",
            "bandwidth": "50 MHz",
            "pulse_duration": "5 us",
            "range_sampling_rate": "60 MHz",
            "prf": "400 Hz",
        },
        "platform": {"velocity": "100 m/s", "altitude": "1 km"},
        "geometry": {"reference_range": "4 km"},
        "acquisition": {"mode": "stripmap", "aperture_time": "1.5 s"},
        "effects": {"antenna": {"pattern": "sinc", "azimuth_beamwidth": "3 deg"}},
        "targets": {"frame": "zero_doppler", "points": [{"name": "A"}, {"name": "BEYOND", "azimuth": "400 m"}]},
    }
    (line,) = warnings_of(caplog, mapping)
    assert "'BEYOND' is outside the main beam" in line
    assert "PSLR none (no side lobes) instead of -15.4 dB" in line and "-300" not in line


def _nadir_cube(*points):
    """A down-looking scene (paper 004's geometry) with a rect 6 deg elevation beam."""
    return {
        "radar": {
            "carrier_frequency": "37.5 GHz",
            "bandwidth": "375 MHz",
            "pulse_duration": "1 us",
            "range_sampling_rate": "450 MHz",
            "prf": "400 Hz",
        },
        "platform": {"velocity": "50 m/s", "altitude": "500 m"},
        "geometry": {"reference_range": "500 m"},
        "acquisition": {"mode": "stripmap", "n_pulses": 61, "range_margin": "8 m"},
        "targets": {"frame": "elevation", "origin": "absolute", "points": list(points)},
        "effects": {"antenna": {"pattern": "rect", "azimuth_beamwidth": "0.57 deg", "elevation_beamwidth": "6 deg"}},
    }


def test_a_target_outside_a_rect_elevation_beam_is_never_lit(caplog):
    """Session 42 trial: a target at 3.4 deg elevation outside a rect 6 deg elevation beam (no echo at all) got no
    warning; the same target 2.21 m along track (partly lit in azimuth) ended simulate with "internal error:
    ValueError: response_theory: no support sample has a positive weight", exit 1."""
    a = {"name": "A", "azimuth": "0 m", "range": "490 m", "elevation": "0 deg"}
    out = {"name": "OUT", "azimuth": "0 m", "range": "490 m", "elevation": "3.4 deg"}
    edge = {**out, "name": "EDGE", "azimuth": "-2.21 m"}
    for target in (out, edge):
        (line,) = warnings_of(caplog, _nadir_cube(a, target))
        assert f"'{target['name']}' is outside the beam over the whole aperture" in line and "never lit" in line
    assert warnings_of(caplog, _nadir_cube(a, {**out, "elevation": "2.9 deg"})) == []
