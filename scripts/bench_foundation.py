#!/usr/bin/env python3
"""Foundation benchmark: simulation throughput, backprojection throughput, peak memory.

Everything is measured in one run, and also reported relative to one complex64 2D FFT of the
raw data measured in the same run, since absolute times on shared machines are noisy.
Usage: python scripts/bench_foundation.py [--scale 1.0] [--out results/bench/foundation.md]
"""

from __future__ import annotations

import argparse
import resource
import time
import tracemalloc
from pathlib import Path

import numpy as np
import scipy.fft as sfft

from sarproc.focus.backprojection import BackprojectParams, backproject
from sarproc.simulation.scene import scene_from_mapping
from sarproc.simulation.simulate import plan_simulation, simulate_blocks


def scene(n_targets: int, aperture_s: float, bandwidth_mhz: float) -> dict:
    side = int(np.ceil(np.sqrt(n_targets)))
    pts = [{"name": f"T{i}", "azimuth": f"{(i % side - side / 2) * 20} m", "range": f"{(i // side - side / 2) * 20} m"}
           for i in range(n_targets)]
    return {
        "radar": {"carrier_frequency": "10 GHz", "bandwidth": f"{bandwidth_mhz} MHz", "pulse_duration": "5 us",
                  "range_sampling_rate": f"{1.2 * bandwidth_mhz} MHz", "prf": "600 Hz"},
        "platform": {"velocity": "150 m/s", "altitude": "3 km"},
        "geometry": {"reference_range": "10 km", "squint": "20 deg"},
        "acquisition": {"mode": "spotlight", "aperture_time": f"{aperture_s} s"},
        "targets": {"frame": "los", "points": pts},
    }


def timed(fn):
    t = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - t


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--scale", type=float, default=1.0, help="aperture scale (1.0: about 1200 pulses)")
    ap.add_argument("--out", type=Path, default=Path("results/bench/foundation.md"))
    args = ap.parse_args()
    rows = []
    m = scene(25, 2.0 * args.scale, 150)
    sc = scene_from_mapping(m, "bench")
    plan = plan_simulation(sc)
    n_env = sc.radar.pulse_duration * sc.radar.range_sampling_rate
    tracemalloc.start()
    _, t_sim = timed(lambda: [None for _ in simulate_blocks(sc, plan)])
    _, peak_sim = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    n_az, n_rg = plan.shape[-2:]
    target_samples = n_az * len(sc.target_xyz) * n_env
    # Reference: one complex64 2D FFT of an array the size of the raw data.
    x = (np.random.default_rng(0).standard_normal((n_az, n_rg)) + 0j).astype(np.complex64)
    _, t_fft = timed(lambda: sfft.fft2(x, workers=-1))
    rows.append(("simulate", f"{n_az}x{n_rg}, 25 targets", t_sim, t_sim / t_fft,
                 f"{target_samples / t_sim / 1e6:.1f} M target-samples/s", peak_sim / 2**20))
    from sarproc.simulation.simulate import simulate
    raw = simulate(sc)
    params = BackprojectParams(frame="los", azimuth_extent=150.0, range_extent=150.0)
    tracemalloc.start()
    img, t_bp = timed(lambda: backproject(raw, params))
    _, peak_bp = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    pix_pulses = img.data.size * n_az
    rows.append(("backproject", f"{img.data.shape[0]}x{img.data.shape[1]} px x {n_az} pulses", t_bp, t_bp / t_fft,
                 f"{pix_pulses / t_bp / 1e6:.1f} M pixel-pulses/s", peak_bp / 2**20))
    lines = ["| stage | size | time (s) | time / one 2D FFT of raw | throughput | peak traced memory (MiB) |",
             "|---|---|---|---|---|---|"]
    lines += [f"| {a} | {b} | {c:.2f} | {d:.0f} | {e} | {f:.0f} |" for a, b, c, d, e, f in rows]
    lines.append(f"\nOne complex64 2D FFT of {n_az}x{n_rg}: {t_fft * 1e3:.1f} ms. "
                 f"Process peak RSS: {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MiB.")
    text = "\n".join(lines)
    print(text)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(text + "\n")


if __name__ == "__main__":
    main()
