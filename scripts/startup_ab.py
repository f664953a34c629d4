"""Interleaved A/B of small `sarproc` processes from several checkouts: wall and CPU seconds, best of N.

    python scripts/startup_ab.py --rounds 12 --dry-run OLD_TREE NEW_TREE

Each stage of the per-process rows that reads the demo products (backproject, evaluate, quicklook, export-sicd,
export-cphd, import-cphd) runs as one process from each tree in turn, round after round. With ``--dry-run``
the process stops after its plan: the interpreter, the imports, the configuration and the input's header, the
part of a stage's overhead that its imports decide, free of the work's noise (docs/performance.md, eighth
round). The demo products are made first by the first tree (in --data, kept); kernels compiled ahead of
time go to --data/aot. Run it under the shared heavy.lock.
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

CASES: dict[str, tuple[str, ...]] = {
    "backproject": ("backproject", "{d}/demo_raw.h5", "--config", "configs/demo.yaml", "-o", "{d}/o_bp.h5"),
    "evaluate": ("evaluate", "{d}/demo_img.h5", "-o", "{d}/o.json"),
    "quicklook": ("quicklook", "{d}/demo_img.h5", "-o", "{d}/o.png"),
    "export-sicd": ("export-sicd", "{d}/demo_img.h5", "-o", "{d}/o.nitf"),
    "export-cphd": ("export-cphd", "{d}/demo_raw.h5", "-o", "{d}/o.cphd"),
    "import-cphd": ("import-cphd", "{d}/demo.cphd", "-o", "{d}/o_cphd.h5"),
}
SETUP: tuple[tuple[str, ...], ...] = (
    ("simulate", "configs/demo.yaml", "-o", "{d}/demo_raw.h5"),
    ("backproject", "{d}/demo_raw.h5", "--config", "configs/demo.yaml", "-o", "{d}/demo_img.h5"),
    ("export-cphd", "{d}/demo_raw.h5", "-o", "{d}/demo.cphd"),
)


def _run(tree: Path, argv: list[str], data: Path) -> tuple[float, float]:
    """(wall s, CPU s of user and system) of one ``sarproc`` process run from ``tree``."""
    env = {**os.environ, "PYTHONPATH": str(tree), "SARPROC_AOT_DIR": str(data / "aot")}
    env.pop("PYTHONDONTWRITEBYTECODE", None)  # bytecode cached as in an install
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "sarproc", *argv], cwd=tree, env=env, check=True, capture_output=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("trees", nargs="+", type=Path)
    ap.add_argument("--rounds", type=int, default=10)
    ap.add_argument("--dry-run", action="store_true", help="stop each process after its plan")
    ap.add_argument("--data", type=Path, default=Path("/tmp/sarproc-startup-ab"))
    args = ap.parse_args()
    d = args.data
    d.mkdir(parents=True, exist_ok=True)
    trees = [t.resolve() for t in args.trees]
    for argv in SETUP:
        out = Path(argv[argv.index("-o") + 1].format(d=d))
        if not out.exists():
            _run(trees[0], [a.format(d=d) for a in argv] + ["-q"], d)
    extra = ["--overwrite", "-q"] + (["--dry-run"] if args.dry_run else [])
    for tree in trees:  # once untimed and in full: bytecode written, every compiled module built
        for argv in CASES.values():
            _run(tree, [a.format(d=d) for a in argv] + ["--overwrite", "-q"], d)
    t0 = time.perf_counter()  # until the compiled modules those runs started building (in the background) are built
    while any((d / "aot").glob("*.lock")) and time.perf_counter() - t0 < 300:
        time.sleep(0.5)
    best: dict[tuple[str, Path], list[float]] = {}
    for r in range(args.rounds):
        for stage, argv in CASES.items():
            for tree in trees:
                wall, cpu = _run(tree, [a.format(d=d) for a in argv] + extra, d)
                b = best.setdefault((stage, tree), [float("inf"), float("inf")])
                b[0], b[1] = min(b[0], wall), min(b[1], cpu)
        print(f"round {r + 1}/{args.rounds} done", file=sys.stderr, flush=True)
    print("| stage | " + " | ".join(f"{t.name}: wall (s) | {t.name}: CPU (s)" for t in trees) + " |")
    print("|---|" + "---:|---:|" * len(trees))
    for stage in CASES:
        cells = " | ".join(f"{best[(stage, t)][0]:.3f} | {best[(stage, t)][1]:.3f}" for t in trees)
        print(f"| {stage} | {cells} |")


if __name__ == "__main__":
    main()
