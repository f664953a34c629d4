"""Assertions shared by several test modules."""

from __future__ import annotations

import dataclasses
import typing
from pathlib import Path

import pytest
import yaml


def assert_theory(report, irw_tol=0.03, db_tol=0.3, pos_cells=0.05, n_targets=None):
    """Every target and axis of a quality report at theory: unweighted sinc IRW/PSLR/ISLR, position."""
    if n_targets is not None:
        assert len(report.targets) == n_targets
    for t in report.targets:
        for ax in t.axes:
            where = f"{t.name}/{ax.axis}"
            assert abs(ax.irw_ratio - 1) < irw_tol, where
            assert ax.pslr_db == pytest.approx(-13.26, abs=db_tol), where
            assert ax.islr_db == pytest.approx(-10.16, abs=db_tol), where
            assert abs(ax.position_error_cells) < pos_cells, where


def progress_recorder(bars: list):
    """A stage ``progress`` callable that records each bar as {'total', 'done'} in ``bars``."""

    def progress(iterable, total=None):
        if total is None and hasattr(iterable, "__len__"):
            total = len(iterable)
        bar = {"total": total, "done": 0}
        bars.append(bar)
        for item in iterable:
            yield item
            bar["done"] += 1

    return progress


def assert_bars_complete(bars: list, count=None):
    """Every bar had a total and reached it."""
    assert bars and (count is None or len(bars) == count), bars
    for bar in bars:
        assert bar["total"] is not None and bar["total"] > 0 and bar["done"] == bar["total"], bars


def declared_keys(cls: type, prefix: str = "") -> list[str]:
    """Every key a model declares, nested ones dotted (``range_window.start``), list items with ``[]``,
    read from the dataclasses themselves (not through sarproc.product.schema)."""
    hints = typing.get_type_hints(cls)
    keys = []
    for f in dataclasses.fields(cls):
        key = prefix + f.name
        keys.append(key)
        tp = hints[f.name]
        origin, args = typing.get_origin(tp), typing.get_args(tp)
        if dataclasses.is_dataclass(tp):
            keys += declared_keys(tp, key + ".")
        for arg in args:
            if dataclasses.is_dataclass(arg):
                keys += declared_keys(arg, key + ("[]." if origin in (list, tuple) else "."))
    return keys


def scene_keys() -> list[str]:
    """Every key of a scene file, each effect's own keys included (``effects.antenna.pattern``)."""
    from sarproc.cli.schema import SCENE_MODEL, model_of
    from sarproc.simulation.effects import EFFECTS

    keys = declared_keys(model_of(SCENE_MODEL))
    for name, effect in EFFECTS.items():
        keys.append(f"effects.{name}")
        keys += declared_keys(effect.Params, f"effects.{name}.")
    return keys


XU_SCENE = Path(__file__).resolve().parents[1] / "configs" / "xu_scene.yaml"
# scripts/mover_campaign.py's reduction of configs/xu_scene.yaml's radar: a 10 MHz, 15 us chirp at 12 MHz (12.5 m
# range cells, a few seconds of reconstruct)
CAMPAIGN_RADAR = {"bandwidth": "10 MHz", "range_sampling_rate": "12 MHz", "pulse_duration": "15 us"}


def mover_campaign_scene(squint, pattern, n_receivers, spacing, mover, noise_snr=None, noise_seed=0, statics=()):
    """A mover campaign scene (configs/xu_scene.yaml reduced as scripts/mover_campaign.py reduces it: 10 MHz, 0.507
    deg beam, 1.2 s) with one mover (name, azimuth m, range m, v_a, v_r m/s, amplitude) and static points (azimuth m,
    range m, amplitude)."""
    name, az, rg, v_a, v_r, amp = mover
    m = yaml.safe_load(XU_SCENE.read_text())
    for section in ("reconstruct", "backproject", "evaluate"):  # the stages' parameters are the test's
        m.pop(section, None)
    m["radar"].update(CAMPAIGN_RADAR)
    m["geometry"]["squint"] = f"{squint} deg"
    m["effects"]["antenna"] = {"azimuth_beamwidth": "0.507 deg", "pattern": pattern}
    m["effects"]["azimuth_channels"] = {"n_receivers": n_receivers, "spacing": spacing}
    mover_point = {
        "name": name,
        "azimuth": f"{az} m",
        "range": f"{rg} m",
        "amplitude": amp,
        "velocity": [f"{v_a} m/s", f"{v_r} m/s", "0 m/s"],
    }
    m["targets"] = {
        "frame": "squint",
        "points": [mover_point]
        + [
            {"name": f"S{k + 1}", "azimuth": f"{a} m", "range": f"{r} m", "amplitude": amp}
            for k, (a, r, amp) in enumerate(statics)
        ],
    }
    if noise_snr is not None:
        m["effects"]["noise"] = {"snr": f"{noise_snr} dB"}
        m.setdefault("simulation", {})["seed"] = noise_seed
    return m


