"""False-target figures with and without the residual (issue 20 item 1), via the CLI only.

For each image: `sarproc evaluate` with `evaluate.residual: false` (guard window only) and `true` (the
default on 2D images); tabulates the guard-window figure, the residual false target, the residual floor and
both run times.
With --before DIR (a checkout of an older sarproc) the residual is also evaluated with that tree's code,
so the table holds the floor before and after a change.
Usage: python scripts/residual_floors.py IMAGE.h5 [...] [--before DIR] --out results/residual_floors.md
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from sarproc.cli.markdown import publish


def evaluate(image: Path, config: Path | None, out: Path, tree: Path | None = None) -> tuple[dict, float]:
    cmd = [sys.executable, "-m", "sarproc", "evaluate", str(image), "-o", str(out), "--overwrite", "--no-progress"]
    if config is not None:
        cmd += ["--config", str(config)]
    env = None if tree is None else dict(os.environ, PYTHONPATH=str(tree))
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, env=env)
    return json.loads(out.read_text()), time.perf_counter() - t0


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("images", nargs="+", type=Path)
    ap.add_argument("--out", type=Path, default=None)
    ap.add_argument("--before", type=Path, default=None, help="older sarproc checkout for the 'before' columns")
    args = ap.parse_args(argv)
    before_head = (
        " residual floor before (dB) | residual false target before (dB) | before (s) |" if args.before else ""
    )
    rows = [
        "| image | guard-window false target (dB) | residual false target (dB) | residual floor (dB) | "
        "residual RMS (dB) | evaluate (s) | with residual (s) |" + before_head,
        "|---|---:|---:|---:|---:|---:|---:|" + ("---:|---:|---:|" if args.before else ""),
    ]

    def fmt(v: float | None) -> str:
        return "n/a" if v is None else f"{v:.2f}"

    with tempfile.TemporaryDirectory() as tmp:
        cfg = Path(tmp) / "residual.yaml"
        cfg.write_text("evaluate:\n  residual: true\n")
        guard = Path(tmp) / "guard.yaml"
        guard.write_text("evaluate:\n  residual: false\n")
        for image in args.images:
            plain, t_plain = evaluate(image, guard, Path(tmp) / "plain.json")
            res, t_res = evaluate(image, cfg, Path(tmp) / "res.json")
            ft = res["false_target"]
            extra = ""
            if args.before:
                old, t_old = evaluate(image, cfg, Path(tmp) / "old.json", args.before)
                extra = (
                    f" {fmt(old['residual']['floor_db'])} | {fmt((old['false_target'] or {}).get('level_db'))} |"
                    f" {t_old:.1f} |"
                )
            rows.append(
                f"| {image} | {fmt((plain['false_target'] or {}).get('level_db'))} | "
                f"{fmt((ft or {}).get('level_db'))} | {fmt(res['residual']['floor_db'])} | "
                f"{fmt(res['residual']['rms_db'])} | {t_plain:.1f} | {t_res:.1f} |" + extra
            )
            print(rows[-1], flush=True)
    publish("\n".join(rows) + "\n", args.out)


if __name__ == "__main__":
    main()
