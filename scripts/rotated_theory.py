"""IRW/theory along the principal axes of responses that a frame rotates (docs/product.md, "The theory along the
same ridges").

Runs, through the command line, `sarproc simulate`, `backproject` (in the frame named) and `evaluate -o` for: the
30 deg squinted spotlight of configs/bp_squint30.yaml in its zero_doppler frame, the same with its targets on the
ground in a ground frame, and a Ku-band -20 deg squinted stripmap with a sinc beam (two of its four targets 3 m
apart) in its zero_doppler frame. Tabulates the range of IRW/theory per axis over the targets, the false-target
level and the residual floor. The sarproc run is the one ``python -m sarproc`` finds (PYTHONPATH=<tree> for
another checkout).

Usage: python scripts/rotated_theory.py [--out results/rotated_theory.md]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]

KU_STRIPMAP = {
    "radar": {
        "carrier_frequency": "16 GHz",
        "bandwidth": "300 MHz",
        "pulse_duration": "4 us",
        "range_sampling_rate": "360 MHz",
        "prf": "1200 Hz",
    },
    "platform": {"velocity": "120 m/s", "altitude": "1500 m"},
    "geometry": {"reference_range": "4 km", "squint": "-20 deg"},
    "acquisition": {"mode": "stripmap", "aperture_time": "0.8 s"},
    "effects": {"antenna": {"pattern": "sinc", "azimuth_beamwidth": "3 deg"}},
    "targets": {
        "frame": "zero_doppler",
        "points": [
            {"name": "A"},
            {"name": "B", "azimuth": "8 m", "range": "25 m", "amplitude": 0.7},
            {"name": "C", "azimuth": "-6 m", "range": "-30 m", "phase": "45 deg"},
            {"name": "D", "azimuth": "3 m", "range": "1.2 m", "amplitude": 0.5},
        ],
    },
}


def cases() -> list[tuple[str, dict, str]]:
    squint30 = yaml.safe_load((ROOT / "configs" / "bp_squint30.yaml").read_text())
    on_ground = {**squint30, "targets": {**squint30["targets"], "frame": "ground"}}
    return [
        ("bp_squint30 (30 deg spotlight)", squint30, "zero_doppler"),
        ("bp_squint30, targets on the ground", on_ground, "ground"),
        ("Ku, -20 deg squinted stripmap, sinc beam", KU_STRIPMAP, "zero_doppler"),
    ]


def sarproc(cwd: Path, *args: str) -> None:
    """``python -m sarproc ARGS`` run from ``cwd`` (not this tree's root, which ``-m`` would put first on the path)."""
    command = [sys.executable, "-m", "sarproc", *args, "--overwrite", "--no-progress", "-q"]
    subprocess.run(command, check=True, cwd=cwd)


def measure(scene: dict, frame: str, tmp: Path, tag: str) -> dict:
    """The evaluate report of ``scene`` simulated and backprojected in ``frame``."""
    scene = {**scene, "backproject": {"frame": frame, "margin_cells": 28}}
    config, raw, image, report = (tmp / f"{tag}{suffix}" for suffix in (".yaml", "_raw.h5", ".h5", ".json"))
    config.write_text(yaml.safe_dump(scene))
    sarproc(tmp, "simulate", str(config), "-o", str(raw))
    sarproc(tmp, "backproject", str(raw), "--config", str(config), "-o", str(image))
    sarproc(tmp, "evaluate", str(image), "-o", str(report))
    return json.loads(report.read_text())


def row(label: str, frame: str, report: dict) -> str:
    ratios: dict[str, list[float]] = {"azimuth": [], "range": []}
    for target in report["targets"]:
        for axis in target["axes"]:
            ratios[axis["axis"]].append(axis["irw_ratio"])
    spans = [f"{min(v):.3f}-{max(v):.3f}" for v in ratios.values()]
    return (
        f"| {label} | {frame} | {spans[0]} | {spans[1]} | {report['false_target']['level_db']:.1f} | "
        f"{report['residual']['floor_db']:.1f} |"
    )


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)
    lines = [
        "| scene | frame | azimuth IRW/theory | range IRW/theory | false target (dB) | residual floor (dB) |",
        "|---|---|---|---|---:|---:|",
    ]
    with tempfile.TemporaryDirectory() as tmp:
        for i, (label, scene, frame) in enumerate(cases()):
            lines.append(row(label, frame, measure(scene, frame, Path(tmp), f"case{i}")))
    text = "\n".join(lines) + "\n"
    print(text, end="")
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(text)


if __name__ == "__main__":
    main()
