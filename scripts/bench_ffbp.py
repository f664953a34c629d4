#!/usr/bin/env python3
"""Fast factorised backprojection against the exact compiled engine on the bench scene (scripts/bench.py), in one
interleaved run: for each grid size, the exact image once, then each ffbp setting; best of ``--repeats`` warm calls,
error of each ffbp image against the exact one (measured and predicted, dB).

    PYTHONPATH=. python scripts/bench_ffbp.py [--sizes 512 1024 2048] [--repeats 3] [--json OUT.json]
"""

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

SETTINGS = [(4, 3.0, "cubic"), (4, 4.0, "cubic"), (4, 5.0, "cubic")]


def best_of(fn, repeats):
    out, best = None, math.inf
    for _ in range(repeats):
        t = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t)
    return out, best


def main():
    from bench import bench_scene_case, plane_grid
    from sarproc.focus.backprojection import backproject_points
    from sarproc.focus.ffbp import ffbp_points, predicted_error

    ap = argparse.ArgumentParser()
    ap.add_argument("--sizes", type=int, nargs="+", default=[512, 1024, 2048])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--json")
    a = ap.parse_args()
    case = bench_scene_case()
    rows = []
    for n in a.sizes:
        spacing = case["spacing"] * 512 / n * 2 if n > 1024 else case["spacing"]   # 2048: 0.15 m, 307 m wide
        pts = plane_grid(case["centre"], case["e1"], case["e2"], n, spacing)
        common = dict(gate_offset=case["gate"])
        exact, t_exact = best_of(lambda: backproject_points(case["rc"], case["range_time"], case["pos"], case["pos"],
                                                           pts, case["fc"], engine="compiled", **common), a.repeats)
        power = float(np.sum(np.abs(exact) ** 2))
        rows.append({"n": n, "spacing": spacing, "engine": "exact", "time_s": t_exact})
        print(f"{n}x{n} ({spacing:.3f} m, {len(case['pos'])} pulses): exact {t_exact:.3f} s", flush=True)
        for k, q, interp in SETTINGS:
            img, t = best_of(lambda: ffbp_points(case["rc"], case["range_time"], case["pos"], pts, case["fc"],
                                                 case["bandwidth"], factor=k, oversample=q, ffbp_interpolation=interp,
                                                 grid_shape=(n, n), **common), a.repeats)
            err = float(np.sum(np.abs(img - exact) ** 2)) / power
            pred = predicted_error(len(case["pos"]), k, q, interp)
            rows.append({"n": n, "spacing": spacing, "engine": "ffbp", "factor": k, "oversample": q,
                         "interpolation": interp, "time_s": t, "speedup": t_exact / t,
                         "error_db": 10 * math.log10(err), "predicted_db": 10 * math.log10(pred)})
            print(f"  ffbp factor {k} oversample {q} {interp}: {t:.3f} s ({t_exact / t:.2f}x), error "
                  f"{10 * math.log10(err):.1f} dB (predicted {10 * math.log10(pred):.1f})", flush=True)
    if a.json:
        Path(a.json).write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
