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
from functools import partial
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


def fastsar_rows(case, n, spacing, exact, power, python, calls):
    """FastSAR's formers on the same pulses and grid (scripts/bench_fastsar.py in its venv), each image's error
    against sarproc's exact one after a least-squares complex scale (FastSAR's own normalisation)."""
    import subprocess
    import tempfile

    from bench import history_from_pulses

    S, ref, fmin, df = history_from_pulses(
        case["rc"], case["range_time"], case["gate"], case["pos"], case["centre"], case["fc"], case["fs"]
    )
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        path, out = Path(tmp) / "case.npz", Path(tmp) / "images.npz"
        np.savez(
            path,
            S=S,
            ant=case["pos"] - case["centre"],
            ref=ref,
            fmin=fmin,
            df=df,
            nx=n,
            ny=n,
            spx=spacing,
            spy=spacing,
            e1=case["e1"],
            e2=case["e2"],
            center=np.zeros(3),
        )
        res = subprocess.run(
            [
                python,
                str(Path(__file__).resolve().parent / "bench_fastsar.py"),
                str(path),
                str(out),
                "--calls",
                str(calls),
                "--factorised",
                "-40",
                "-50",
            ],
            capture_output=True,
            text=True,
        )
        if res.returncode != 0:
            print(f"  FastSAR failed: {res.stderr.strip()[-300:]}", flush=True)
            return rows
        info = json.loads(res.stdout.strip().splitlines()[-1])
        imgs = np.load(out)
        ex = exact.reshape(n, n)
        for key in ("linear", "imageformer-40", "imageformer-50"):
            img = imgs[key].reshape(n, n)
            scale = np.vdot(img, ex) / np.vdot(img, img)
            err = float(np.sum(np.abs(scale * img - ex) ** 2)) / power
            rows.append(
                {
                    "n": n,
                    "spacing": spacing,
                    "engine": f"fastsar {key}",
                    "time_s": info[key]["time_s"],
                    "error_db": 10 * math.log10(max(err, 1e-30)),
                }
            )
            print(
                f"  FastSAR {key}: {info[key]['time_s']:.3f} s, error {10 * math.log10(max(err, 1e-30)):.1f} dB "
                "against sarproc's exact image",
                flush=True,
            )
    return rows


def main():
    from bench import bench_scene_case, plane_grid

    from sarproc.focus.backprojection import backproject_points
    from sarproc.focus.ffbp import ffbp_points, predicted_error

    ap = argparse.ArgumentParser()
    ap.add_argument("--sizes", type=int, nargs="+", default=[512, 1024, 2048])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--json")
    ap.add_argument(
        "--fastsar-python",
        help="the bench venv's python (make bench-venv): FastSAR's exact linear x8 "
        "and factorised ImageFormer (target -40 and -50 dB) on the same pulses",
    )
    a = ap.parse_args()
    case = bench_scene_case()
    rows = []
    for n in a.sizes:
        spacing = case["spacing"] * 512 / n * 2 if n > 1024 else case["spacing"]  # 2048: 0.15 m, 307 m wide
        pts = plane_grid(case["centre"], case["e1"], case["e2"], n, spacing)
        common = dict(gate_offset=case["gate"])
        exact, t_exact = best_of(
            partial(
                backproject_points,
                case["rc"],
                case["range_time"],
                case["pos"],
                case["pos"],
                pts,
                case["fc"],
                engine="compiled",
                **common,
            ),
            a.repeats,
        )
        power = float(np.sum(np.abs(exact) ** 2))
        rows.append({"n": n, "spacing": spacing, "engine": "exact", "time_s": t_exact})
        print(f"{n}x{n} ({spacing:.3f} m, {len(case['pos'])} pulses): exact {t_exact:.3f} s", flush=True)
        for k, q, interp in SETTINGS:
            img, t = best_of(
                partial(
                    ffbp_points,
                    case["rc"],
                    case["range_time"],
                    case["pos"],
                    pts,
                    case["fc"],
                    case["bandwidth"],
                    factor=k,
                    oversample=q,
                    ffbp_interpolation=interp,
                    grid_shape=(n, n),
                    **common,
                ),
                a.repeats,
            )
            err = float(np.sum(np.abs(img - exact) ** 2)) / power
            pred = predicted_error(len(case["pos"]), k, q, interp)
            rows.append(
                {
                    "n": n,
                    "spacing": spacing,
                    "engine": "ffbp",
                    "factor": k,
                    "oversample": q,
                    "interpolation": interp,
                    "time_s": t,
                    "speedup": t_exact / t,
                    "error_db": 10 * math.log10(err),
                    "predicted_db": 10 * math.log10(pred),
                }
            )
            print(
                f"  ffbp factor {k} oversample {q} {interp}: {t:.3f} s ({t_exact / t:.2f}x), error "
                f"{10 * math.log10(err):.1f} dB (predicted {10 * math.log10(pred):.1f})",
                flush=True,
            )
        if a.fastsar_python:
            rows += fastsar_rows(case, n, spacing, exact, power, a.fastsar_python, a.repeats)
    if a.json:
        Path(a.json).write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
