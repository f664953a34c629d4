"""Paper 002 accuracy against time: each pfa2 knob alone on one scene (default the reduced Table 1 scene).

    python scripts/accuracy_002.py --config configs/nie2016_small.yaml --out results/002-accuracy

For each setting: run times of pfa2 (--repeat runs, interleaved round-robin over the settings, one
process: best, median and spread) and the worst target's
quality (the largest of |IRW / own theory - 1| / 5 %, |PSLR + 13.26| / 0.5 dB, |ISLR + 10.16| / 0.5
dB and |position| / 0.5 cell: <= 1 is within the issue's tolerance). Writes table.md (with the
Pareto front named) and tradeoff.png. A setting is faster than another only when its worst time is
below the other's best; the front is that of (best time, quality) (sarproc.quality.tradeoff).

    python scripts/accuracy_002.py --from-sweep DIR --out results/002-accuracy

``make accuracy-002`` runs the settings as a sweep (configs/sweeps/accuracy_002.yaml, on Dask) and then
this script with ``--from-sweep``: the same table from the sweep's images (the per-target score against
each target's own theory is no sweep column); its times are the sweep's focus times (``repeats:`` runs
of each task, interleaved, product I/O included).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import reproduce_002  # (same folder: the per-target table against own theory)

from sarproc.focus.pfa.chain import Pfa2Params, pfa2
from sarproc.product.config import load_yaml
from sarproc.quality.tradeoff import faster_groups, pareto_front, timing_stats
from sarproc.quality.tradeoff_plot import plot_tradeoff
from sarproc.simulation.scene import load_scene
from sarproc.simulation.simulate import simulate

SETTINGS = [
    ("plain (baseline PFA)", {"method": "plain"}),
    ("two-step (defaults)", {}),
    ("kernel knab 4", {"range_kernel_length": 4, "azimuth_kernel_length": 4}),
    ("kernel knab 16", {"range_kernel_length": 16, "azimuth_kernel_length": 16}),
    ("kernel cubic", {"range_kernel": "cubic", "azimuth_kernel": "cubic"}),
    ("kernel linear", {"range_kernel": "linear", "azimuth_kernel": "linear"}),
    ("sub-image 0.5 radius", {"subimage_size": 0.5}),
    ("sub-image 1.5 radius", {"subimage_size": 1.5}),
    ("overlap 0.1", {"subimage_overlap": 0.1}),
    ("sub-image oversampling 1.25", {"subimage_oversampling": 1.25}),
    ("sub-image oversampling 2", {"subimage_oversampling": 2.0}),
    ("range oversampling 1.5", {"range_oversampling": 1.5}),
]


def worst(rows) -> float:
    return max(max(reproduce_002.badness(r), max(abs(p) / 0.5 for p in r["pos"])) for r in rows)


def _sweep_setting(row) -> dict:
    return {k.split(".", 1)[1]: v for k, v in row.items() if k.startswith("pfa2.")}


def from_sweep(directory: Path) -> tuple[list, str]:
    """(label, time, worst, false-target level) per setting, from a sweep of configs/sweeps/accuracy_002.yaml."""
    from sarproc.product.io import read_product

    doc = json.loads((directory / "table.json").read_text())
    if doc["failures"]:
        raise SystemExit(f"{directory}: the sweep has failed tasks: {doc['failures']}")
    raws = sorted((directory / "raw").glob("*.h5"))
    if len(raws) != 1:
        raise SystemExit(f"{directory}: expected one raw product, found {len(raws)}")
    raw = read_product(raws[0])
    rows = {json.dumps(_sweep_setting(r), sort_keys=True): r for r in doc["rows"]}
    two_step = next(r for r in doc["rows"] if _sweep_setting(r) == {"method": "two_step"})
    radius = read_product(directory / "tasks" / two_step["task"] / "pfa2.h5", load=False).attrs["valid_radius_eq7"]
    results = []
    for label, change in SETTINGS:
        want = dict(change) if change else {"method": "two_step"}
        if "subimage_size" in want:
            want["subimage_size"] = want["subimage_size"] * radius
        match = [r for k, r in rows.items() if _same(json.loads(k), want)]
        if len(match) != 1:
            raise SystemExit(f"{directory}: no single task with the setting {label!r} ({want})")
        image = read_product(directory / "tasks" / match[0]["task"] / "pfa2.h5")
        table_rows, false = reproduce_002.table(raw, image)
        times = match[0].get("focus_times") or [match[0]["focus_s"]]
        if match[0].get("repeats_identical") is False:
            raise SystemExit(f"{directory}: task {match[0]['task']}: its repeated images differ from the first run")
        results.append((label, times, worst(table_rows), false.level_db))
    n = min(len(r[1]) for r in results)
    identical = " (repeats bit-identical to the first run)" if n > 1 else ""
    return results, f"the sweep's focus times, {n} interleaved runs each{identical}"


def _same(got: dict, want: dict) -> bool:
    """A task's setting (YAML values: '48.87 m' is metres) equals a script setting (floats to 1e-9)."""
    if set(got) != set(want):
        return False
    for k, w in want.items():
        g = got[k]
        if isinstance(w, float):
            g = float(g[:-2]) if isinstance(g, str) and g.endswith(" m") else g
            if not isinstance(g, (int, float)) or abs(g - w) > 1e-9 * abs(w):
                return False
        elif g != w:
            return False
    return True


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--config", type=Path, default=Path("configs/nie2016_small.yaml"))
    ap.add_argument("--out", type=Path, default=Path("results/002-accuracy"))
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument(
        "--from-sweep",
        type=Path,
        default=None,
        help="build the table from this sweep's images instead of running the settings",
    )
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    if args.from_sweep:
        results, timing = from_sweep(args.from_sweep)
        return write(args, results, f"{args.from_sweep}, {timing}")
    raw = simulate(load_scene(args.config))
    base = {k: v for k, v in (load_yaml(args.config).get("pfa2", {}) or {}).items() if k != "method"}
    radius = None
    results, kws = [], []
    for _label, change in SETTINGS:
        kw = {**base, **change}
        if "subimage_size" in change:
            if radius is None:
                radius = pfa2(raw, Pfa2Params(**base)).attrs["valid_radius_eq7"]
            kw["subimage_size"] = change["subimage_size"] * radius
        kws.append(kw)
    times = [[] for _ in kws]
    images = [None] * len(kws)
    for _ in range(args.repeat):  # round-robin: a slow spell of the machine hits every setting
        for i, kw in enumerate(kws):
            t0 = time.perf_counter()
            images[i] = pfa2(raw, Pfa2Params(**kw))
            times[i].append(time.perf_counter() - t0)
    for (label, _), t, image in zip(SETTINGS, times, images):
        rows, false = reproduce_002.table(raw, image)
        results.append((label, t, worst(rows), false.level_db))
    write(args, results, f"{args.config}, {args.repeat} interleaved runs each")


def write(args, results, how: str):
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
