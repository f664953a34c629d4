"""simulate's azimuth folding messages (issue 9): they say what folds, by how much and whether the
declared chain undoes it, and stay silent when nothing folds.

Base scene (tests/conftest.py): 10 GHz, v = 100 m/s, R = 2 km, so the Doppler rate is
2 v^2 / (lambda R) = 333 Hz/s and a target's Doppler moves 2 v / (lambda R) = 3.33 Hz per metre of
azimuth; a 0.5 s spotlight aperture gives each target a 167 Hz Doppler history.
"""

from __future__ import annotations

import logging

import pytest

from sarproc.simulation.scene import doppler_folding, scene_from_mapping


def messages(caplog, mapping, level=logging.INFO):
    caplog.clear()
    with caplog.at_level(level, logger="sarproc.simulation.scene"):
        scene = scene_from_mapping(mapping, source="scene.yaml")
    return scene, [(r.levelname, r.getMessage()) for r in caplog.records]


def test_silent_when_nothing_folds(scene_mapping, caplog):
    scene, msgs = messages(caplog, scene_mapping())  # 167 Hz history, PRF 400 Hz
    assert msgs == []
    dop = doppler_folding(scene)
    assert dop["own"] == pytest.approx(2 * 100**2 / (0.0299792458 * 2000) * 0.5, rel=0.01)


@pytest.mark.parametrize(
    "declared, level", [({}, "WARNING"), ({"coarse_focus": {}}, "INFO"), ({"backproject": {}}, "INFO")]
)
def test_spotlight_fold_and_whether_the_chain_unfolds_it(scene_mapping, caplog, declared, level):
    # PRF 120 Hz < 167 Hz history of the single target: the spectrum folds by about 47 Hz, but the
    # targets' instantaneous spread (0 Hz for one target) fits, so deramp / backprojection undo it.
    scene, msgs = messages(caplog, scene_mapping(radar={"prf": "120 Hz"}, **declared))
    assert len(msgs) == 1 and msgs[0][0] == level, msgs
    text = msgs[0][1]
    assert "folds by 4" in text and "spans 16" in text
    if level == "INFO":
        assert "unfolds it" in text
    else:
        assert "no declared stage unfolds it" in text


def test_spotlight_targets_folding_onto_each_other(scene_mapping, caplog):
    # Two targets 60 m apart are 200 Hz apart in Doppler at every time: more than a 150 Hz PRF.
    m = scene_mapping(
        radar={"prf": "150 Hz"}, coarse_focus={}, targets={"points": [{"name": "A"}, {"name": "B", "azimuth": "60 m"}]}
    )
    _, msgs = messages(caplog, m)
    assert [lvl for lvl, _ in msgs] == ["WARNING"]
    assert "instantaneous Doppler spread is 200" in msgs[0][1] and "aliasing by 5" in msgs[0][1]
    # ghosts one PRF away in Doppler: 150 Hz / 333 Hz/s x 100 m/s = 45 m along track
    assert "44.97 m away" in msgs[0][1]


def test_stripmap_beam_wider_than_the_sampling_rate(scene_mapping, caplog):
    # Beam Doppler band 2 v beta / lambda = 2 x 100 x 0.0349 / 0.03 = 233 Hz.
    base = dict(
        acquisition={"mode": "stripmap", "aperture_time": "0.5 s"}, effects={"antenna": {"azimuth_beamwidth": "2 deg"}}
    )
    _, msgs = messages(caplog, scene_mapping(radar={"prf": "200 Hz"}, **base))
    assert [lvl for lvl, _ in msgs] == ["WARNING"] and "the beam's Doppler band is 232" in msgs[0][1]
    _, msgs = messages(caplog, scene_mapping(radar={"prf": "300 Hz"}, **base))
    assert msgs == []


@pytest.mark.parametrize(
    "changes",
    [
        {},  # spotlight, no beam
        {"geometry": {"squint": "20 deg"}},
        {"platform": {"altitude": "1 km"}, "geometry": {"reference_range": "2.5 km"}},
        {"effects": {"antenna": {"azimuth_beamwidth": "3 deg"}}},  # spotlight with a beam
        {
            "acquisition": {"mode": "stripmap", "aperture_time": "4 s"},
            "effects": {"antenna": {"azimuth_beamwidth": "3 deg"}},
        },
    ],
)
def test_bounded_check_agrees_with_every_pulse_and_target(scene_mapping, changes):
    # 41 x 31 targets over 2 s (800 pulses) evaluated fully, then on 64 pulses x 200 targets.
    m = scene_mapping(**{"acquisition": {"aperture_time": "2 s"}, **changes})
    m["targets"] = {"grid": {"azimuth_count": 41, "range_count": 31, "azimuth_spacing": "3 m", "range_spacing": "4 m"}}
    scene = scene_from_mapping(m, source="scene.yaml")
    full = doppler_folding(scene, max_pulses=10**6, max_targets=10**6)
    bounded = doppler_folding(scene, max_pulses=64, max_targets=200)
    for key in ("own", "spread", "span"):
        assert bounded[key] == pytest.approx(full[key], rel=0.01, abs=0.5), key


def test_loading_many_targets_does_not_allocate_pulses_times_targets(scene_mapping):
    # 4000 pulses x 20,000 targets: one float64 (pulses x targets) array alone would be 640 MB.
    import tracemalloc

    m = scene_mapping(acquisition={"aperture_time": "10 s"})
    m["targets"] = {
        "grid": {"azimuth_count": 200, "range_count": 100, "azimuth_spacing": "1 m", "range_spacing": "1 m"}
    }
    tracemalloc.start()
    try:
        scene = scene_from_mapping(m, source="scene.yaml")
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert scene.n_pulses == 4000 and len(scene.target_xyz) == 20_000
    assert peak < 64e6, f"{peak / 1e6:.0f} MB"
