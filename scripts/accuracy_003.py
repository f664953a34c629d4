"""What accuracy costs in time for paper 003's reconstruct (``make accuracy-003``): a table of two sweeps.

On the single moving target T (v_r = 10 m/s), one knob at a time, the sweeps' settings (their one source):

* velocity-search step (and fast vs exhaustive search): reconstruct time, number of leakage
  evaluations, |v_r error|, and the false-target level it leaves (strip MFTA);
* number of channels N = 3, 4, 5 at the same PRF and beam (d = 2 v / (N PRF), uniform): time,
  v_r error, worst IRW ratio / PSLR and MFTA;
* backprojection interpolation knobs on the N = 3 reconstruct (range upsampling, linear vs nearest):
  backproject time against worst-target quality and MFTA (reconstruct itself interpolates nothing: its
  filter bank is exact in the frequency domain).

The computing is the sweeps' (``make accuracy-003`` runs both): configs/sweeps/accuracy_003.yaml times
reconstruct alone (best of its interleaved repeats as a CLI step, product I/O included) and its products
hold the search results (v_r, evaluations); configs/sweeps/accuracy_003_images.yaml reconstructs every
case again and backprojects it twice, ``image`` (where the moving target appears: the quality) and
``strip`` (the false-target strip: MFTA), and evaluates both. This script only reads the two sweeps'
tables, products' attributes and step records, and writes table.md, table.json and accuracy.png
under --results.

    python scripts/accuracy_003.py --from-sweep DIR --images-sweep DIR2 --results results/003-accuracy
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from sarproc.cli.sweep_output import sweep_rows
from sarproc.product.config import load_yaml
from sarproc.product.io import read_product
from sarproc.product.units import parse_quantity


def only_window(rec_path: Path) -> dict:
    """The one moving-target window of a single-target scene's reconstruct product (a second one would be a
    detection error)."""
    windows = read_product(rec_path, load=False).attrs["reconstruct"]["moving_targets"]
    if len(windows) != 1:
        raise SystemExit(f"{rec_path}: expected one moving-target window, got {len(windows)}: {windows}")
    return windows[0]


def reconstruct_parameters(rec_path: Path) -> dict[str, Any]:
    """The resolved parameters reconstruct recorded in its product's history (defaults filled in)."""
    history = read_product(rec_path, load=False).history
    return next(h["parameters"] for h in reversed(history) if "reconstruct" in str(h.get("command", "")))


def _quality(row: dict[str, Any]) -> dict[str, Any]:
    """Worst |IRW / theory - 1|, PSLR and |position error| of an image row (the sweep's evaluate report)."""
    return {"worst_irw_dev": row["irw_dev"], "worst_pslr_db": row["pslr_db"], "worst_pos_cells": row["position_cells"]}


def _mfta(row: dict[str, Any]) -> float:
    """The strip's false-target level, dB (-inf where the evaluate report found none)."""
    level = row["false_target_db"]
    return float("-inf") if level is None else float(level)


KNOBS = ("interpolation", "upsample")  # the backprojection knobs of the interpolation rows


def _stem(config: dict[str, Any]) -> dict[str, Any]:
    """What a task reconstructs: its config without the backprojection and evaluate sections."""
    return {k: v for k, v in config.items() if k not in ("backproject", "evaluate")}


def _images_of(image_rows: list[dict[str, Any]], config: dict[str, Any]) -> dict[str, dict[str, Any]]:
    """{"image": row, "strip": row} of the images sweep for a reconstruct config (no interpolation knob set)."""
    found: dict[str, list] = {"image": [], "strip": []}
    for row in image_rows:
        cfg = row["config"]
        if _stem(cfg) == _stem(config) and not set(KNOBS) & set(cfg["backproject"]):
            found["strip" if cfg["backproject"].get("frame") == "squint_lrwc" else "image"].append(row)
    if len(found["strip"]) != 1 or len(found["image"]) > 1:
        raise SystemExit(f"expected one strip and at most one image of {config.get('reconstruct')}, got {found}")
    return {k: v[0] for k, v in found.items() if v}


