"""Injected-ghost table of the residual false-target search on real processed images (issue 20 item 1).

For a scene: `sarproc simulate` + the processor of the scene as given, and the same with one more
target G (amplitude 1, off every target's ridges, inside the targets' extent so the image grid is the
same). By linearity G's own response is the difference of the two images; G is added to the clean
image at -40, -45 and -50 dB (its refined peak against the strongest truth target's) and the sum is
evaluated with the clean image's targets table, which does not hold G (`evaluate.residual: true`).
The injection and its evaluations are `sarproc ghost-test CLEAN GHOSTED -o report.json`
(sarproc.quality.ghost_test); this script runs simulate, the processor and ghost-test, and tabulates the
report: the level and place found against injected, and the clean image's residual floor.
With `backproject` the ghosted scene's grid is centred and sized on the clean scene's targets (--targets).
Usage: python scripts/residual_ghosts.py --scene configs/demo.yaml --ghost 30,35 --process backproject
       [--process-config FILE] --out results/residual_ghosts_demo.md
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path

import yaml

from sarproc.cli.markdown import publish
from sarproc.product.io import read_product

LEVELS = "-40,-45,-50"


def sarproc(*args: str) -> None:
    subprocess.run([sys.executable, "-m", "sarproc", *args, "--overwrite", "--no-progress", "-q"], check=True)


def image(
    scene: Path, process: str, process_config: Path | None, tmp: Path, tag: str, grid_on: Sequence[str] = ()
) -> Path:
    """Simulate and process ``scene``; ``grid_on``: backproject's grid centred and sized on these targets."""
    raw, out = tmp / f"{tag}_raw.h5", tmp / f"{tag}.h5"
    sarproc("simulate", str(scene), "-o", str(raw))
    extra = ["--targets", ",".join(grid_on)] if grid_on and process == "backproject" else []
    sarproc(process, str(raw), "--config", str(process_config or scene), "-o", str(out), *extra)
    return out


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", type=Path, required=True)
    ap.add_argument("--ghost", required=True, help="azimuth,range of G in the scene's target frame, metres")
    ap.add_argument("--process", default="backproject")
    ap.add_argument("--process-config", type=Path, default=None)
    ap.add_argument("--out", type=Path, default=None)
    ap.add_argument("--waveform", default=None, help="simulation.waveform for both scenes (e.g. band_limited)")
    args = ap.parse_args(argv)
    scene = yaml.safe_load(args.scene.read_text())
    if args.waveform is not None:
        scene["simulation"] = dict(scene.get("simulation") or {}, waveform=args.waveform)
    az, rg = (float(v) for v in args.ghost.split(","))
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        with_g = dict(scene, targets=dict(scene["targets"]))
        with_g["targets"]["points"] = list(scene["targets"].get("points", [])) + [
            {"name": "G", "azimuth": f"{az} m", "range": f"{rg} m"}
        ]
        ghost_scene = tmp / "scene_g.yaml"
        ghost_scene.write_text(yaml.safe_dump(with_g))
        clean_scene = tmp / "scene.yaml"
        clean_scene.write_text(yaml.safe_dump(scene))
        clean = image(clean_scene, args.process, args.process_config, tmp, "clean")
        table = read_product(clean, load=False).targets
        names = [n.decode() if isinstance(n, bytes) else str(n) for n in table["name"]]
        ghosted = image(ghost_scene, args.process, args.process_config, tmp, "ghost", names)
        report = tmp / "ghost_test.json"
        sarproc("ghost-test", str(clean), str(ghosted), "--levels", LEVELS, "-o", str(report))
        doc = json.loads(report.read_text())
    dims = doc["dims"]

    def num(v: float | None, spec: str) -> str:  # ghost-test writes a non-finite figure as null
        return "n/a" if v is None else format(v, spec)

    rows = [
        f"Scene {args.scene}{'' if args.waveform is None else f' (simulation.waveform: {args.waveform})'} processed by `{args.process}`; ghost G at {doc['ghost_position']} (strongest pixel of its response); "
        f"clean image: residual floor {num(doc['floor_db'], '.2f')} dB, residual false target "
        f"{num(doc['false_target_db'], '.2f')} dB, guard-window figure {num(doc['guard_db'], '.2f')} dB.",
        "",
        "| injected (dB) | found (dB) | error (dB) | "
        + " | ".join(f"{d} error (cells)" for d in dims)
        + " | guard-window figure (dB) | residual floor (dB) |",
        "|---:|---:|---:|" + "---:|" * len(dims) + "---:|---:|",
    ]
    for r in doc["rows"]:
        rows.append(
            f"| {r['injected_db']:.1f} | {num(r['found_db'], '.2f')} | {num(r['error_db'], '+.2f')} | "
            + " | ".join(num(r["error_cells"][d], "+.2f") for d in dims)
            + f" | {num(r['guard_db'], '.2f')} | {num(r['floor_db'], '.2f')} |"
        )
    publish("\n".join(rows) + "\n", args.out)


if __name__ == "__main__":
    main()
