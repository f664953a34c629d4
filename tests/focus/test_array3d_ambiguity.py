"""array3d names elevation ambiguities from the metadata and the cube (issue 9).

Reduced paper-004 array (tests/focus/test_array3d.py): 8 receivers, d = 0.0764 m at 37.5 GHz, so
the unambiguous sector is +-asin(lambda/2d) = +-3.0 deg and one elevation cell is about 0.66 deg.
"""

from __future__ import annotations

import logging
import math

import pytest

from sarproc.focus.array3d.ambiguity import alias_of, unambiguous_half_sector
from sarproc.focus.array3d.linear_array import array3d_product
from sarproc.simulation.scene import scene_from_mapping
from sarproc.simulation.simulate import simulate
from tests.focus.test_array3d import LAM, D, reduced


def run(beam_deg, *elevations_deg, caplog):
    m = reduced(
        targets={
            "points": [
                {"name": f"T{i}", "azimuth": "0 m", "range": f"{490 + 5 * i} m", "elevation": f"{e} deg"}
                for i, e in enumerate(elevations_deg)
            ]
        },
        effects={"antenna": {"elevation_beamwidth": f"{beam_deg} deg"}},
    )
    raw = simulate(scene_from_mapping(m))
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="sarproc.focus.array3d.linear_array"):
        cube, _ = array3d_product(raw)
    return cube, [r.getMessage() for r in caplog.records]


def test_sector_and_alias_arithmetic():
    psi = unambiguous_half_sector(LAM, D)
    assert math.degrees(psi) == pytest.approx(3.0, abs=0.01)
    # just outside the sector folds onto just inside the opposite edge
    assert math.degrees(alias_of(math.radians(3.45), LAM, D)) == pytest.approx(-2.55, abs=0.01)
    assert alias_of(math.radians(2.7), LAM, D) == pytest.approx(math.radians(2.7))


def test_beam_within_the_sector_is_silent(caplog):
    # the paper's 6 deg beam (+-3.0 deg) against the +-2.999 deg sector: a sliver far below one cell
    cube, msgs = run(6.0, 2.7, -2.7, caplog=caplog)
    assert msgs == []
    assert cube.history[-1]["parameters"]["derived"]["elevation_ambiguities"] == []


def test_target_just_inside_is_not_flagged_just_outside_is_named(caplog):
    # +-3.5 deg beam: scatterers at 3.0..3.5 deg fold onto -3.0..-2.5 deg (and mirrored).
    _, msgs = run(7.0, 2.3, caplog=caplog)
    assert len(msgs) == 1 and "reaches beyond the unambiguous sector +-3 deg" in msgs[0]
    assert "onto -3..-2.5, +2.5..+3 deg" in msgs[0]
    _, msgs = run(7.0, 2.3, 3.45, caplog=caplog)
    named = [m for m in msgs if "grating-lobe alias" in m]
    assert len(named) == 1, msgs
    text = named[0]
    at = float(text.split("elevation ")[1].split(" deg")[0])
    true = float(text.split("alias of one at ")[1].split(" deg")[0])
    assert at == pytest.approx(math.degrees(alias_of(math.radians(3.45), LAM, D)), abs=0.2)  # -2.55 deg
    assert true == pytest.approx(3.45, abs=0.2)  # the true elevation it names
    assert "range 494.9" in text or "range 495" in text  # the folded target's range; the real one is not named
