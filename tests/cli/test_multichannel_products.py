"""What paper 003's reproduction reads from the command line's products (issue 19 item 4: the scripts only tabulate
and plot): the ghost level of a simulated channel imbalance (simulate's attribute ``channel_errors``, carried by
reconstruct and backproject; evaluate's ``false_target_predicted``); reconstruct's Doppler power
spectrum (aux ``doppler_frequency``, ``doppler_power``); evaluate's first-order ghost level of a mover's velocity
error (``channel_phase_from_velocity``, ``ghost_level_from_velocity_db``). Each equals what the package's
functions give on the products (what the scripts computed in process before).

Reduced scene: configs/xu_small.yaml.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from sarproc.cli.main import cli
from sarproc.focus.multichannel import channels
from sarproc.product.io import read_product

CONFIG = Path(__file__).resolve().parents[2] / "configs" / "xu_small.yaml"


def run(*args: object) -> None:
    r = CliRunner().invoke(cli, [str(a) for a in args])
    assert r.exit_code == 0, r.output


def chain(d: Path, name: str, edit: dict) -> dict[str, Path]:
    """simulate -> reconstruct -> backproject -> evaluate of xu_small.yaml with the top-level sections updated."""
    m = yaml.safe_load(CONFIG.read_text())
    for section, values in edit.items():
        m.setdefault(section, {}).update(values)
    cfg = d / f"{name}.yaml"
    cfg.write_text(yaml.safe_dump(m))
    p = {k: d / f"{name}_{k}.h5" for k in ("raw", "rec", "img")}
    p["report"] = d / f"{name}.json"
    run("simulate", cfg, "-o", p["raw"], "--no-progress")
    run("reconstruct", p["raw"], "-o", p["rec"], "--config", cfg, "--no-progress")
    run("backproject", p["rec"], "-o", p["img"], "--config", cfg, "--no-progress")
    run("evaluate", p["img"], "-o", p["report"], "--config", cfg, "--no-progress")
    return p


@pytest.fixture(scope="module")
def imbalance(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """A static target, channel 3 off by 3 deg and +3 %, conventional reconstruction (hard_cases_003's case)."""
    return chain(
        tmp_path_factory.mktemp("imbalance"),
        "imb",
        {
            "effects": {
                "azimuth_channels": {
                    "n_receivers": 3,
                    "spacing": "5 m",
                    "phase_imbalance": ["0 deg", "0 deg", "3 deg"],
                    "amplitude_imbalance": [0, 0, 0.03],
                }
            },
            "reconstruct": {"method": "conventional"},
            "evaluate": {"guard_cells": 60},
        },
    )


@pytest.fixture(scope="module")
def velocity_error(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """Target T at v_r 5 m/s reconstructed with a given v_r of 5.1 m/s (reproduce_003's error curve)."""
    return chain(
        tmp_path_factory.mktemp("velocity"),
        "vel",
        {
            "targets": {"points": [{"name": "T", "velocity": ["0 m/s", "5 m/s", "0 m/s"]}]},
            "effects": {"target_motion": {}},
            "reconstruct": {"radial_velocity": "5.1 m/s", "along_track_velocity": "0 m/s"},
            "evaluate": {"guard_cells": 60},
        },
    )


def test_evaluate_predicts_the_ghost_level_of_the_simulated_channel_imbalance(imbalance: dict[str, Path]) -> None:
    raw = read_product(imbalance["raw"], load=False)
    errors = raw.attrs["channel_errors"]  # what simulate simulated, carried through reconstruct and backproject
    assert errors == {"phase_imbalance": [0, 0, math.radians(3)], "amplitude_imbalance": [0, 0, 0.03]}
    for stage in ("rec", "img"):
        assert read_product(imbalance[stage], load=False).attrs["channel_errors"] == errors
    gain = (1 + np.array([0, 0, 0.03])) * np.exp(1j * np.array([0, 0, math.radians(3)]))
    expected = channels.product_ghost_level_db(raw, -1j * np.log(gain))  # hard_cases_003's former in-process one
    assert -40 < expected < -30  # about -36.8 dB (docs/multichannel.md)
    report = json.loads(imbalance["report"].read_text())  # beside the measured false-target level
    assert report["false_target_predicted"]["level_db"] == expected
    assert "channel imbalance" in report["false_target_predicted"]["source"]


def test_no_channel_imbalance_no_prediction(velocity_error: dict[str, Path]) -> None:
    assert "channel_errors" not in read_product(velocity_error["raw"], load=False).attrs
    assert "false_target_predicted" not in json.loads(velocity_error["report"].read_text())


def test_reconstruct_stores_its_doppler_power_spectrum(imbalance: dict[str, Path]) -> None:
    rec = read_product(imbalance["rec"])
    f, power = channels.doppler_power_spectrum(rec)  # computed in process, as reproduce_003 did
    assert len(rec.aux["doppler_frequency"]) == len(rec.data) == 1800
    np.testing.assert_array_equal(rec.aux["doppler_frequency"], f)
    np.testing.assert_allclose(rec.aux["doppler_power"], power, rtol=1e-9)
    assert rec.attrs["reconstruct"]["channel_offsets"] == [-5.0, 0.0, 5.0]


def test_evaluate_reports_the_ghost_level_of_a_movers_velocity_error(velocity_error: dict[str, Path]) -> None:
    (mover,) = json.loads(velocity_error["report"].read_text())["movers"]
    dv_r = mover["v_r_error"]
    assert dv_r == pytest.approx(0.1, abs=1e-9)
    raw = read_product(velocity_error["raw"], load=False)  # reproduce_003's former in-process prediction
    r = raw.radar
    tau = channels.channel_delays(raw.aux["rx_offset"][:, 0], r.velocity)
    phase = 4 * np.pi * dv_r * math.cos(r.squint) * tau / r.wavelength
    assert mover["channel_phase_from_velocity"] == pytest.approx(float(np.abs(phase).max()), rel=1e-12)
    expected = channels.product_ghost_level_db(raw, phase)
    assert -60 < expected < -30
    assert mover["ghost_level_from_velocity_db"] == pytest.approx(expected, abs=1e-9)
    assert mover["relocation_error_from_velocity"] > 0  # the relocation bound beside the relocation error
    assert mover["relocation_error"] is not None
