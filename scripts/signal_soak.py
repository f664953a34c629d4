"""Signal soak (issue 18): SIGTERM, SIGINT and SIGHUP sent to real `sarproc simulate` processes at random
moments of a ~100 MB product's run (start-up, compute, HDF5 writes, publishing, after it).

Each delivery must end 128 + N with no output and nothing left behind, or 0 with the complete output.
One that lands while Python itself starts (before sarproc's first line runs) kills the process with the
signal's default action: no output, and a shell reports 128 + N too; counted in its own column.
Prints a Markdown table (per signal: deliveries, stopped, completed, wrong) and writes the per-run
records as JSON.

    python scripts/signal_soak.py --runs 90 --out results/soak      (make signal-soak)
"""

from __future__ import annotations

import argparse
import json
import random
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import h5py
import yaml

SCENE = {
    "radar": {
        "carrier_frequency": "10 GHz",
        "bandwidth": "100 MHz",
        "pulse_duration": "1 us",
        "range_sampling_rate": "120 MHz",
        "prf": "1000 Hz",
    },
    "platform": {"velocity": "100 m/s", "altitude": "0 m"},
    "geometry": {"reference_range": "2 km", "squint": "0 deg"},
    "acquisition": {"mode": "spotlight", "aperture_time": "12 s", "range_window": {"start": "1.6 km", "end": "2.6 km"}},
    "targets": {"frame": "squint", "points": [{"name": "A"}, {"name": "B", "range": "30 m", "azimuth": "10 m"}]},
    "simulation": {"block_pulses": 256},
    "backproject": {},  # declares a chain that unfolds the spectrum (no folding warning)
}


def run_once(scene: Path, out: Path, sig: signal.Signals | None = None, delay: float = 0.0) -> dict:
    proc = subprocess.Popen(
        [sys.executable, "-m", "sarproc", "simulate", str(scene), "-o", str(out), "--overwrite", "--no-progress", "-q"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    start = time.monotonic()
    tmp_mb = None
    if sig is not None:
        time.sleep(delay)
        tmps = list(out.parent.glob(f".{out.name}.*.sarproc-tmp"))
        tmp_mb = max((t.stat().st_size for t in tmps if t.exists()), default=0) / 1e6 if tmps else 0.0
        proc.send_signal(sig)
    _, err = proc.communicate(timeout=600)
    return {"code": proc.returncode, "seconds": time.monotonic() - start, "stderr": err[-400:], "tmp_mb": tmp_mb}


def complete(out: Path, shape: tuple[int, ...]) -> bool:
    try:
        with h5py.File(out) as f:
            return f["signal"].shape == shape and f["targets"].shape[0] == 2
    except OSError:
        return False


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=90)
    ap.add_argument("--seed", type=int, default=18)
    ap.add_argument("--out", type=Path, default=Path("results/soak"))
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    rng = random.Random(args.seed)
    with tempfile.TemporaryDirectory(dir=args.out) as work:
        work = Path(work)
        scene = work / "scene.yaml"
        scene.write_text(yaml.safe_dump(SCENE))
        run_once(scene, work / "ref.h5")  # the first run is cold (kernels loaded, files cached): timed again
        ref = run_once(scene, work / "ref.h5")
        assert ref["code"] == 0, ref
        with h5py.File(work / "ref.h5") as f:
            shape = f["signal"].shape
        size_mb = (work / "ref.h5").stat().st_size / 1e6
        sigs = [signal.SIGTERM, signal.SIGINT, signal.SIGHUP]
        records = []
        for i in range(args.runs):
            sig = sigs[i % 3]
            out = work / f"out_{i}.h5"
            delay = rng.uniform(0.0, 1.1 * ref["seconds"])
            r = run_once(scene, out, sig, delay)
            leftovers = sorted(p.name for p in work.iterdir() if p.name.endswith((".sarproc-tmp", ".sarproc-lock")))
            if r["code"] == 0:
                verdict = "completed" if complete(out, shape) else "wrong"
            elif r["code"] == 128 + sig:
                verdict = "stopped" if not out.exists() else "wrong"
            elif r["code"] == -sig:  # the signal's own action, before Python ran sarproc's first line
                verdict = "killed at start-up" if not out.exists() else "wrong"
            else:
                verdict = "wrong"
            if leftovers or "Traceback" in r["stderr"]:
                verdict = "wrong"
            records.append(
                {
                    "run": i,
                    "signal": sig.name,
                    "delay_s": delay,
                    "tmp_mb_at_signal": r["tmp_mb"],
                    "code": r["code"],
                    "output": out.exists(),
                    "leftovers": leftovers,
                    "verdict": verdict,
                    "stderr": r["stderr"],
                }
            )
            if out.exists():
                out.unlink()
    (args.out / "signal_soak.json").write_text(
        json.dumps({"product_mb": size_mb, "reference_s": ref["seconds"], "records": records}, indent=1)
    )
    print(f"Product {size_mb:.0f} MB, unsignalled run {ref['seconds']:.2f} s; delays uniform in [0, 1.1 x that].\n")
    print(
        "| signal | deliveries | stopped (128+N, no output) | killed at interpreter start-up (shell: 128+N, "
        "no output) | completed (0, full output) | wrong | temp file at delivery (MB) |"
    )
    print("|---|---:|---:|---:|---:|---:|---|")
    for name in ("SIGTERM", "SIGINT", "SIGHUP"):
        rs = [r for r in records if r["signal"] == name]
        mbs = [r["tmp_mb_at_signal"] for r in rs if r["tmp_mb_at_signal"]]
        span = f"0 - {max(mbs):.0f}" if mbs else "0"
        print(
            f"| {name} | {len(rs)} | {sum(r['verdict'] == 'stopped' for r in rs)} | "
            f"{sum(r['verdict'] == 'killed at start-up' for r in rs)} | "
            f"{sum(r['verdict'] == 'completed' for r in rs)} | {sum(r['verdict'] == 'wrong' for r in rs)} | {span} |"
        )
    wrong = [r for r in records if r["verdict"] == "wrong"]
    for r in wrong:
        print(f"\nwrong: {r}")
    sys.exit(1 if wrong else 0)


if __name__ == "__main__":
    main()
