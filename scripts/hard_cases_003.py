"""Tabulate paper 003's hard cases on the small scene (configs/xu_small.yaml): each stays finite (reconstruct's
``non_finite_samples``, 0; later stages refuse to read NaN or Inf); its loss is measured.

The processing runs through the command line (``make reproduce-003``: ``sarproc sweep
configs/sweeps/hard_cases_003.yaml``, reconstruct then backproject, each case imaged where its target
appears and on an azimuth strip for the false targets); this script only reads the sweep's products
and reports. Cases: slant-range velocity on the search bound (20 m/s) and just beyond (20.5 m/s); a
single channel; a 3 deg / 3 % channel imbalance (with the first-order prediction, eq. 6, that simulate
records and evaluate reports: false_target_predicted); PRFs away from the uniform 1 kHz: 0.5 kHz (N PRF
below the Doppler band), 1.45 kHz and 1.5 kHz (phase centres coincide: singular), with condition number,
noise gain and ghosts without and with Tikhonov regularisation. Writes hard_cases.md and hard_cases.json under --results.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from sarproc.cli.sweep_output import pick_row, sweep_rows
from sarproc.product.io import read_product
from sarproc.quality.summary import worst_quality_json

LABELS = {  # the sweep's cases (configs/sweeps/hard_cases_003.yaml, <case>-image / <case>-strip) in words
    "vr20": "v_r 20.0 m/s (search bound 20)",
    "vr20.5": "v_r 20.5 m/s (search bound 20)",
    "single_channel": "single channel (PRF 3 kHz)",
    "imbalance": "imbalance 3 deg / 3 % on channel 3",
    "prf500_mu0": "PRF 500 Hz, mu 0",
    "prf1450_mu0": "PRF 1450 Hz, mu 0",
    "prf1450_mu0.01": "PRF 1450 Hz, mu 0.01",
    "prf1500_mu0": "PRF 1500 Hz, mu 0",
    "prf1500_mu0.001": "PRF 1500 Hz, mu 0.001",
    "prf1500_mu0.01": "PRF 1500 Hz, mu 0.01",
    "prf1500_mu0.1": "PRF 1500 Hz, mu 0.1",
}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--results", default="results/003")
    args = ap.parse_args()
    res = Path(args.results)
    sweep = res / "sweep-hard"
    rows_in = sweep_rows(sweep)
    rows = []
    cases = [r["scene"].removesuffix("-image") for r in rows_in if r["scene"].endswith("-image")]
    for scene in cases:
        label = LABELS.get(scene, scene)
        image, strip = pick_row(rows_in, scene=f"{scene}-image"), pick_row(rows_in, scene=f"{scene}-strip")
        info = read_product(image["dir"] / "reconstruct.h5", load=False).attrs["reconstruct"]
        mts = info["moving_targets"]
        image_report = json.loads((image["dir"] / "report.json").read_text())
        t = image_report["targets"][0]
        mfta = worst_quality_json(json.loads((strip["dir"] / "report.json").read_text())).false_target_db
        az = {a["axis"]: a for a in t["axes"]}["azimuth"]
        row = {
            "case": label,
            "finite": info["non_finite_samples"] == 0,  # reconstruct's count of NaN / Inf samples written
            "condition": info["condition_number"],
            "noise_gain_db": info["noise_gain_db"],
            "v_r_est": mts[0]["radial_velocity"] if mts else None,
            "at_bound": mts[0]["at_bound"] if mts else None,
            "mfta_db": float("-inf") if mfta is None else mfta,
            "az_irw_ratio": az["irw_ratio"],
            "az_pslr": az["pslr_db"],
            "peak": t["peak_amplitude"],
        }
        predicted = image_report.get("false_target_predicted")  # the simulated imbalance's ghosts (eq. 6)
        if predicted is not None:
            row["predicted_db"] = predicted["level_db"]
        rows.append(row)
    (res / "hard_cases.json").write_text(json.dumps(rows, indent=1, default=float))
    cols = [
        "case",
        "finite",
        "condition",
        "noise_gain_db",
        "v_r_est",
        "at_bound",
        "peak",
        "az_irw_ratio",
        "az_pslr",
        "mfta_db",
        "predicted_db",
    ]
    lines = [
        "# Paper 003 hard cases (configs/xu_small.yaml; configs/sweeps/hard_cases_003.yaml, scripts/hard_cases_003.py)",
        "",
        "| " + " | ".join(cols) + " |",
        "|" + "---|" * len(cols),
    ]
    for r_ in rows:
        lines.append(
            "| "
            + " | ".join(f"{r_.get(c):.4g}" if isinstance(r_.get(c), float) else str(r_.get(c, "")) for c in cols)
            + " |"
        )
    (res / "hard_cases.md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