def from_sweeps(timed: Path, images: Path) -> list[dict[str, Any]]:
    """The script's rows: a row per task of the timed reconstruct sweep, in its order (tasks that set
    reconstruct knobs are search rows, the others channel rows), then the images sweep's interpolation rows
    (its images with a backprojection knob); a row's image and strip are the images sweep's tasks that
    reconstruct as it does."""
    timed_rows = sweep_rows(timed)
    image_rows = [{**r, "config": load_yaml(r["dir"] / "config.yaml")} for r in sweep_rows(images)]
    knobs = json.loads((timed / "table.json").read_text())["knobs"]
    search_rows: list[dict] = []
    channel_rows: list[dict] = []
    for row in timed_rows:
        config = load_yaml(row["dir"] / "config.yaml")
        v_r = parse_quantity(config["targets"]["points"][0]["velocity"][1], "velocity")
        mt = only_window(row["dir"] / "reconstruct.h5")
        shots = _images_of(image_rows, config)
        out = {
            "time_s": row["focus_s"],
            "times_s": row.get("focus_times") or [row["focus_s"]],
            "evaluations": mt["search_evaluations"],
            "v_r_error": abs(mt["radial_velocity"] - v_r),
        }
        if any(k.startswith("reconstruct.") for k in knobs if k in row):
            p = reconstruct_parameters(row["dir"] / "reconstruct.h5")
            knob = f"search {p['search']} step {p['velocity_step']} m/s"
            search_rows.append({"knob": knob, **out, "mfta_db": _mfta(shots["strip"])})
        else:
            n = config["effects"]["azimuth_channels"]["n_receivers"]
            channel_rows.append(
                {
                    "knob": f"N = {n} channels",
                    **out,
                    "simulate_s": row["simulate_s"],
                    **_quality(shots["image"]),
                    "mfta_db": _mfta(shots["strip"]),
                }
            )
    interpolation_rows: list[dict] = []
    for row in image_rows:
        bp = row["config"]["backproject"]
        if bp.get("frame") == "squint_lrwc" or not set(KNOBS) & set(bp):
            continue
        strip = [
            r
            for r in image_rows
            if {k: v for k, v in r["config"]["backproject"].items() if k in KNOBS}
            == {k: v for k, v in bp.items() if k in KNOBS}
            and r["task"] != row["task"]
        ]
        if len(strip) != 1:
            raise SystemExit(f"{images}: expected one strip with the knobs of {row['task']}, got {len(strip)}")
        # the backproject step's own times over the sweep's interleaved repeats (its reconstruct before it is the
        # N = 3 one); a sweep without repeats: its one run
        times = (row.get("focus_step_times") or {}).get("backproject")
        if not times:
            times = [json.loads((row["dir"] / "backproject.h5.done.json").read_text())["seconds"]]
        interpolation_rows.append(
            {
                "knob": f"backproject {bp['interpolation']} x{bp['upsample']}",
                "time_s": min(times),
                "times_s": times,
                **_quality(row),
                "mfta_db": _mfta(strip[0]),
            }
        )
    return search_rows + channel_rows + interpolation_rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--results", default="results/003-accuracy")
    ap.add_argument("--from-sweep", type=Path, required=True, help="the sweep of configs/sweeps/accuracy_003.yaml")
    ap.add_argument(
        "--images-sweep", type=Path, required=True, help="the sweep of configs/sweeps/accuracy_003_images.yaml"
    )
    args = ap.parse_args()
    res = Path(args.results)
    res.mkdir(parents=True, exist_ok=True)
    rows = from_sweeps(args.from_sweep, args.images_sweep)
    how = (
        f"Sweeps {args.from_sweep} (reconstruct) and {args.images_sweep} (images and strips): search and "
        "channel rows' time_s and simulate_s are the reconstruct sweep's step times (best of its interleaved "
        "repeats as a CLI step, product I/O included; time_spread_s max - min of them); interpolation rows' "
        "the images sweep's backproject step, best of its interleaved repeats (a CLI step, product I/O included)."
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
