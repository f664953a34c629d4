"""What accuracy costs in time for paper 003's reconstruct (``make accuracy-003``).

On the single moving target B of configs/xu_scene.yaml (v_r = 10 m/s), one knob at a time:

* velocity-search step (and fast vs exhaustive search): reconstruct time, number of leakage
  evaluations, |v_r error|, and the false-target level it leaves (strip MFTA);
* number of channels N = 3, 4, 5 at the same PRF and beam (d = 2 v / (N PRF), uniform): time,
  v_r error, worst IRW ratio / PSLR and MFTA;
* backprojection interpolation knobs on the reconstructed output (range upsampling, linear vs
  nearest): time against worst-target quality and MFTA (reconstruct itself interpolates nothing:
  its filter bank is exact in the frequency domain).

Writes table.md, table.json and accuracy.png under --results.

    python scripts/accuracy_003.py --from-sweep DIR --results results/003-accuracy

``make accuracy-003`` runs the reconstruct settings (the 5 search and 3 channel rows) as a sweep
(configs/sweeps/accuracy_003.yaml, on Dask) and then this script with ``--from-sweep``: the search
results (v_r, evaluations) from the sweep's reconstructed products, their time the sweep's reconstruct
time (one run as a CLI step, product I/O included); the moving target's image at its static-equivalent
position (quality), the false-target strips (MFTA) and the backprojection-knob rows are computed here,
in-process, from the sweep's products (backproject and evaluate follow a moving target to where it
appears, sarproc.product.moving).
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np

from sarproc.focus.backprojection import BackprojectParams, backproject
from sarproc.focus.multichannel.reconstruct import ReconstructParams, reconstruct
from sarproc.product.config import build, load_yaml
from sarproc.product.model import target_names
from sarproc.quality.metrics import EvaluateParams, evaluate_product
from sarproc.simulation.scene import scene_from_mapping
from sarproc.simulation.simulate import simulate

STRIP_GUARD = 0.45  # guard around the target on a strip, in ghost spacings (the sinc side lobes there: < -66 dB)


def scene_mapping(path, points=None, **radar):
    m = load_yaml(path)
    if points is not None:
        m["targets"]["points"] = points
        if any("velocity" in pt for pt in points):
            m["effects"].setdefault("target_motion", {})
    m.setdefault("radar", {}).update(radar)
    return m


def sim(m):
    return simulate(scene_from_mapping(m))


def focus(rec, raw, bp: BackprojectParams, theory_from_truth=False):
    """Image of ``rec``: backproject's default grid follows a moving target to where it appears and records
    its own theory (that of its true position); ``theory_from_truth`` is kept for the callers (always so)."""
    return backproject(rec, bp)


def ghost_strips(rec, raw, extent_ghosts=1.5, **bp_knobs):
    """{target: (MFTA dB, strip image)} on azimuth strips (squint_lrwc) of +-extent_ghosts ghost spacings
    around where each target appears, its own +-STRIP_GUARD spacing left out."""
    r = rec.radar
    ka = 2 * (r.velocity * math.cos(r.squint)) ** 2 / (r.wavelength * r.reference_range)
    extent = 2 * extent_ghosts * raw.radar.prf / ka * r.velocity
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


TARGET = {"name": "T", "azimuth": "800 m", "velocity": ["0 m/s", "10 m/s", "0 m/s"]}


def only_window(rec):
    """The one moving-target window of a single-target scene (a second one would be a detection error)."""
    windows = rec.attrs["reconstruct"]["moving_targets"]
    if len(windows) != 1:
        raise RuntimeError(f"expected one moving-target window, got {len(windows)}: {windows}")
    return windows[0]


def worst(report):
    t = report.targets[0]
    return (
        max(abs(a.irw_ratio - 1) for a in t.axes),
        max(a.pslr_db for a in t.axes),
        max(abs(a.position_error_cells) for a in t.axes),
    )


SEARCH = (("fast", 0.5), ("fast", 0.2), ("fast", 0.1), ("fast", 0.05), ("exhaustive", 0.1))
CHANNELS = (3, 4, 5)
INTERPOLATION = (("nearest", 8), ("linear", 2), ("linear", 4), ("linear", 8), ("linear", 16))


def search_params(search, step):
    return ReconstructParams(search=search, velocity_step=step, coarse_step=max(step, 2.0))


def channel_spacing(radar, n):
    """Uniform phase centres at this PRF: d = 2 v / (N PRF)."""
    return 2 * radar.velocity / (n * radar.prf)


def channel_row(n, rec, r, dt, t_sim):
    mt = only_window(rec)
    irw, pslr, pos = worst(
        evaluate_product(
            focus(rec, r, BackprojectParams(oversample=1.25), theory_from_truth=True), EvaluateParams(guard_cells=60)
        )
    )
    return {
        "knob": f"N = {n} channels",
        "time_s": dt,
        "simulate_s": t_sim,
        "evaluations": mt["search_evaluations"],
        "v_r_error": abs(mt["radial_velocity"] - 10.0),
        "worst_irw_dev": irw,
        "worst_pslr_db": pslr,
        "worst_pos_cells": pos,
        "mfta_db": ghost_strips(rec, r)["T"][0],
    }


def search_row(search, step, rec, raw, dt):
    mt = only_window(rec)
    return {
        "knob": f"search {search} step {step} m/s",
        "time_s": dt,
        "evaluations": mt["search_evaluations"],
        "v_r_error": abs(mt["radial_velocity"] - 10.0),
        "mfta_db": ghost_strips(rec, raw)["T"][0],
    }


def interpolation_rows(rec, raw):
    rows = []
    for interp, up in INTERPOLATION:
        bp = BackprojectParams(oversample=1.25, upsample=up, interpolation=interp)
        t0 = time.perf_counter()
        img = focus(rec, raw, bp, theory_from_truth=True)
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
    """The script's rows from a sweep of configs/sweeps/accuracy_003.yaml (its products and step times)."""
    from sarproc.cli.sweep_tasks import plan_sweep
    from sarproc.product.io import read_product
    from sarproc.product.units import parse_quantity

    doc = json.loads((directory / "table.json").read_text())
    if doc["failures"]:
        raise SystemExit(f"{directory}: the sweep has failed tasks: {doc['failures']}")
    plan = plan_sweep(doc["sweep"], directory)  # the tasks' raw products
    raws = {job.key: job.raw for job in plan.sims}
    times = {r["task"]: r for r in doc["rows"]}
    if set(times) != {t.task_id for t in plan.tasks}:
        raise SystemExit(f"{directory}: the sweep's table does not hold the tasks of {doc['sweep']}")
    by_search, by_channels = {}, {}
    for task in plan.tasks:
        p = build(ReconstructParams, task.config.get("reconstruct") or {})
        ch = task.config["effects"]["azimuth_channels"]
        n, d = ch["n_receivers"], parse_quantity(ch["spacing"], "length")

        def products(t=task):
            return read_product(t.directory / "reconstruct.h5"), read_product(raws[t.sim_key])

        if any(k.startswith("reconstruct.") for k in task.setting):
            by_search[(p.search, p.velocity_step, p.coarse_step, n, d)] = (task, products)
        else:
            by_channels[(n, p)] = (task, products)
        if n == 3 and any(k.startswith("reconstruct.") for k in task.setting) and d != 2.0:
            raise SystemExit(f"{directory}: {task.task_id}: the search rows run on N = 3, d = 2 m")

    def pick(table, key, what):
        if key not in table:
            raise SystemExit(f"{directory}: no task with the script's setting {what} ({key})")
        task, products = table.pop(key)
        return times[task.task_id], *products()

    rows, rec3, raw3 = [], None, None
    default = ReconstructParams()
    for search, step in SEARCH:
        p = search_params(search, step)
        row, rec, raw = pick(by_search, (p.search, p.velocity_step, p.coarse_step, 3, 2.0), f"search {search} {step}")
        rows.append(search_row(search, step, rec, raw, row["focus_s"]))
        rows[-1]["times_s"] = row.get("focus_times") or [row["focus_s"]]
    for n in CHANNELS:
        row, rec, r = pick(by_channels, (n, default), f"N = {n}")
        d = float(np.ptp(r.aux["rx_offset"][:, 0])) / (n - 1)
        if abs(d - channel_spacing(r.radar, n)) > 1e-9:
            raise SystemExit(f"{directory}: N = {n}: spacing {d} m, the script's is {channel_spacing(r.radar, n)} m")
        rows.append(channel_row(n, rec, r, row["focus_s"], row["simulate_s"]))
        rows[-1]["times_s"] = row.get("focus_times") or [row["focus_s"]]
        if n == 3:
            rec3, raw3 = rec, r  # the script's default reconstruct for the interpolation rows
    if by_search or by_channels:
        raise SystemExit(
            f"{directory}: tasks that are none of the script's settings: "
            f"{[t.task_id for t, _ in [*by_search.values(), *by_channels.values()]]}"
        )
    return rows + interpolation_rows(rec3, raw3)


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--results", default="results/003-accuracy")
    ap.add_argument("--config", default="configs/xu_scene.yaml")
    ap.add_argument(
        "--from-sweep",
        type=Path,
        default=None,
        help="build the table from this sweep's products (configs/sweeps/accuracy_003.yaml)",
    )
    args = ap.parse_args()
    res = Path(args.results)
    res.mkdir(parents=True, exist_ok=True)
    if args.from_sweep:
        rows = from_sweep(args.from_sweep)
        how = (
            f"Sweep {args.from_sweep}: search and channel rows' time_s and simulate_s are the sweep's step "
            "times (best of the sweep's interleaved repeats as a CLI step, product I/O included; time_spread_s "
            "max - min of them); interpolation rows timed here, one run."
        )
    else:
        rows = run(args.config)
        how = f"Single moving target B (v_r 10 m/s) of {args.config}."
    write(res, rows, how)


def run(config):
    rows = []
    raw = sim(scene_mapping(config, [TARGET]))

    for search, step in SEARCH:
        t0 = time.perf_counter()
        rec = reconstruct(raw, search_params(search, step))
        rows.append(search_row(search, step, rec, raw, time.perf_counter() - t0))

    for n in CHANNELS:
        m = scene_mapping(config, [TARGET])
        spacing = channel_spacing(raw.radar, n)
        m["effects"]["azimuth_channels"] = {"n_receivers": n, "spacing": f"{spacing} m"}
        t0 = time.perf_counter()
        r = sim(m)
        t_sim = time.perf_counter() - t0
        t0 = time.perf_counter()
        rec = reconstruct(r, ReconstructParams())
        rows.append(channel_row(n, rec, r, time.perf_counter() - t0, t_sim))

    return rows + interpolation_rows(reconstruct(raw, ReconstructParams()), raw)


def write(res, rows, how):
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
