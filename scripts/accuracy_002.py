"""Paper 002 accuracy against time: each pfa2 knob alone on one scene (default the reduced Table 1 scene).

    python scripts/accuracy_002.py --config configs/nie2016_small.yaml --out results/002-accuracy

For each setting: run time of pfa2 (median of --repeat runs, one process) and the worst target's
quality (the largest of |IRW / own theory - 1| / 5 %, |PSLR + 13.26| / 0.5 dB, |ISLR + 10.16| / 0.5
dB and |position| / 0.5 cell: <= 1 is within the issue's tolerance). Writes table.md (with the
Pareto front named) and tradeoff.png.
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from sarproc.focus.pfa.chain import Pfa2Params, pfa2  # noqa: E402
from sarproc.product.config import load_yaml  # noqa: E402
from sarproc.simulation.scene import load_scene  # noqa: E402
from sarproc.simulation.simulate import simulate  # noqa: E402

import reproduce_002  # noqa: E402  (same folder: the per-target table against own theory)

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


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--config", type=Path, default=Path("configs/nie2016_small.yaml"))
    ap.add_argument("--out", type=Path, default=Path("results/002-accuracy"))
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    raw = simulate(load_scene(args.config))
    base = {k: v for k, v in (load_yaml(args.config).get("pfa2", {}) or {}).items() if k != "method"}
    radius = None
    results = []
    for label, change in SETTINGS:
        kw = {**base, **change}
        if "subimage_size" in change:
            if radius is None:
                radius = pfa2(raw, Pfa2Params(**base)).attrs["valid_radius_eq7"]
            kw["subimage_size"] = change["subimage_size"] * radius
        times, image = [], None
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            image = pfa2(raw, Pfa2Params(**kw))
            times.append(time.perf_counter() - t0)
        rows, false = reproduce_002.table(raw, image)
        results.append((label, statistics.median(times), worst(rows), false.level_db))
    front = [r for r in results if not any(o[1] <= r[1] and o[2] <= r[2] and (o[1], o[2]) != (r[1], r[2])
                                           for o in results)]
    lines = [f"# pfa2 accuracy against time ({args.config}, median of {args.repeat} runs)", "",
             "| setting | time (s) | worst target / tolerance | false target (dB) | Pareto |",
             "| --- | --- | --- | --- | --- |"]
    for label, t, w, f in results:
        lines.append(f"| {label} | {t:.2f} | {w:.2f} | {f:.1f} | {'yes' if (label, t, w, f) in front else ''} |")
    lines += ["", "Pareto front (no other setting is both faster and better): "
              + ", ".join(r[0] for r in sorted(front, key=lambda r: r[1])), ""]
    (args.out / "table.md").write_text("\n".join(lines))
    plt.figure(figsize=(6, 4))
    for label, t, w, _ in results:
        plt.loglog(t, max(w, 1e-3), "o")
        plt.annotate(label, (t, max(w, 1e-3)), fontsize=7)
    plt.axhline(1, color="k", lw=0.8)
    plt.xlabel("time (s)")
    plt.ylabel("worst target / tolerance")
    plt.tight_layout()
    plt.savefig(args.out / "tradeoff.png", dpi=110)
    print("\n".join(lines))


if __name__ == "__main__":
    main()
