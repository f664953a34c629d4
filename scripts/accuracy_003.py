"""What accuracy costs in time for paper 003's reconstruct (``make accuracy-003``).

On the single moving target T of the sweep configs/sweeps/accuracy_003.yaml (v_r = 10 m/s), one knob
at a time, the sweep's settings (its one source):

* velocity-search step (and fast vs exhaustive search): reconstruct time, number of leakage
  evaluations, |v_r error|, and the false-target level it leaves (strip MFTA);
* number of channels N = 3, 4, 5 at the same PRF and beam (d = 2 v / (N PRF), uniform): time,
  v_r error, worst IRW ratio / PSLR and MFTA;
* backprojection interpolation knobs on the reconstructed output of the sweep's N = 3 task (range
  upsampling, linear vs nearest; this script's own settings, INTERPOLATION): time against worst-target
  quality and MFTA (reconstruct itself interpolates nothing: its filter bank is exact in the frequency
  domain).

Writes table.md, table.json and accuracy.png under --results.

    python scripts/accuracy_003.py --from-sweep DIR --results results/003-accuracy

``make accuracy-003`` runs the sweep (on Dask) and then this script: the search results (v_r, evaluations)
from the sweep's reconstructed products, their time the sweep's reconstruct time (best of its interleaved
repeats as a CLI step, product I/O included); the moving target's image at its static-equivalent position
(quality), the false-target strips (MFTA) and the backprojection-knob rows are computed here, in-process,
from the sweep's products (backproject and evaluate follow a moving target to where it appears,
sarproc.product.moving).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

from sarproc.focus.backprojection import BackprojectParams, backproject
from sarproc.focus.multichannel.channels import ghost_spacing
from sarproc.focus.multichannel.reconstruct import ReconstructParams
from sarproc.product.config import build
from sarproc.product.model import Product, target_names
from sarproc.quality.metrics import EvaluateParams, QualityReport, evaluate_product
from sarproc.quality.summary import worst_of_targets

STRIP_GUARD = 0.45  # guard around the target on a strip, in ghost spacings (the sinc side lobes there: < -66 dB)


def ghost_strips(
    rec: Product, raw: Product, extent_ghosts: float = 1.5, **bp_knobs: Any
) -> dict[str, tuple[float, Product]]:
    """{target: (MFTA dB, strip image)} on azimuth strips (squint_lrwc) of +-extent_ghosts ghost spacings
    around where each target appears, its own +-STRIP_GUARD spacing left out."""
    extent = 2 * extent_ghosts * ghost_spacing(rec.radar, raw.radar.prf)
    out = {}
    for name in target_names(rec.targets):
        strip = backproject(
            rec,
            BackprojectParams(
                frame="squint_lrwc", azimuth_extent=extent, range_extent=30.0, oversample=1.2, **bp_knobs
            ),
            grid_targets=[name],
        )
        guard = STRIP_GUARD * extent / (2 * extent_ghosts) / strip.attrs["theoretical_irw"][0]
        rep = evaluate_product(strip, EvaluateParams(guard_cells=guard), names=[name])
        out[name] = (rep.false_target.level_db if rep.false_target else float("-inf"), strip)
    return out


def only_window(rec: Product) -> dict:
    """The one moving-target window of a single-target scene (a second one would be a detection error)."""
    windows = rec.attrs["reconstruct"]["moving_targets"]
    if len(windows) != 1:
        raise RuntimeError(f"expected one moving-target window, got {len(windows)}: {windows}")
    return windows[0]


def worst(report: QualityReport) -> tuple[float | None, float | None, float | None]:
    """Worst |IRW / theory - 1|, PSLR and |position error| of the one target's image."""
    w = worst_of_targets(report.targets)
    return w.irw_dev, w.pslr_db, w.position_cells


INTERPOLATION = (("nearest", 8), ("linear", 2), ("linear", 4), ("linear", 8), ("linear", 16))


def image(rec: Product, bp: BackprojectParams) -> Product:
    """Image of ``rec``: backproject's default grid follows a moving target to where it appears and records
    its own theory (that of its true position)."""
    return backproject(rec, bp)


def channel_row(n: int, rec: Product, r: Product, dt: float, t_sim: float, v_r: float) -> dict:
    mt = only_window(rec)
    irw, pslr, pos = worst(
        evaluate_product(image(rec, BackprojectParams(oversample=1.25)), EvaluateParams(guard_cells=60))
    )
    return {
        "knob": f"N = {n} channels",
        "time_s": dt,
        "simulate_s": t_sim,
        "evaluations": mt["search_evaluations"],
        "v_r_error": abs(mt["radial_velocity"] - v_r),
        "worst_irw_dev": irw,
        "worst_pslr_db": pslr,
        "worst_pos_cells": pos,
        "mfta_db": ghost_strips(rec, r)["T"][0],
    }


def search_row(p: ReconstructParams, rec: Product, raw: Product, dt: float, v_r: float) -> dict:
    mt = only_window(rec)
    return {
        "knob": f"search {p.search} step {p.velocity_step} m/s",
        "time_s": dt,
        "evaluations": mt["search_evaluations"],
        "v_r_error": abs(mt["radial_velocity"] - v_r),
        "mfta_db": ghost_strips(rec, raw)["T"][0],
    }


