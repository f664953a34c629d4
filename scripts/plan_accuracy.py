"""How close each stage's up-front plan (sarproc -v) comes to what the run then takes.

Runs three chains in subprocesses (demo.yaml: simulate, backproject, evaluate; an2012_exp2_small:
simulate, preprocess, coarse-focus, fine-focus; du2010: simulate, array3d) and prints, per stage,
the planned and measured output size, peak memory (the process's max RSS, which includes about
100 MB of interpreter and libraries) and run time.

    .venv/bin/python scripts/plan_accuracy.py [OUT_DIR]
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PLAN = re.compile(r"plan: output ~([\d.]+ \w+), working memory ~([\d.]+ \w+), run time ~([\d.e+-]+ \w+)")
UNIT = {"B": 1, "kB": 1e3, "MB": 1e6, "GB": 1e9, "TB": 1e12, "s": 1, "min": 60, "h": 3600}


def value(text: str) -> float:
    number, unit = text.split()
    return float(number) * UNIT[unit]


def run(args, out: Path):
    t0 = time.perf_counter()
    extra = [] if args[0] == "evaluate" else ["--no-progress"]
    proc = subprocess.Popen([sys.executable, "-m", "sarproc", "-v", *map(str, args), *extra],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT)
    _, status, usage = os.wait4(proc.pid, 0)
    stdout, stderr = proc.stdout.read(), proc.stderr.read()
    proc.stdout.close()
    proc.stderr.close()
    wall = time.perf_counter() - t0
    if os.waitstatus_to_exitcode(status) != 0:
        raise SystemExit(f"sarproc {' '.join(map(str, args))} failed:\n{stdout}{stderr}")
    m = PLAN.search(stderr)
    work = re.search(r"\(([\d.]+) s\)\s*$", stdout)   # the stage's own timing in its summary line
    return {"stage": args[0], "plan_out": value(m.group(1)), "plan_mem": value(m.group(2)),
            "plan_s": value(m.group(3)), "out": out.stat().st_size, "rss": usage.ru_maxrss * 1024, "wall": wall,
            "work": float(work.group(1)) if work else float("nan")}


def main() -> None:
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(tempfile.mkdtemp(prefix="plan_accuracy_"))
    out.mkdir(parents=True, exist_ok=True)
    c = ROOT / "configs"
    steps = [
        ("simulate", c / "demo.yaml", "-o", out / "demo_raw.h5"),
        ("backproject", out / "demo_raw.h5", "--config", c / "demo.yaml", "-o", out / "demo_img.h5"),
        ("evaluate", out / "demo_img.h5", "-o", out / "demo.json"),
        ("simulate", c / "an2012_exp2_small.yaml", "-o", out / "exp2_raw.h5"),
        ("preprocess", out / "exp2_raw.h5", "--config", c / "an2012_exp2_small.yaml", "-o", out / "exp2_pre.h5"),
        ("coarse-focus", out / "exp2_pre.h5", "--config", c / "an2012_exp2_small.yaml", "-o", out / "exp2_coarse.h5"),
        ("fine-focus", out / "exp2_coarse.h5", "--config", c / "an2012_exp2_small.yaml", "-o", out / "exp2_img.h5"),
        ("simulate", c / "du2010.yaml", "-o", out / "du_raw.h5"),
        ("array3d", out / "du_raw.h5", "--config", c / "du2010.yaml", "-o", out / "du_cube.h5"),
    ]
    base = subprocess.Popen([sys.executable, "-c", "import sarproc.cli.main, scipy.fft, h5py, numba"])
    _, _, usage = os.wait4(base.pid, 0)
    print(f"baseline RSS of the interpreter with numpy/scipy/h5py/numba imported: {usage.ru_maxrss * 1024 / 1e6:.0f} MB")
    print("| stage | input | output planned / actual | memory planned / peak RSS | time planned / work (wall) |")
    print("|---|---|---|---|---|")
    for args in steps:
        args = list(args) + ["--overwrite"]
        r = run(args, Path(args[args.index("-o") + 1]))
        print(f"| {r['stage']} | {Path(args[1]).name} | {r['plan_out'] / 1e6:.3g} / {r['out'] / 1e6:.3g} MB | "
              f"{r['plan_mem'] / 1e6:.3g} / {r['rss'] / 1e6:.3g} MB | {r['plan_s']:.3g} / {r['work']:.3g} "
              f"({r['wall']:.3g}) s |")


if __name__ == "__main__":
    main()
