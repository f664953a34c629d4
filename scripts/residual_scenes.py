"""Residual floors of the paper scenes' clean images, simulated with a given waveform (issue 20 item 1).

For each scene: `sarproc simulate` with `simulation.waveform` set (continuous: the sampled continuous chirp, the
default before session 35 and the paper configs' setting; band_limited: the DAC-filtered sampled chirp, no aliasing
pedestal, the default where f_s > 1.01 B), its processing chain, then `sarproc evaluate` with
the guard window only and with `evaluate.residual: true`. Tabulates the residual floor, the residual false
target, the guard-window figure and the run time of every stage (one run each: noisy on a shared machine).
Usage: python scripts/residual_scenes.py --waveform band_limited [--only NAME ...] --out results/residual_scenes.md
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

from sarproc.cli.markdown import publish

# name -> (scene, chain of (stage, --config or None for the scene itself))
SCENES = {
    "demo (backproject)": ("configs/demo.yaml", [("backproject", None)]),
    "bp_squint30 (backproject)": ("configs/bp_squint30.yaml", [("backproject", None)]),
    "bp_stripmap (backproject)": ("configs/bp_stripmap.yaml", [("backproject", None)]),
    "bp_hamming (backproject)": ("configs/bp_hamming.yaml", [("backproject", None)]),
    "000 an2012_exp2_small (fine-focus)": (
        "configs/an2012_exp2_small.yaml",
        [("preprocess", None), ("coarse-focus", None), ("fine-focus", None)],
    ),
    "003 xu_small (reconstruct + backproject)": (
        "configs/xu_small.yaml",
        [("reconstruct", None), ("backproject", None)],
    ),
    "002 nie2016_small (pfa2 two-step)": ("configs/nie2016_small.yaml", [("pfa2", None)]),
}


def sarproc(*args: str) -> float:
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "sarproc", *args, "--overwrite", "--no-progress", "-q"], check=True)
    return time.perf_counter() - t0


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--waveform", default="band_limited", choices=("continuous", "band_limited"))
    ap.add_argument("--only", nargs="*", default=None, help="scene names (substrings) to run")
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)
    rows = [
        f"simulation.waveform: {args.waveform}; one run each (seconds, wall)",
        "",
        "| image | floor (dB) | residual false target (dB) | guard window (dB) | stages (s) | evaluate (s) | "
        "with residual (s) |",
        "|---|---:|---:|---:|---|---:|---:|",
    ]
    with tempfile.TemporaryDirectory() as tmpdir:
        tmp = Path(tmpdir)
        on = tmp / "residual.yaml"
        on.write_text("evaluate:\n  residual: true\n")
        off = tmp / "guard.yaml"
        off.write_text("evaluate:\n  residual: false\n")
        for name, (path, chain) in SCENES.items():
            if args.only and not any(o in name for o in args.only):
                continue
            scene = yaml.safe_load(Path(path).read_text())
            scene["simulation"] = dict(scene.get("simulation") or {}, waveform=args.waveform)
            cfg = tmp / "scene.yaml"
            cfg.write_text(yaml.safe_dump(scene))
            product = tmp / "raw.h5"
            times = [f"simulate {sarproc('simulate', str(cfg), '-o', str(product)):.1f}"]
            for k, (stage, config) in enumerate(chain):
                out = tmp / f"stage{k}.h5"
                times.append(
                    f"{stage} {sarproc(stage, str(product), '--config', config or str(cfg), '-o', str(out)):.1f}"
                )
                product = out
            t_guard = sarproc("evaluate", str(product), "--config", str(off), "-o", str(tmp / "guard.json"))
            t_res = sarproc("evaluate", str(product), "--config", str(on), "-o", str(tmp / "res.json"))
            rep = json.loads((tmp / "res.json").read_text())
            floor = rep["residual"]["floor_db"]
            rows.append(
                f"| {name} | {floor:.1f} | {rep['false_target']['level_db']:.1f} | "
                f"{rep['false_target_guard']['level_db']:.1f} | {', '.join(times)} | {t_guard:.1f} | {t_res:.1f} |"
            )
            print(rows[-1], flush=True)
    publish("\n".join(rows) + "\n", args.out)


if __name__ == "__main__":
    main()
