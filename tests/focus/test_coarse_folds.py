"""coarse-focus detects deramped energy that folded, from the data (issue 9).

Scene: configs/an2012_airborne_small.yaml (X band, 300 MHz, 2 s aperture, PRF 400 Hz; deramp rate
k = 150 Hz/s, so the deramped window +-PRF/2 covers x_n within about +-200 m) with its declared box
x_n in [-120, 120] m, a unit target C at the centre and one half-amplitude target X outside the box.
The range band moves a response by 1.8 % of its deramped frequency between the lower and upper
thirds of the band, 16 coarse cells per PRF: enough to tell a folded response from a direct one.
Targets 250-330 m out fold once and are caught; farther ones (-420 m, 600 m) are smeared over tens
of Hz by their FM-rate mismatch and are not claimed (no false claim either: a known limit).
"""

from __future__ import annotations

import logging

import numpy as np
import pytest

from sarproc.focus.squint_deramp.coarse_focus import CoarseFocusParams, coarse_focus
from sarproc.focus.squint_deramp.fine_focus import FineFocusParams, fine_focus
from sarproc.focus.squint_deramp.preprocess import PreprocessParams, preprocess
from sarproc.product.config import build, load_yaml
from sarproc.product.errors import InputError
from sarproc.quality.metrics import evaluate_product
from sarproc.simulation.scene import scene_from_mapping
from sarproc.simulation.simulate import simulate
from tests.focus.test_squint_deramp import ROOT

CONFIGS = ROOT / "configs"
STAGES = ("preprocess", "coarse_focus", "fine_focus")


def preprocessed(*xs):
    cfg = load_yaml(CONFIGS / "an2012_airborne_small.yaml")
    cfg["targets"]["points"] = [{"name": "C", "azimuth": "0 m", "range": "0 m"}] + [
        {"name": f"X{i}", "azimuth": f"{x} m", "range": "0 m", "amplitude": 0.5} for i, x in enumerate(xs)
    ]
    raw = simulate(scene_from_mapping({k: v for k, v in cfg.items() if k not in STAGES}))
    return cfg, preprocess(raw, build(PreprocessParams, cfg["preprocess"]))


def test_target_outside_the_box_inside_the_window_is_imaged_and_not_flagged(caplog):
    cfg, pre = preprocessed(160.0)
    with caplog.at_level(logging.WARNING):
        coarse = coarse_focus(pre, build(CoarseFocusParams, cfg["coarse_focus"]))
    assert coarse.attrs["folds"] == [] and not coarse.attrs["aliased"]
    assert "coarse-focus" not in caplog.text
    rep = evaluate_product(fine_focus(coarse, build(FineFocusParams, cfg["fine_focus"] or {})))
    for m in rep.target("X0").axes:
        assert abs(m.position_error_cells) < 0.2 and abs(m.irw_ratio - 1) < 0.05


@pytest.mark.parametrize("x", [250.0, -260.0, 330.0])
def test_folded_target_is_refused_with_cause_and_alias_position(x):
    cfg, pre = preprocessed(x)
    with pytest.raises(InputError) as err:
        coarse_focus(pre, build(CoarseFocusParams, cfg["coarse_focus"]))
    msg = str(err.value)
    assert "is a fold" in msg and "outside the scene box x_n in [-120, 120] m" in msg and "on_alias: warn" in msg
    # with the switch set the stage goes on and records the fold: predicted true and ghost positions
    coarse = coarse_focus(pre, build(CoarseFocusParams, {**cfg["coarse_focus"], "on_alias": "warn"}))
    folds = coarse.attrs["folds"]
    assert folds and all(f["n"] == np.sign(x) for f in folds)
    v, k, prf = pre.radar.velocity, coarse.attrs["deramp_rate"], pre.radar.prf
    best = max(folds, key=lambda f: f["level_db"])
    assert best["t_true"] * v == pytest.approx(x, abs=0.2 * abs(x))  # where the scatterer really is
    assert best["t_app"] * v == pytest.approx(best["t_true"] * v - np.sign(x) * prf / k * v, abs=1.0)
    assert f"x_n ~ {best['t_app'] * v:.0f} m (a ghost)" in msg or len(folds) > 1
