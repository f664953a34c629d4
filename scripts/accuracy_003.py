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
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from reproduce_003 import focus, ghost_strips, scene_mapping, sim
from sarproc.focus.backprojection import BackprojectParams
from sarproc.focus.multichannel.reconstruct import ReconstructParams, reconstruct
from sarproc.quality.metrics import EvaluateParams, evaluate_product

TARGET = {"name": "T", "azimuth": "800 m", "velocity": ["0 m/s", "10 m/s", "0 m/s"]}


def only_window(rec):
    """The one moving-target window of a single-target scene (a second one would be a detection error)."""
    windows = rec.attrs["reconstruct"]["moving_targets"]
    if len(windows) != 1:
        raise RuntimeError(f"expected one moving-target window, got {len(windows)}: {windows}")
    return windows[0]


def worst(report):
    t = report.targets[0]
    return (max(abs(a.irw_ratio - 1) for a in t.axes), max(a.pslr_db for a in t.axes),
            max(abs(a.position_error_cells) for a in t.axes))


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--results", default="results/003-accuracy")
    ap.add_argument("--config", default="configs/xu_scene.yaml")
    args = ap.parse_args()
    res = Path(args.results)
    res.mkdir(parents=True, exist_ok=True)
    rows = []
    raw = sim(scene_mapping(args.config, [TARGET]))

    for search, step in (("fast", 0.5), ("fast", 0.2), ("fast", 0.1), ("fast", 0.05), ("exhaustive", 0.1)):
        t0 = time.perf_counter()
        rec = reconstruct(raw, ReconstructParams(search=search, velocity_step=step, coarse_step=max(step, 2.0)))
        dt = time.perf_counter() - t0
        mt = only_window(rec)
        rows.append({"knob": f"search {search} step {step} m/s", "time_s": dt,
                     "evaluations": mt["search_evaluations"], "v_r_error": abs(mt["radial_velocity"] - 10.0),
                     "mfta_db": ghost_strips(rec, raw)["T"][0]})

    for n in (3, 4, 5):
        m = scene_mapping(args.config, [TARGET])
        spacing = 2 * raw.radar.velocity / (n * raw.radar.prf)          # uniform phase centres at this PRF
        m["effects"]["azimuth_channels"] = {"n_receivers": n, "spacing": f"{spacing} m"}
        t0 = time.perf_counter()
        r = sim(m)
        t_sim = time.perf_counter() - t0
        t0 = time.perf_counter()
        rec = reconstruct(r, ReconstructParams())
        dt = time.perf_counter() - t0
        mt = only_window(rec)
        irw, pslr, pos = worst(evaluate_product(focus(rec, r, BackprojectParams(oversample=1.25),
                                                      theory_from_truth=True), EvaluateParams(guard_cells=60)))
        rows.append({"knob": f"N = {n} channels", "time_s": dt, "simulate_s": t_sim,
                     "evaluations": mt["search_evaluations"], "v_r_error": abs(mt["radial_velocity"] - 10.0),
                     "worst_irw_dev": irw, "worst_pslr_db": pslr, "worst_pos_cells": pos,
                     "mfta_db": ghost_strips(rec, r)["T"][0]})

    rec = reconstruct(raw, ReconstructParams())
    for interp, up in (("nearest", 8), ("linear", 2), ("linear", 4), ("linear", 8), ("linear", 16)):
        bp = BackprojectParams(oversample=1.25, upsample=up, interpolation=interp)
        t0 = time.perf_counter()
        img = focus(rec, raw, bp, theory_from_truth=True)
        dt = time.perf_counter() - t0
        irw, pslr, pos = worst(evaluate_product(img, EvaluateParams(guard_cells=60)))
        rows.append({"knob": f"backproject {interp} x{up}", "time_s": dt, "worst_irw_dev": irw,
                     "worst_pslr_db": pslr, "worst_pos_cells": pos,
                     "mfta_db": ghost_strips(rec, raw, upsample=up, interpolation=interp)["T"][0]})

    (res / "table.json").write_text(json.dumps(rows, indent=1, default=float))
    cols = ["knob", "time_s", "simulate_s", "evaluations", "v_r_error", "worst_irw_dev", "worst_pslr_db",
            "worst_pos_cells", "mfta_db"]
    lines = ["# Paper 003 reconstruct: accuracy against time (scripts/accuracy_003.py)", "",
             f"Single moving target B (v_r 10 m/s) of {args.config}. time_s: reconstruct (search and channel rows) or "
             "backproject of the chip (interpolation rows); MFTA: strip false-target level, dB (the strip is "
             "backprojected with the row's interpolation knobs).", "",
             "| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    for r in rows:
        cells = []
        for c in cols:
            v = r.get(c, "")
            cells.append(f"{v:.3g}" if isinstance(v, float) else str(v))
        lines.append("| " + " | ".join(cells) + " |")
    (res / "table.md").write_text("\n".join(lines) + "\n")

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7, 5))
    for r in rows:
        ax.scatter(r["time_s"], r["mfta_db"])
        ax.annotate(r["knob"], (r["time_s"], r["mfta_db"]), fontsize=7)
    ax.set_xlabel("stage time, s")
    ax.set_ylabel("false-target level, dB")
    fig.tight_layout()
    fig.savefig(res / "accuracy.png", dpi=110)


if __name__ == "__main__":
    main()
