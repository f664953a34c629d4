#!/usr/bin/env python
"""What backproject's range upsampling does to the measurements: each shipped backprojection scene focused by
the CLI with linear reads on x8 and x16 pulses and by the float64 reference engine on x32 pulses, every image
evaluated, and each figure's distance from the reference's.

    python scripts/range_upsample_effect.py [--out results/range-upsample] [--configs demo bp_stripmap ...]

Per scene: the image error against the reference (energy of the difference over the reference's, and the
largest difference over the peak, dB), and the largest |difference| over targets and axes of IRW / theory,
PSLR, ISLR and position, and of the residual floor and false-target level. Writes ``table.md``. Every figure
comes from the CLI: the image errors from `sarproc compare REFERENCE IMAGE -o` (its products' signal_db and
max_rel), the measurements from `sarproc evaluate -o`.
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import yaml

ROOT = Path(__file__).resolve().parents[1]
CONFIGS = ["demo", "bp_stripmap", "bp_squint30", "bp_beam_edge", "bp_hamming"]
SETTINGS: dict[str, dict[str, Any]] = {
    "linear x8": {"upsample": 8},
    "linear x16": {"upsample": 16},
    "reference x32": {"engine": "reference", "upsample": 32},
}
REFERENCE = "reference x32"
FIGURES = ("IRW / theory", "PSLR (dB)", "ISLR (dB)", "position (mm)", "floor (dB)", "false target (dB)")


def sarproc(*args: str) -> float:
    """Run one CLI command; returns its wall time (s)."""
    start = time.perf_counter()
    subprocess.run([sys.executable, "-m", "sarproc", *args, "--no-progress"], check=True, capture_output=True)
    return time.perf_counter() - start


def run_scene(name: str, out: Path) -> dict:
    config = ROOT / "configs" / f"{name}.yaml"
    raw = out / f"{name}_raw.h5"
    sarproc("simulate", str(config), "-o", str(raw), "--overwrite")
    scene: dict[str, Any] = yaml.safe_load(config.read_text())
    result: dict = {}
    for label, keys in SETTINGS.items():
        tag = label.replace(" ", "_")
        cfg = out / f"{name}_{tag}.yaml"
        cfg.write_text(yaml.safe_dump({**scene, "backproject": {**scene.get("backproject", {}), **keys}}))
        image, report = out / f"{name}_{tag}.h5", out / f"{name}_{tag}.json"
        seconds = sarproc("backproject", str(raw), "--config", str(cfg), "-o", str(image), "--overwrite")
        sarproc("evaluate", str(image), "--config", str(config), "-o", str(report), "--overwrite")
        result[label] = {"image": image, "report": json.loads(report.read_text()), "s": seconds}
    for label in SETTINGS:
        if label != REFERENCE:
            diff = result[label]["image"].with_suffix(".compare.json")
            args = ["compare", str(result[REFERENCE]["image"]), str(result[label]["image"]), "-o", str(diff)]
            subprocess.run([sys.executable, "-m", "sarproc", *args, "--overwrite"], check=True, capture_output=True)
            (result[label]["compare"],) = json.loads(diff.read_text())["files"]
    return result


def figures(report: dict) -> dict[str, list[float]]:
    cuts = [a for t in report["targets"] for a in t["axes"]]
    values = (
        [a["irw_ratio"] for a in cuts],
        [a["pslr_db"] for a in cuts],
        [a["islr_db"] for a in cuts],
        [1e3 * a["position_error"] for a in cuts],
        [report["residual"]["floor_db"]],
        [report["false_target"]["level_db"]],
    )
    return dict(zip(FIGURES, values, strict=True))


def rows(name: str, result: dict) -> list[str]:
    ref = result[REFERENCE]
    ref_figures = figures(ref["report"])
    out = []
    for label in SETTINGS:
        if label == REFERENCE:
            continue
        r = result[label]
        energy, peak = r["compare"]["signal_db"], 20 * math.log10(max(r["compare"]["max_rel"], 1e-30))
        worst = {
            k: max(abs(x - y) for x, y in zip(v, ref_figures[k], strict=True)) for k, v in figures(r["report"]).items()
        }
        out.append(
            f"| {name} | {label} | {r['s']:.2f} | {energy:.1f} | {peak:.1f} | "
            + " | ".join(f"{worst[k]:.4f}" if k == "IRW / theory" else f"{worst[k]:.3f}" for k in worst)
            + " |"
        )
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "range-upsample")
    ap.add_argument("--configs", nargs="+", default=CONFIGS)
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    lines = [
        "Largest |difference| from the reference engine's (x32) figure, over targets and axes; image error: "
        "energy of the difference / the reference's, and largest difference / peak. Time: the backproject "
        "process, wall (one run).",
        "",
        "| scene | reads | backproject (s) | image error (dB) | peak error (dB) | " + " | ".join(FIGURES) + " |",
        "|---|---|---:|---:|---:|" + "---:|" * len(FIGURES),
    ]
    for name in args.configs:
        lines += rows(name, run_scene(name, args.out))
    text = "\n".join(lines) + "\n"
    (args.out / "table.md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
