"""`sarproc reconstruct`: runs on a simulated raw_multichannel product, refuses other products with exit 2."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
from click.testing import CliRunner

from sarproc.cli.main import cli

CONFIG = Path(__file__).resolve().parents[2] / "configs" / "xu_small.yaml"


def test_reconstruct_cli_writes_a_raw_product_at_n_prf(tmp_path):
    raw = tmp_path / "raw_mc.h5"
    out = tmp_path / "raw.h5"
    runner = CliRunner()
    r = runner.invoke(cli, ["simulate", str(CONFIG), "-o", str(raw), "--no-progress"])
    assert r.exit_code == 0, r.output
    # A real subprocess run, as a user would.
    p = subprocess.run(
        [
            sys.executable,
            "-m",
            "sarproc",
            "reconstruct",
            str(raw),
            "-o",
            str(out),
            "--config",
            str(CONFIG),
            "--no-progress",
        ],
        capture_output=True,
        text=True,
    )
    assert p.returncode == 0, p.stderr
    assert "3000 Hz" in p.stdout
    with h5py.File(out) as f:
        assert f.attrs["product"] == "raw"
        assert f["signal"].shape[0] == 1800
        assert float(f["radar"].attrs["prf"]) == 3000.0
        # no internal hand-over left in the product's metadata (a static-only scene once kept "_probes")
        info = json.loads(f["signal"].attrs["reconstruct"])
        assert not [k for k in info if k.startswith("_")], sorted(info)
        assert np.all(np.isfinite(f["signal"][()]))
    r = runner.invoke(cli, ["reconstruct", str(out), "-o", str(tmp_path / "again.h5")])
    assert r.exit_code == 2 and "raw_multichannel" in r.output
    bad = tmp_path / "bad.yaml"
    bad.write_text("reconstruct:\n  method: fancy\n")
    r = runner.invoke(cli, ["reconstruct", str(raw), "-o", str(tmp_path / "x.h5"), "--config", str(bad)])
    assert r.exit_code == 2 and "method" in r.output