def interpolation_rows(rec: Product, raw: Product) -> list[dict]:
    rows = []
    for interp, up in INTERPOLATION:
        bp = BackprojectParams(oversample=1.25, upsample=up, interpolation=interp)
        t0 = time.perf_counter()
        img = image(rec, bp)
        dt = time.perf_counter() - t0
        irw, pslr, pos = worst(evaluate_product(img, EvaluateParams(guard_cells=60)))
        rows.append(
            {
                "knob": f"backproject {interp} x{up}",
                "time_s": dt,
                "worst_irw_dev": irw,
                "worst_pslr_db": pslr,
                "worst_pos_cells": pos,
                "mfta_db": ghost_strips(rec, raw, upsample=up, interpolation=interp)["T"][0],
            }
        )
    return rows


def from_sweep(directory: Path) -> list:
    """The script's rows from a sweep of configs/sweeps/accuracy_003.yaml: a row per task, in the sweep's order
    (tasks that set reconstruct knobs are search rows, the others channel rows), then the interpolation rows
    on the N = 3 task's products."""
    from sarproc.cli.sweep_tasks import plan_sweep
    from sarproc.product.io import read_product
    from sarproc.product.units import parse_quantity

    doc = json.loads((directory / "table.json").read_text())
    if doc["failures"]:
        raise SystemExit(f"{directory}: the sweep has failed tasks: {doc['failures']}")
    plan = plan_sweep(doc["sweep"], directory)  # the tasks' configs and raw products
    raws = {job.key: job.raw for job in plan.sims}
    times = {r["task"]: r for r in doc["rows"]}
    if set(times) != {t.task_id for t in plan.tasks}:
        raise SystemExit(f"{directory}: the sweep's table does not hold the tasks of {doc['sweep']}")
    search_rows: list[dict] = []
    channel_rows: list[dict] = []
    rec3: Product | None = None
    raw3: Product | None = None
    for task in plan.tasks:
        row = times[task.task_id]
        rec, raw = read_product(task.directory / "reconstruct.h5"), read_product(raws[task.sim_key])
        v_r = parse_quantity(task.config["targets"]["points"][0]["velocity"][1], "velocity")
        if any(k.startswith("reconstruct.") for k in task.setting):
            p = build(ReconstructParams, task.config.get("reconstruct") or {})
            search_rows.append(search_row(p, rec, raw, row["focus_s"], v_r))
            search_rows[-1]["times_s"] = row.get("focus_times") or [row["focus_s"]]
        else:
            n = task.config["effects"]["azimuth_channels"]["n_receivers"]
            channel_rows.append(channel_row(n, rec, raw, row["focus_s"], row["simulate_s"], v_r))
            channel_rows[-1]["times_s"] = row.get("focus_times") or [row["focus_s"]]
            if n == 3:
                rec3, raw3 = rec, raw  # the default reconstruct for the interpolation rows
    if rec3 is None or raw3 is None:
        raise SystemExit(f"{directory}: no channel task with N = 3 for the interpolation rows")
    return search_rows + channel_rows + interpolation_rows(rec3, raw3)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--results", default="results/003-accuracy")
    ap.add_argument("--from-sweep", type=Path, required=True, help="the sweep of configs/sweeps/accuracy_003.yaml")
    args = ap.parse_args()
    res = Path(args.results)
    res.mkdir(parents=True, exist_ok=True)
    rows = from_sweep(args.from_sweep)
    how = (
        f"Sweep {args.from_sweep}: search and channel rows' time_s and simulate_s are the sweep's step "
        "times (best of the sweep's interleaved repeats as a CLI step, product I/O included; time_spread_s "
        "max - min of them); interpolation rows timed here, one run."
    )
    write(res, rows, how)


def write(res: Path, rows: list[dict], how: str) -> None:
    from sarproc.quality.tradeoff import timing_stats
    from sarproc.quality.tradeoff_plot import plot_tradeoff

    for r in rows:
        r.setdefault("times_s", [r["time_s"]])
        r["time_spread_s"] = timing_stats(r["times_s"])["spread"]
    (res / "table.json").write_text(json.dumps(rows, indent=1, default=float))
    cols = [
        "knob",
        "time_s",
        "time_spread_s",
        "simulate_s",
        "evaluations",
        "v_r_error",
        "worst_irw_dev",
        "worst_pslr_db",
        "worst_pos_cells",
        "mfta_db",
    ]
    lines = [
        "# Paper 003 reconstruct: accuracy against time (scripts/accuracy_003.py)",
        "",
        f"{how} time_s: reconstruct (search and channel rows) or "
        "backproject of the chip (interpolation rows); MFTA: strip false-target level, dB (the strip is "
        "backprojected with the row's interpolation knobs). A row is faster than another only when its "
        "worst time is below the other's best (sarproc.quality.tradeoff); the figure's front is that of best time against MFTA.",
        "",
        "| " + " | ".join(cols) + " |",
        "|" + "---|" * len(cols),
    ]
    for r in rows:
        cells = []
        for c in cols:
            v = r.get(c, "")
            cells.append(f"{v:.3g}" if isinstance(v, float) else str(v))
        lines.append("| " + " | ".join(cells) + " |")
    (res / "table.md").write_text("\n".join(lines) + "\n")

    plot_tradeoff(
        res / "accuracy.png",
        [r["knob"] for r in rows],
        [r["times_s"] for r in rows],
        [r["mfta_db"] for r in rows],
        quality_label="false-target level (MFTA), dB",
        title="paper 003: reconstruct / backproject knobs",
    )


if __name__ == "__main__":
    main()
