"""Paper 002 accuracy against time: each pfa2 knob alone on the reduced Table 1 scene.

    python scripts/accuracy_002.py --from-sweep DIR --out results/002-accuracy

``make accuracy-002`` runs the settings as a sweep (configs/sweeps/accuracy_002.yaml, on Dask: the one
list of settings) and then this script: per setting, the sweep's focus times (``repeats:`` runs of each
task, interleaved, product I/O included: best, median and spread) and the worst target's quality, its
score against its own theory (the sweep's `sarproc evaluate` reports' tolerance_score per target,
sarproc.quality.summary.tolerance_score: the largest of |IRW / own theory
- 1| / 5 %, |PSLR - theory| / 0.5 dB, |ISLR - theory| / 0.5 dB and |position| / 0.5 cell; <= 1 is within
the issue's tolerance; each target's theory is what pfa2 records from its own polar support), which is no
sweep column. Writes table.md (with the Pareto front named), table.json and tradeoff.png. A setting is
faster than another only when its worst time is below the other's best; the front is that of (best time,
quality) (sarproc.quality.tradeoff).
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

from sarproc.cli.sweep_output import sweep_rows
from sarproc.product.io import read_product
from sarproc.product.units import parse_quantity
from sarproc.quality.tradeoff import faster_groups, pareto_front, timing_stats
from sarproc.quality.tradeoff_plot import plot_tradeoff


def label(setting: dict, radius: float | None) -> str:
    """A sweep task's pfa2 setting in words; sub-image sizes as fractions of eq. (7)'s valid radius."""
    words = []
    for key, value in setting.items():
        name = key.split(".", 1)[1]
        if name == "subimage_size":
            assert radius is not None, "a sub-image size setting without the images' valid_radius_eq7"
            value = f"{parse_quantity(value, 'length') / radius:.2g} x eq. (7) radius"
        words.append(f"{name} {value}")
    return ", ".join(words)


def from_sweep(directory: Path) -> tuple[list, str]:
    """(label, times, worst score, false-target level) per task, from a sweep of configs/sweeps/accuracy_002.yaml."""
    rows = sweep_rows(directory)
    radius = None
    for row in rows:
        attrs = read_product(row["dir"] / "pfa2.h5", load=False).attrs
        if attrs.get("valid_radius_eq7"):
            radius = attrs["valid_radius_eq7"]
            break
    results = []
    for row in rows:
        setting = {k: v for k, v in row.items() if k.startswith("pfa2.")}
        if row.get("repeats_identical") is False:
            raise SystemExit(f"{directory}: task {row['task']}: its repeated images differ from the first run")
        report = json.loads((row["dir"] / "report.json").read_text())  # the sweep's `sarproc evaluate -o`
        if any("tolerance_score" not in t for t in report["targets"]):
            raise SystemExit(
                f"{row['dir']}/report.json: no tolerance_score (an older sarproc's): delete it, rerun the sweep"
            )
        worst = max(math.nan if t["tolerance_score"] is None else t["tolerance_score"] for t in report["targets"])
        ft = report["false_target"]
        level = float("-inf") if ft is None else (math.nan if ft["level_db"] is None else ft["level_db"])
        results.append((label(setting, radius), row.get("focus_times") or [row["focus_s"]], worst, level))
    n = min(len(r[1]) for r in results)
    identical = " (repeats bit-identical to the first run)" if n > 1 else ""
    return results, f"the sweep's focus times, {n} interleaved runs each{identical}"


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--out", type=Path, default=Path("results/002-accuracy"))
    ap.add_argument("--from-sweep", type=Path, required=True, help="the sweep of configs/sweeps/accuracy_002.yaml")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    results, timing = from_sweep(args.from_sweep)
    write(args, results, f"{args.from_sweep}, {timing}")


def write(args: argparse.Namespace, results: list[tuple[str, list[float], float, float]], how: str) -> None:
    times = [r[1] for r in results]
    quality = [r[2] for r in results]
    front = pareto_front(times, quality)
    stats = [timing_stats(t) for t in times]
    beats = faster_groups(times)
    lines = [
        f"# pfa2 accuracy against time ({how})",
        "",
        "A setting is faster than another only when its worst time is below the other's best (the "
        "ranges of their repeated times do not overlap): the 'faster than #' column. The Pareto front is "
        "that of (best time, quality); front neighbours not in each other's 'faster' column are not "
        "resolved by the timings.",
        "",
        "| # | setting | best (s) | median (s) | spread (s) | worst target / tolerance | false target (dB) "
        "| faster than # | Pareto |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for i, ((label, _, w, f), st) in enumerate(zip(results, stats)):
        lines.append(
            f"| {i + 1} | {label} | {st['best']:.2f} | {st['median']:.2f} | {st['spread']:.2f} | {w:.2f} "
            f"| {f:.1f} | {', '.join(str(j + 1) for j in beats[i]) or '-'} | {'yes' if i in front else ''} |"
        )
    lines += ["", "Pareto front (by best time): " + ", ".join(results[i][0] for i in front), ""]
    (args.out / "table.md").write_text("\n".join(lines))
    (args.out / "table.json").write_text(
        json.dumps(
            [
                {
                    "setting": label,
                    "times_s": t,
                    **{f"{k}_s": st[k] for k in ("best", "median", "spread")},
                    "worst_over_tolerance": w,
                    "false_target_db": f,
                    "pareto": i in front,
                }
                for i, ((label, t, w, f), st) in enumerate(zip(results, stats))
            ],
            indent=1,
        )
        + "\n"
    )
    plot_tradeoff(
        args.out / "tradeoff.png",
        [r[0] for r in results],
        times,
        quality,
        quality_label="worst target / tolerance (<= 1 within tolerance)",
        title="pfa2 knobs, reduced Table 1 scene",
        log_quality=True,
        floor=1e-3,
    )
    print("\n".join(lines))


if __name__ == "__main__":
    main()