# The session 42 new-user trial's targets (docs/cli.md, "Session 42 new-user trial", row 7), squint frame
TRIAL_POINTS = {
    "S": {"name": "S", "azimuth": "0 m", "range": "0 m"},
    "M1": {"name": "M1", "azimuth": "300 m", "range": "60 m", "velocity": ["0 m/s", "4 m/s", "0 m/s"]},
    "M2": {"name": "M2", "azimuth": "-300 m", "range": "-60 m", "velocity": ["5 m/s", "-3 m/s", "0 m/s"]},
    "M3": {"name": "M3", "azimuth": "600 m", "range": "-120 m", "velocity": ["0 m/s", "12 m/s", "0 m/s"]},
}


def trial_mover_scene(points: list[dict]) -> dict:
    """The session 42 trial's radar (configs/xu_small.yaml's: 3 channels 5 m apart, PRF 1000 Hz, 20 deg squint,
    0.6 s, rect beam 0.305 deg; continuous chirp) with ``points`` (squint frame)."""
    return {
        "radar": {
            "carrier_frequency": "9.6 GHz",
            "bandwidth": "30 MHz",
            "pulse_duration": "4 us",
            "range_sampling_rate": "36 MHz",
            "prf": "1000 Hz",
        },
        "platform": {"velocity": "7500 m/s", "altitude": "0 m"},
        "geometry": {"reference_range": "600 km", "squint": "20 deg"},
        "acquisition": {"mode": "stripmap", "aperture_time": "0.6 s", "range_margin": "30 m"},
        "targets": {"frame": "squint", "points": points},
        "effects": {
            "antenna": {"pattern": "rect", "azimuth_beamwidth": "0.305 deg"},
            "azimuth_channels": {"n_receivers": 3, "spacing": "5 m"},
            "target_motion": {},
        },
        "simulation": {"waveform": "continuous"},
    }


def warped_model(rng, position=(60.3, 81.7), kappa=0.02, curvature=0.0, cross_warp=True):
    """A warped, keystoned 2D response model of evaluate's residual (sarproc.quality.residual.ResponseModel: skewed
    ridges, a chirp, a band centre, as pfa2's images give), its coefficients drawn from ``rng``."""
    import numpy as np

    from sarproc.quality.residual import ResponseModel, spectral_orders

    orders = spectral_orders(2, 1, 2)
    V = np.array([[0.99, 0.14], [-0.05, 1.0]])
    warp = np.zeros((2, 2, 2))
    warp[0, 1, 1], warp[1, 0, 0] = 2e-5, -3e-5
    if cross_warp:
        warp[1, 0, 1], warp[1, 1, 0] = 1e-5, 1e-5
    return ResponseModel(
        position=np.asarray(position, dtype=float),
        ridges=V / np.linalg.norm(V, axis=1)[:, None],
        nulls=np.array([2.3, 2.1]),
        band_centre=np.array([0.03, -0.11]),
        orders=orders,
        coef=rng.normal(size=len(orders)) + 1j * rng.normal(size=len(orders)),
        chirp=np.array([[1e-4, 2e-5], [2e-5, -3e-4]]),
        kappa=np.array([kappa]),
        warp=warp,
        curvature=curvature,
    )


def model_on_every_sample(box, model):
    """A residual response model's values at every sample of the image box ``box`` (slices), by model_values."""
    import numpy as np

    from sarproc.quality.residual import model_values

    axes = np.meshgrid(*[np.arange(s.start, s.stop) for s in box], indexing="ij")
    return model_values(np.stack([x.ravel() for x in axes]), model).reshape(axes[0].shape)
