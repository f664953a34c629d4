#!/usr/bin/env python
"""The paper-000 chain's hard cases: refusals and special scenes that are no grid of one scene.

    python scripts/accuracy_000.py --from-sweep DIR [--out results/000-accuracy]

Squint 60 deg, 800 km with complex64 storage and float32 intermediates, the Stolt square-root limit,
alpha near 1/2, a target at the edge of the data window, PRF just above / below what the coarse step
needs: the sweep configs/sweeps/hard_cases_000.yaml runs them through the CLI (``make accuracy-000``);
this script reads its table, products and reports and writes hardcases.md: each case's measured worst
quality over targets and axes (sarproc.quality.summary) or the refusal message. The knobs' accuracy
against time on one scene is the sweep configs/sweeps/accuracy_000.yaml (``make accuracy-000`` runs both).
"""

from __future__ import annotations

import argparse
import json
import math
import re
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]

# the scenes of configs/sweeps/hard_cases_000.yaml tabulated, in order: (label, targets scored (None: all));
# prf_base only gives the PRF notes their deramp extent
CASES = {
    "squint60": ("squint 60 deg", None),
    "far800": ("800 km, complex64", None),
    "sqrt_limit": ("Stolt square-root limit", None),
    "alpha0.5": ("alpha = 0.5", None),
    "alpha0.45": ("alpha = 0.45", None),
    "alpha0.55": ("alpha = 0.55", None),
    "alpha0.4": ("alpha = 0.4", None),
    "window_edge": ("target at the data-window edge", ("E",)),
    "prf_up": ("PRF 2 % above coarse need", None),
    "prf_down": ("PRF 2 % below coarse need", None),
}


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--from-sweep", type=Path, required=True, help="the sweep of configs/sweeps/hard_cases_000.yaml")
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "000-accuracy")
    a = ap.parse_args(argv)
    a.out.mkdir(parents=True, exist_ok=True)
    hard_cases(a.from_sweep, a.out)
    print(f"accuracy_000: {a.out / 'hardcases.md'}")


def _note(scene: str, task: Path, raw: Path, base: Path) -> str:
    """The case's note, read off its products (and prf_base's coarse product for the PRF cases)."""
    from sarproc.product.io import read_product

    if scene == "squint60":
        return "exp1_small geometry at 60 deg (agreement with backprojection: tests/focus/test_squint_deramp.py)"
    if scene == "far800":
        return f"raw stored {read_product(raw, check_finite=False).data.dtype}, all intermediates complex64"
    if scene == "sqrt_limit":
        c, img = read_product(task / "coarse-focus.h5", load=False), read_product(task / "fine-focus.h5", load=False)
        lim = 2 * 10e9 * 100 * (1 - math.sin(math.radians(60))) / 299792458.0
        return (
            f"F_a''/2 = {c.attrs['azimuth_sampling_rate'] / 2:.0f} Hz beyond the limit {lim:.0f} Hz; "
            f"{100 * img.attrs['stolt_masked_fraction']:.1f} % of the spectrum masked (zero), no NaN; "
            "range IRW is wide-angle (1.5 s at 1 km), same with the grid inside the limit"
        )
    if scene.startswith("alpha"):
        h = read_product(task / "fine-focus.h5", load=False).history[-1]["parameters"]
        return f"{h['nlcs_azimuth_samples']} azimuth samples, dispersion {h['nlcs_dispersion']:.3g} s"
    if scene == "window_edge":
        return "window ends 150 m past E's latest echo start: E's chirps cut; metrics of E only"
    extent = read_product(base / "coarse-focus.h5", load=False).attrs["deramp_extent"]
    prf = read_product(raw, load=False).radar.prf
    return f"PRF = {prf / extent:.2f} x the needed {extent:.1f} Hz"


def hard_cases(directory: Path, out: Path) -> None:
    from sarproc.cli.sweep_tasks import plan_sweep
    from sarproc.product.io import read_product
    from sarproc.quality.summary import worst_quality_json

    doc = json.loads((directory / "table.json").read_text())
    if doc["failures"]:
        raise SystemExit(f"{directory}: the sweep has failed tasks: {doc['failures']}")
    plan = plan_sweep(doc["sweep"], directory)  # the tasks' raw products
    raws = {job.key: job.raw for job in plan.sims}
    tasks = {t.scene: t for t in plan.tasks}
    table = {r["scene"]: r for r in doc["rows"]}
    if set(table) != set(CASES) | {"prf_base"}:
        raise SystemExit(f"{directory}: expected the scenes {sorted(CASES)} and prf_base, got {sorted(table)}")
    rows = []
    for scene, (case, names) in CASES.items():
        row, task = table[scene], tasks[scene]
        if row.get("refused") is not None:
            msg = re.sub(r"^\S+\.(h5|yaml): ", "", row["refused"])  # without the input's file name
            rows.append(f"| {case} | refused (exit 2) | - | - | - | - | - | {msg[:160]} |")
            continue
        img = read_product(task.directory / "fine-focus.h5", check_finite=False)
        finite = bool(np.all(np.isfinite(img.data)))
        report = json.loads((task.directory / "report.json").read_text())
        w = worst_quality_json({"targets": [t for t in report["targets"] if names is None or t["name"] in names]})
        note = _note(scene, task.directory, raws[task.sim_key], tasks["prf_base"].directory)
        rows.append(
            f"| {case} | ran | {finite} | {w.irw_dev:.3f} | {w.pslr_db:.2f} | {w.islr_db:.2f} | "
            f"{w.position_cells:.3f} | {note} |"
        )
    lines = [
        "# Paper 000 chain: hard cases",
        "",
        "Worst over targets and both axes (squint_lrwc frame). 'refused' = InputError, CLI exit 2, with the message.",
        "",
        "| case | outcome | finite | worst IRW dev | worst PSLR (dB) | worst ISLR (dB) | worst position (cells) | note |",
        "|---|---|---|---:|---:|---:|---:|---|",
    ] + rows
    (out / "hardcases.md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
