"""An image larger than --max-memory, through `sarproc backproject` locally and on a local Dask cluster.

Runs the CLI only: simulate a scene, backproject it onto an N x N grid (complex64: 8 N^2 bytes) with
--max-memory below that, once in this process and once with --scheduler local; reports each process's
wall time and peak resident memory (the Dask workers' from the command's -v line) and checks that the
two images are identical, reading them a block of rows at a time. Writes a markdown table.

    python scripts/tiled_backproject.py --scene configs/demo.yaml --pixels 8192 --max-memory 384M
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import yaml

from sarproc.cli.plan_check import PEAK_RSS


def run(args: list[str]) -> tuple[float, int, str]:
    """Run ``python -m sarproc ARGS``; (wall seconds, its peak RSS in bytes, stderr). The peak is the command's
    own VmHWM (sarproc.cli.plan_check.PEAK_RSS), not wait4's, which can carry this process's RSS."""
    start = time.perf_counter()
    proc = subprocess.run([sys.executable, "-c", PEAK_RSS, *args], capture_output=True, text=True, check=False)
    wall = time.perf_counter() - start
    if proc.returncode:
        sys.exit(f"sarproc {' '.join(args)} failed ({proc.returncode}):\n{proc.stderr}")
    hwm = re.search(r"plan_accuracy: VmHWM (\d+) kB", proc.stderr)
    if hwm is None:
        sys.exit(f"sarproc {' '.join(args)} did not report its peak RSS:\n{proc.stderr[-300:]}")
    return wall, int(hwm.group(1)) * 1024, proc.stderr


def max_difference(a: Path, b: Path, rows: int = 256) -> tuple[tuple[int, ...], float, float]:
    with h5py.File(a, "r") as fa, h5py.File(b, "r") as fb:
        da, db = fa["image"], fb["image"]
        assert da.shape == db.shape, (da.shape, db.shape)
        diff = peak = 0.0
        for s in range(0, da.shape[0], rows):
            x, y = da[s : s + rows], db[s : s + rows]
            diff, peak = max(diff, float(np.abs(x - y).max())), max(peak, float(np.abs(x).max()))
        return da.shape, diff, peak


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default="configs/demo.yaml")
    ap.add_argument("--pixels", type=int, default=8192, help="image side N (N x N pixels)")
    ap.add_argument("--spacing", type=float, default=0.35, help="pixel spacing, m")
    ap.add_argument("--max-memory", default="384M")
    ap.add_argument("--out", type=Path, default=Path("results/tiled"))
    a = ap.parse_args()
    a.out.mkdir(parents=True, exist_ok=True)
    raw = a.out / "raw.h5"
    if not raw.exists():
        run(["simulate", a.scene, "-o", str(raw)])
    frame = (yaml.safe_load(Path(a.scene).read_text()).get("backproject") or {}).get("frame", "product")
    extent = f"{(a.pixels - 0.5) * a.spacing} m"
    config = a.out / "backproject.yaml"
    config.write_text(
        yaml.safe_dump(
            {
                "backproject": {
                    "frame": frame,
                    "azimuth_spacing": f"{a.spacing} m",
                    "range_spacing": f"{a.spacing} m",
                    "azimuth_extent": extent,
                    "range_extent": extent,
                    "max_pixels": a.pixels**2,
                }
            }
        )
    )
    rows = []
    for name, extra in (("local", []), ("dask", ["--scheduler", "local"])):
        image = a.out / f"image_{name}.h5"
        cmd = ["-v", "backproject", str(raw), "-o", str(image), "--config", str(config)]
        wall, rss, err = run([*cmd, "--max-memory", a.max_memory, "--overwrite", *extra])
        blocks = re.search(r"in (\d+) blocks", err)
        workers = re.search(r"peak memory per worker (.*)", err)
        rows.append((name, wall, rss, blocks.group(1) if blocks else "1", workers.group(1) if workers else "-"))
    shape, diff, peak = max_difference(a.out / "image_local.h5", a.out / "image_dask.h5")
    image_bytes = 8 * shape[0] * shape[1]
    lines = [
        f"`sarproc backproject` of {a.scene} onto {shape[0]} x {shape[1]} pixels "
        f"({image_bytes / 2**20:.0f} MiB complex64) with --max-memory {a.max_memory}, {os.cpu_count()} cores",
        "",
        "| run | wall (s) | peak RSS of the command | blocks | peak RSS per Dask worker |",
        "|---|---|---|---|---|",
    ]
    lines += [f"| {n} | {w:.1f} | {r / 2**20:.0f} MiB | {b} | {wk} |" for n, w, r, b, wk in rows]
    verdict = "identical" if diff == 0 else f"max |difference| {diff / peak:.2e} of the peak"
    lines += ["", f"local against Dask image: {verdict}"]
    (a.out / "table.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
