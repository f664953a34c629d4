#!/usr/bin/env python3
"""The compiled backprojection's cost per pixel-pulse and per tile-pulse (backproject's time model, issue 23).

    python scripts/tile_cost.py [--rounds 3]

One synthetic 560k-pixel flat grid (2000 x 280 at 0.3 m) read from 512 random X-band pulses at ~600 km, on one
numba thread, with tiles of 32 to 1024 pixels (``tile_points``); the best CPU time of each is fitted as
a + b x tile-pulses, a / pixel-pulses being the per-pixel-pulse cost and b the per-tile-pulse cost. Then the
same pixel count at 1.4 x 2.2 m (tiles capped at ~40 pixels, run in blocks on these linear reads): what its CPU
time leaves over a per pixel-pulse and b per block-pulse, per pulse of each further tile in a block.
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import numpy as np

from sarproc.focus import (
    backprojection as bp,
    backprojection_kernel as bk,
)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3)
    args = ap.parse_args()
    rng = np.random.default_rng(0)
    n_az, n_rg, fc, fs = 512, 600, 9.6e9, 36e6
    x, y = np.meshgrid(np.arange(2000) * 0.3, np.arange(280) * 0.3, indexing="ij")
    pts = np.stack([x.ravel(), y.ravel(), np.zeros(x.size)], 1)
    t = np.linspace(-0.3, 0.3, n_az)
    pos = np.stack([300 + 7500 * t, -560e3 + 0 * t, 200e3 + 0 * t], 1)
    r0 = np.linalg.norm(pos[n_az // 2] - pts[len(pts) // 2])
    rc = (rng.standard_normal((n_az, n_rg)) + 1j * rng.standard_normal((n_az, n_rg))).astype(np.complex64)
    rt = 2 * (r0 - 300) / bp.C + np.arange(n_rg) / fs
    sizes = (32, 128, 1024)
    best = dict.fromkeys(sizes, np.inf)
    tiles = {}
    for _ in range(args.rounds):
        for size in sizes:
            edge = bp._tile_size(pts, size, bp.MAX_TILE_RADIUS_CYCLES * bp.C / fc)
            tiles[size] = len(bk.make_tiles(pts, edge, max_tile=4 * size)[1]) - 1
            c = time.process_time()
            bp.backproject_points(rc, rt, pos, pos, pts, fc, engine="compiled", workers=1, tile_points=size)
            best[size] = min(best[size], time.process_time() - c)
    tp = np.array([tiles[s] * n_az for s in sizes], float)
    cpu = np.array([best[s] for s in sizes])
    b, a = np.polyfit(tp, cpu, 1)
    print("| tile_points | tiles | CPU s (best) |\n|---:|---:|---:|")
    for s in sizes:
        print(f"| {s} | {tiles[s]} | {best[s]:.3f} |")
    print(f"\nper pixel-pulse {a / (len(pts) * n_az) * 1e9:.2f} ns, per tile-pulse {b * 1e6:.3f} us (one core)")
    xc, yc = np.meshgrid(np.arange(2000) * 1.4, np.arange(280) * 2.2, indexing="ij")
    coarse = np.stack([xc.ravel(), yc.ravel(), np.zeros(xc.size)], 1)
    tiles_c = bp._tiles(coarse, bp.DEFAULT_TILE_POINTS, fc, None, blocks=True)
    n_tiles, n_blocks = len(tiles_c.start) - 1, len(tiles_c.blocks) - 1
    cpu_c = np.inf
    for _ in range(args.rounds):
        c = time.process_time()
        bp.backproject_points(rc, rt, pos, pos, coarse, fc, engine="compiled", workers=1)
        cpu_c = min(cpu_c, time.process_time() - c)
    rest = (cpu_c - a * len(coarse) / len(pts) - b * n_blocks * n_az) / ((n_tiles - n_blocks) * n_az)
    print(
        f"1.4 x 2.2 m: {n_tiles} tiles in {n_blocks} blocks, CPU {cpu_c:.3f} s (best), "
        f"per further tile-pulse in a block {rest * 1e6:.3f} us (one core)"
    )


if __name__ == "__main__":
    main()
