"""Evaluate time with and without the residual, this checkout against an older one (issue 20 item 1).

For each image (made beforehand by the CLI: e.g. `sarproc simulate configs/demo.yaml` + `backproject`),
runs `sarproc evaluate` with `evaluate.residual: false` and `true`, with this tree and with ``--before``
(a checkout of the code before a change), interleaved, ``--repeats`` times; tabulates the best wall time
of each and the residual figures of both trees (floor, RMS, residual false target, guard window).
Usage: python scripts/residual_speed.py IMAGE.h5 [...] --before DIR [--repeats 2] [--out FILE.md]
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

ROOT = Path(__file__).resolve().parents[1]


def evaluate(tree: Path, image: Path, config: Path, out: Path) -> float:
    env = dict(os.environ, PYTHONPATH=str(tree))
    cmd = [sys.executable, "-m", "sarproc", "evaluate", str(image), "--config", str(config), "-o", str(out)]
    t0 = time.perf_counter()
    subprocess.run([*cmd, "--overwrite", "--no-progress", "-q"], check=True, env=env, stdout=subprocess.DEVNULL)
    return time.perf_counter() - t0


def figures(path: Path) -> str:
    d = json.loads(path.read_text())
    r, ft, g = d["residual"], d["false_target"] or {}, d["false_target_guard"] or {}
    vals = (r["floor_db"], r["rms_db"], ft.get("level_db"), g.get("level_db"))
    return " / ".join("n/a" if v is None else f"{v:.4f}" for v in vals)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("images", nargs="+", type=Path)
    ap.add_argument("--before", type=Path, required=True, help="checkout of the code before the change")
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)
    trees = {"before": args.before.resolve(), "now": ROOT}
    rows = [
        f"best of {args.repeats}, interleaved (seconds, wall); figures: residual floor / RMS / residual false "
        "target / guard window (dB)",
        "",
        "| image | guard window only (s) | residual, before (s) | residual, now (s) | figures before | figures now |",
        "|---|---:|---:|---:|---|---|",
    ]
    with tempfile.TemporaryDirectory() as tmpdir:
        tmp = Path(tmpdir)
        cfg = {k: tmp / f"{k}.yaml" for k in ("guard", "residual")}
        cfg["guard"].write_text("evaluate:\n  residual: false\n")
        cfg["residual"].write_text("evaluate:\n  residual: true\n")
        for image in args.images:
            best: dict[tuple[str, str], float] = {}
            for _ in range(args.repeats):
                for tree_name, tree in trees.items():
                    for kind, config in cfg.items():
                        t = evaluate(tree, image, config, tmp / f"{tree_name}_{kind}.json")
                        best[tree_name, kind] = min(best.get((tree_name, kind), t), t)
            rows.append(
                f"| {image} | {best['now', 'guard']:.2f} | {best['before', 'residual']:.2f} | "
                f"{best['now', 'residual']:.2f} | {figures(tmp / 'before_residual.json')} | "
                f"{figures(tmp / 'now_residual.json')} |"
            )
            print(rows[-1], flush=True)
    publish("\n".join(rows) + "\n", args.out)


if __name__ == "__main__":
    main()
