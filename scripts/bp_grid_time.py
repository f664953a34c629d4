#!/usr/bin/env python3
"""CPU and wall time of one compiled backprojection call on a synthetic X-band grid (docs/performance.md,
"Coarse pixels in blocks"); saves the image for a comparison between trees.

    python scripts/bp_grid_time.py {coarse,fine512,fine2048} OUT.npy [--upsample 8]

coarse: xu_small-like, 2143 x 273 pixels at 1.4 x 2.2 m, 1800 pulses; fine512: 512^2 at 0.3 m, 600 pulses;
fine2048: 2048^2 at 0.15 m, 300 pulses. Random pulses from ~600 km, linear reads (x8 unless told: older trees'
default), numba's threads (run with SARPROC_AOT=0 so both trees load the same kernels), the kernels loaded by a
small call first.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from sarproc.focus import backprojection as bp

GRIDS = {  # (nx, ny, sx, sy, pulses)
    "coarse": (2143, 273, 1.4, 2.2, 1800),
    "fine512": (512, 512, 0.3, 0.3, 600),
    "fine2048": (2048, 2048, 0.15, 0.15, 300),
}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("grid", choices=sorted(GRIDS))
    ap.add_argument("out")
    ap.add_argument("--upsample", type=int, default=8)
    args = ap.parse_args()
    nx, ny, sx, sy, n_az = GRIDS[args.grid]
    rng = np.random.default_rng(0)
    fc, fs, n_rg = 9.6e9, 36e6, 1200
    x, y = np.meshgrid(np.arange(nx) * sx - nx * sx / 2, np.arange(ny) * sy - ny * sy / 2, indexing="ij")
    pts = np.stack([x.ravel(), y.ravel(), np.zeros(x.size)], 1)
    t = np.linspace(-0.5, 0.5, n_az)
    pos = np.stack([3000 * t, -560e3 + 0 * t, 200e3 + 0 * t], 1)
    r0 = np.linalg.norm(pos[n_az // 2])
    rc = (rng.standard_normal((n_az, n_rg)) + 1j * rng.standard_normal((n_az, n_rg))).astype(np.complex64)
    rt = 2 * (r0 - 700) / bp.C + np.arange(n_rg) / fs
    bp.backproject_points(rc[:64], rt, pos[:64], pos[:64], pts[:5000], fc, engine="compiled")  # load the kernels
    c, w = time.process_time(), time.perf_counter()
    img = bp.backproject_points(rc, rt, pos, pos, pts, fc, engine="compiled", upsample=args.upsample)
    print(f"{args.grid} cpu {time.process_time() - c:.3f} wall {time.perf_counter() - w:.3f}")
    np.save(args.out, img)


if __name__ == "__main__":
    main()
