"""Issue 19 ("static targets unaffected", "focused within tolerance"): a fast mover's refocus put -28..-35 dB of
the other targets' own peaks beside them (the session 42 trial's scene, /tmp/ux42-m/mc.yaml; docs/multichannel.md
section 22).

A target detected a few cells outside a mover's window had its range side lobes in the window's cells given the
mover's reconstruction, cut at the window's edge: static S, 4 cells below the window of M3 (v_r 12 m/s), was left
with -28.1 dB of its peak 4 cells from it in range (7 image samples), where each target alone leaves -47 dB. The
refocus now keeps the conventional reconstruction of every detection (and, with the clutter null, every static
peak of the conventional image) up to window_margin cells beyond the window.
"""

from __future__ import annotations

import numpy as np
import pytest

import sarproc.quality.residual as residual
from helpers import TRIAL_POINTS, mover_campaign_scene, trial_mover_scene
from sarproc.focus.backprojection import BackprojectParams, backproject
from sarproc.focus.multichannel.reconstruct import ReconstructParams, reconstruct
from sarproc.product.model import moving_target_rows
from sarproc.quality.metrics import EvaluateParams, evaluate_product, window_slices
from sarproc.simulation.scene import scene_from_mapping
from sarproc.simulation.simulate import simulate


def trial(*names: str) -> dict:
    return trial_mover_scene([TRIAL_POINTS[n] for n in names])


def fit_box_residue(monkeypatch, scene: dict, **params) -> dict[str, float]:
    """Per target: the strongest residual (image minus evaluate's models) inside the box its model is fitted on,
    dB of its own peak (read where evaluate tests its misfits, residual._misfit_targets)."""
    levels: dict[str, float] = {}
    misfit_targets = residual._misfit_targets

    def spy(mag, axes, peaks, reports, ev_params, own_nulls=()):
        for i, (peak, report) in enumerate(zip(peaks, reports)):
            half = residual._fit_box(axes, report, ev_params, residual._own(own_nulls, i))
            box = window_slices(peak, half, mag.shape)
            levels[report.name] = float(20 * np.log10(mag[box].max() / report.peak_amplitude))
        return misfit_targets(mag, axes, peaks, reports, ev_params, own_nulls)

    monkeypatch.setattr(residual, "_misfit_targets", spy)
    raw = reconstruct(simulate(scene_from_mapping(scene)), ReconstructParams(method="modified", **params))
    evaluate_product(backproject(raw, BackprojectParams(oversample=2, margin_cells=24)), EvaluateParams())
    return levels


@pytest.mark.parametrize(
    ("names", "params"),
    [
        (("S", "M3"), {}),  # main: S -28.1 dB
        (("S", "M3"), {"clutter_suppression": True}),  # main: S -41.4 dB (the static peak 4 cells out, not spared)
        (("S", "M1", "M2", "M3"), {}),  # the trial; main: S -27.9, M1 -34.8, M3 -35.2 dB
    ],
    ids=["S+M3", "S+M3 clutter null", "trial"],
)
def test_a_fast_movers_refocus_leaves_the_targets_beside_its_window_as_alone(monkeypatch, names, params):
    levels = fit_box_residue(monkeypatch, trial(*names), **params)
    assert set(levels) == set(names)
    for name in ("S", "M1", "M3"):
        if name in levels:
            assert levels[name] <= -45.0, (name, levels)  # each alone: -47.1..-47.8 dB


def _campaign_025() -> dict:
    """Mover campaign scene 025 (scripts/mover_campaign.py --seed 1; the same mapping as its YAML), band-limited
    echoes (simulate's default): three movers sharing range cells 150-151, a gaussian beam, no clutter, no noise."""
    movers = [
        ("M1", 826.8, 236.0, 9.57, 3.42, 0.8002),
        ("M2", 835.3, 231.4, 11.16, 7.62, 0.7313),
        ("M3", 841.3, 230.4, -7.89, 11.55, 0.3976),
    ]
    scenes = [mover_campaign_scene(1.8, "gaussian", 3, "2 m", m) for m in movers]
    m = scenes[0]
    m.pop("simulation", None)  # xu_scene.yaml pins the continuous chirp
    m["targets"]["points"] = [s["targets"]["points"][0] for s in scenes]
    return m


def test_range_pedestal_of_a_movers_ambiguity_is_no_second_pass_false_alarm():
    """docs/multichannel.md section 34: in campaign scene 025 (band-limited) the second pass detected two peaks in
    cells 134 and 168, either side of M2's -1 x PRF / K_a response (cells 150-151), 6 azimuth samples off its index,
    45.7 / 45.9 dB under it (18.5-19.3 dB under its range side-lobe envelope): its range pedestal, skewed by the
    range-azimuth coupling beyond the max(2, width) samples find_detections' envelope test reaches. One was examined
    as a mover (v_r 12.31 m/s, a false alarm), the other taken for static. Now the three movers are found alone and
    the product counts the two as range_pedestal."""
    rec = reconstruct(simulate(scene_from_mapping(_campaign_025())), ReconstructParams(method="modified"))
    info = rec.attrs["reconstruct"]
    truth = info["truth"]
    assert truth["false_alarms"] == 0 and truth["unmatched"] == [], truth
    rows = sorted(moving_target_rows(rec.aux), key=lambda r: r["truth_index"])
    assert [r["truth_index"] for r in rows] == [0, 1, 2], rows
    for r, v_r in zip(rows, (3.42, 7.62, 11.55)):
        assert abs(r["v_r"] - v_r) < 0.1, r
    assert info["detections"]["range_pedestal"] == 2, info["detections"]


def test_range_pedestal_reaches_only_the_range_cut_and_under_the_envelope():
    """_on_range_pedestal drops a candidate only on a stronger detection's range cut (RANGE_CUT_SAMPLES samples either
    side, pulse_cells in range: what _range_cuts leaves out of the CFAR's background) and under its side-lobe envelope
    with SIDELOBE_MARGIN; a target beside it (off the cut, or over the envelope) is examined."""
    from types import SimpleNamespace

    from sarproc.focus.multichannel import detection, reconstruct as rc

    strong = detection.Detection(cell=151, index=1568, time=0.0, power=1.0, background=1e-6, width=4.0)
    found = SimpleNamespace(dets=[strong], pulse_cells=180, range_width=1.2)
    envelope = detection.SIDELOBE_MARGIN * detection.sinc_sidelobes(17 / 1.2)

    def cand(index: int, cell: int, level: float) -> detection.Detection:
        return detection.Detection(cell=cell, index=index, time=0.0, power=level, background=1e-6, width=4.0)

    n = rc.RANGE_CUT_SAMPLES
    assert rc._on_range_pedestal(cand(1568 - n, 134, 0.1 * envelope), found, 9000)
    assert rc._on_range_pedestal(cand(1568 + n, 168, 0.1 * envelope), found, 9000)
    assert not rc._on_range_pedestal(cand(1568 - n - 1, 134, 0.1 * envelope), found, 9000)  # off the cut
    assert not rc._on_range_pedestal(cand(1568, 134, 1.1 * envelope), found, 9000)  # over the envelope
    assert not rc._on_range_pedestal(cand(1568, 151 + 181, 1e-9), found, 9000)  # beyond the pulse length
    assert rc._on_range_pedestal(
        cand(8999, 140, 1e-6),
        SimpleNamespace(
            **{
                **vars(found),
                "dets": [detection.Detection(cell=150, index=2, time=0.0, power=1.0, background=1e-6, width=4.0)],
            }
        ),
        9000,
    )  # wraps
