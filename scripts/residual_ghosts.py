"""Injected-ghost table of the residual false-target search on real processed images (issue 20 item 1).

For a scene: `sarproc simulate` + the processor of the scene as given, and the same with one more
target G (amplitude 1, off every target's ridges, inside the targets' extent so the image grid is the
same). By linearity G's own response is the difference of the two images; G is added to the clean
image at -40, -45 and -50 dB (its refined peak against the strongest truth target's) and the sum is
evaluated with the clean image's targets table, which does not hold G (`evaluate.residual: true`).
Tabulates the level and place found against injected, and the clean image's residual floor.
With `backproject` the ghosted scene's grid is centred and sized on the clean scene's targets (--targets).
Usage: python scripts/residual_ghosts.py --scene configs/demo.yaml --ghost 30,35 --process backproject
       [--process-config FILE] --out results/residual_ghosts_demo.md
"""

from __future__ import annotations

import argparse
import dataclasses
import subprocess
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import yaml

from sarproc.cli.markdown import publish
from sarproc.product.io import read_product
from sarproc.quality.metrics import EvaluateParams, evaluate_product

LEVELS = (-40.0, -45.0, -50.0)


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
        clean = read_product(image(clean_scene, args.process, args.process_config, tmp, "clean"))
        names = [n.decode() if isinstance(n, bytes) else str(n) for n in clean.targets["name"]]
        ghosted = read_product(image(ghost_scene, args.process, args.process_config, tmp, "ghost", names))
    if clean.data.shape != ghosted.data.shape or any(
        not np.allclose(clean.coords[d], ghosted.coords[d]) for d in clean.dims
    ):
        sys.exit("the ghost changed the image grid: put it inside the targets' extent")
    response = ghosted.data.astype(np.complex128) - clean.data
    params = EvaluateParams(residual=True)
    base = evaluate_product(clean, params)
    assert base.residual is not None and base.false_target is not None and base.false_target_guard is not None
    ref = max(t.peak_amplitude for t in base.targets)
    g_index = np.unravel_index(np.argmax(np.abs(response)), response.shape)
    g_pos = {d: float(clean.coords[d][i]) for d, i in zip(clean.dims, g_index)}
    g_peak = float(np.abs(response[g_index]))
    cells = dict(zip(clean.dims, clean.attrs["theoretical_irw"]))
    rows = [
        f"Scene {args.scene}{'' if args.waveform is None else f' (simulation.waveform: {args.waveform})'} processed by `{args.process}`; ghost G at {g_pos} (strongest pixel of its response); "
        f"clean image: residual floor {base.residual.floor_db:.2f} dB, residual false target "
        f"{base.false_target.level_db:.2f} dB, guard-window figure {base.false_target_guard.level_db:.2f} dB.",
        "",
        "| injected (dB) | found (dB) | error (dB) | "
        + " | ".join(f"{d} error (cells)" for d in clean.dims)
        + " | guard-window figure (dB) | residual floor (dB) |",
        "|---:|---:|---:|" + "---:|" * len(clean.dims) + "---:|---:|",
    ]
    for level in LEVELS:
        a = 10 ** (level / 20) * ref / g_peak  # G's strongest pixel at `level` below the strongest target's peak
        product = dataclasses.replace(clean, data=(clean.data + a * response).astype(np.complex64))
        rep = evaluate_product(product, params)
        ft = rep.false_target
        assert ft is not None and rep.residual is not None and rep.false_target_guard is not None
        errs = [(ft.position[d] - g_pos[d]) / cells[d] for d in clean.dims]
        rows.append(
            f"| {level:.1f} | {ft.pixel_level_db:.2f} | {ft.pixel_level_db - level:+.2f} | "
            + " | ".join(f"{e:+.2f}" for e in errs)
            + f" | {rep.false_target_guard.level_db:.2f} | {rep.residual.floor_db:.2f} |"
        )
        print(rows[-1], flush=True)
    publish("\n".join(rows) + "\n", args.out)


if __name__ == "__main__":
    main()
