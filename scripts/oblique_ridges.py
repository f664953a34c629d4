"""Range side lobes against their own theory on squinted stripmaps (docs/product.md, "evaluate on scenes nobody
tuned": side lobes against their own theory).

Runs, through the command line, `sarproc simulate`, `backproject` (zero_doppler frame) and `evaluate -o` on one
noise-free target at the scene centre of scripts/evaluate_campaign.py's stripmap (10 GHz, 150 MHz, 100 m/s, 2 km,
120 m track, 2 deg beam), for each squint, window (none or Hamming in range and azimuth) and beam pattern asked
for. Tabulates each axis' cut angle (deg from its image axis), IRW/theory, and PSLR and ISLR beside the target's
own theory. The sarproc run is the one ``python -m sarproc`` finds (PYTHONPATH=<tree> for another checkout);
``--images DIR`` keeps the products there and reuses them (evaluate another tree on the same images).

Usage: python scripts/oblique_ridges.py [--squints 0 10 25] [--windows none hamming] [--patterns sinc]
       [--images DIR] [--out results/oblique_ridges.md]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import yaml


def scene(squint: float, window: str, pattern: str) -> dict:
    return {
        "radar": {
            "carrier_frequency": "10 GHz",
            "bandwidth": "150 MHz",
            "pulse_duration": "2 us",
            "range_sampling_rate": "180 MHz",
            "prf": "1500 Hz",
        },
        "platform": {"velocity": "100 m/s", "altitude": "500 m"},
        "geometry": {"reference_range": "2000 m", "squint": f"{squint} deg"},
        "acquisition": {"mode": "stripmap", "aperture_time": "1.2 s"},
        "effects": {"antenna": {"pattern": pattern, "azimuth_beamwidth": "2.0 deg"}},
        "targets": {"frame": "zero_doppler", "points": [{"name": "T1"}]},
        "simulation": {"waveform": "band_limited"},
        "backproject": {"frame": "zero_doppler", "margin_cells": 28, "range_window": window, "azimuth_window": window},
    }


def sarproc(*args: str, cwd: Path) -> None:
    subprocess.run([sys.executable, "-m", "sarproc", *args, "--no-progress", "-q"], cwd=cwd, check=True)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--squints", type=float, nargs="+", default=[0.0, 10.0, 25.0])
    ap.add_argument("--windows", nargs="+", default=["none", "hamming"])
    ap.add_argument("--patterns", nargs="+", default=["sinc"])
    ap.add_argument("--images", type=Path, default=None, help="keep (and reuse) the products here")
    ap.add_argument("--out", type=Path, default=None, help="write the table here too")
    args = ap.parse_args(argv)
    rows = [
        "| squint (deg) | window | beam | axis | cut angle (deg) | IRW/theory | PSLR (theory) dB | ISLR (theory) dB |",
        "|---:|---|---|---|---:|---:|---|---|",
    ]
    with tempfile.TemporaryDirectory() as tmp:
        root = args.images or Path(tmp)
        for squint in args.squints:
            for window in args.windows:
                for pattern in args.patterns:
                    work = root / f"squint{squint:g}_{window}_{pattern}"
                    work.mkdir(parents=True, exist_ok=True)
                    (work / "scene.yaml").write_text(yaml.safe_dump(scene(squint, window, pattern)))
                    if not (work / "image.h5").exists():
                        sarproc("simulate", "scene.yaml", "-o", "raw.h5", "--overwrite", cwd=work)
                        sarproc("backproject", "raw.h5", "--config", "scene.yaml", "-o", "image.h5", cwd=work)
                    sarproc("evaluate", "image.h5", "-o", "report.json", "--overwrite", cwd=work)
                    report = json.loads((work / "report.json").read_text())
                    for m in report["targets"][0]["axes"]:
                        rows.append(
                            f"| {squint:g} | {window} | {pattern} | {m['axis']} | {m['angle_deg']:.2f} | "
                            f"{m['irw_ratio']:.4f} | {m['pslr_db']:.2f} ({m['pslr_theory_db']:.2f}) | "
                            f"{m['islr_db']:.2f} ({m['islr_theory_db']:.2f}) |"
                        )
                    print(rows[-2], rows[-1], sep="\n", flush=True)
    table = "\n".join(rows) + "\n"
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(table)
    print(table)


if __name__ == "__main__":
    main()
