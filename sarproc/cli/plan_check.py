"""How close a stage's --dry-run plan comes to what its run takes: one stage measured like /usr/bin/time.

:func:`run_stage` asks a ``sarproc`` stage for its plan (``--dry-run``: output size, peak memory, run
time), then runs it in a subprocess that reports its own peak RSS (VmHWM: interpreter and libraries
included, as the plan counts them), its wall and CPU time and its output size. :func:`within` is the
acceptance rule (every ratio plan / measured within 2x; time against the lower of wall and CPU time, since
load on a shared machine stretches the wall clock of a mostly single-threaded run). :func:`all_chains` and
:func:`chain`: the stages ``make plan-accuracy`` measures for every shipped config. Used by
scripts/plan_accuracy.py (``make plan-accuracy``, docs/plans.md) and tests/cli/test_plans.py.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

PLAN = re.compile(
    r"(\S+): plan: output ~([\d.]+ \w+), (?:working|peak) memory ~([\d.]+ \w+), "
    r"run time ~([\d.e+-]+ \w+)"
)
UNIT = {"B": 1, "kB": 1e3, "MB": 1e6, "GB": 1e9, "TB": 1e12, "s": 1, "min": 60, "h": 3600}


def value(text: str) -> float:
    number, unit = text.split()
    return float(number) * UNIT[unit]


# `python -m sarproc ARGS` that reports its peak RSS at exit: VmHWM of its own memory map. ru_maxrss
# from wait4 is no good here: with vfork it includes the RSS of the parent at the time of exec (a
# pytest process of 300 MB made a 117 MB quicklook read 296 MB).
PEAK_RSS = """
import atexit, sys

def report():
    with open("/proc/self/status") as fh:
        hwm = next(line.split()[1] for line in fh if line.startswith("VmHWM:"))
    print(f"plan_accuracy: VmHWM {hwm} kB", file=sys.stderr)

atexit.register(report)
sys.argv[0] = "sarproc"
from sarproc.cli.main import main
main()
"""


def _run(args: list, extra: tuple | list = (), cwd: Path | None = None) -> tuple[int, str, str]:
    """(exit status, stdout, stderr) of one sarproc subprocess."""
    proc = subprocess.run(
        [sys.executable, "-m", "sarproc", *map(str, args), *extra], check=False, capture_output=True, text=True, cwd=cwd
    )
    return proc.returncode, proc.stdout, proc.stderr


def run_stage(
    args: list,
    repeat: int = 1,
    accept: Callable[[dict], bool] | None = None,
    dry_run: Callable[[list, list], tuple[int, str, str]] | None = None,
    cwd: Path | None = None,
) -> dict[str, Any]:
    """The stage's --dry-run plan, then the real run, up to ``repeat`` times (stopping once ``accept(row)``):
    best wall and CPU time, highest peak RSS. The plan is asked for again before each run; when it
    changes (the first run filled numba's cache, so no compilation is planned any more), the runs
    before it no longer count. ``dry_run(args, extra)``: how the plan is asked for ((status, stdout,
    stderr); by default a subprocess). ``cwd``: where the subprocesses run (the tree whose sarproc they import
    first)."""
    if dry_run is None:

        def dry_run(a: list, e: list) -> tuple[int, str, str]:
            return _run(a, e, cwd)

    args = [*args, "--overwrite"]
    output = Path(args[args.index("-o") + 1])
    if output.exists():
        output.unlink()
    row = {"stage": args[0], "input": Path(args[1]).name, "output": output.name}
    extra = (
        []
        if args[0] in ("evaluate", "import-gotcha", "quicklook") or args[0].startswith(("export", "import"))
        else ["--no-progress"]
    )
    for i in range(repeat):
        existed = output.exists()
        code, stdout, stderr = dry_run(args, ["--dry-run"])
        if code != 0:
            row["refused"] = " ".join((stderr or stdout).split())[:200]
            return row
        m = PLAN.search(stdout)
        if m is None:
            raise RuntimeError(f"{args[0]} --dry-run printed no plan line: {stdout[-300:]!r}")
        plan = {"plan_out": value(m.group(2)), "plan_mem": value(m.group(3)), "plan_s": value(m.group(4))}
        if i == 0:
            row["dry_run_wrote"] = output.exists() and not existed
        if any(row.get(k) != v for k, v in plan.items()):
            row.update(plan)
            for k in ("wall", "cpu", "rss"):
                row.pop(k, None)
        t0 = time.perf_counter()
        proc = subprocess.Popen(
            [sys.executable, "-c", PEAK_RSS, *map(str, args), *extra],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
            cwd=cwd,
        )
        assert proc.stderr is not None  # stderr=PIPE
        err = proc.stderr.read()
        _, status, usage = os.wait4(proc.pid, 0)  # reaped here for its rusage (CPU time)
        wall = time.perf_counter() - t0
        proc.returncode = os.waitstatus_to_exitcode(status)
        proc.stderr.close()
        if proc.returncode != 0:
            row["refused"] = " ".join(err.split())[:200]
            return row
        hwm = re.search(r"plan_accuracy: VmHWM (\d+) kB", err)
        if hwm is None:
            raise RuntimeError(f"{args[0]}: the run did not report its peak RSS: {err[-300:]!r}")
        rss, cpu = float(hwm.group(1)) * 1024, usage.ru_utime + usage.ru_stime
        row["runs"] = i + 1
        row["wall"] = min(wall, row.get("wall", wall))
        row["cpu"] = min(cpu, row.get("cpu", cpu))
        row["rss"] = max(rss, row.get("rss", 0.0))
        row["out"] = float(output.stat().st_size)
        if accept is not None and accept(row):
            break
    return row


def within(row: dict[str, Any], factor: float = 2.0) -> bool:
    """Plan within ``factor`` of the measured peak RSS and time. The time measured is the best wall
    time, or the CPU time when lower (load on a shared machine stretches the wall clock of a
    single-threaded run, not its CPU time)."""
    if "rss" not in row:
        return False
    measured_s = min(row["wall"], row["cpu"])
    return (
        1 / factor <= row["plan_mem"] / row["rss"] <= factor
        and 1 / factor <= row["plan_s"] / measured_s
        and row["plan_s"] / row["wall"] <= factor
    )


# The focusing stages of a scene config, by the first word of its name (paper or family) ...
FOCUS = {
    "an2012": ("preprocess", "coarse-focus", "fine-focus"),
    "bp": ("backproject",),
    "demo": ("backproject",),
    "du2010": ("array3d",),
    "nie2016": ("pfa2",),
    "xu": ("reconstruct", "backproject"),
}
# ... or by its whole name where the first word names no processor
FOCUS_OF = {"evaluate_campaign": ("backproject",)}  # scripts/evaluate_campaign.py backprojects its scenes
# the chains of the tests' scale: every stage at least once, each config seconds to run
SMALL = ("demo", "an2012_exp1_small", "nie2016_sliding_small", "xu_small", "du2010_wide_swath")
# config variants (stage sections only), run on their base scene's raw product (Gotcha's: its pfa2 alone)
VARIANTS = {
    "an2012_exp1_linear": "an2012_exp1",
    "an2012_exp1_none": "an2012_exp1",
    "an2012_exp2_flow1": "an2012_exp2",
    "xu_conventional": "xu_scene",
    "pfa2_plain": "nie2016_small",  # make formats-readers, make residual-ghosts
    "gotcha_two_step": "gotcha",  # make reproduce-gotcha
}


def chain(name: str, out: Path, configs: Path, gotcha: Path) -> list[list]:
    """The stages of config ``name`` (a file ``configs/NAME.yaml``, or "gotcha": the files in ``gotcha``,
    or "formats": the SICD/CPHD round trip on the demo): argument lists, each with its -o output in ``out``.
    A variant (:data:`VARIANTS`) reads its base's raw product, so its base's chain must run first."""
    if name == "gotcha":
        cfg = configs / "gotcha.yaml"
        return [
            ["import-gotcha", gotcha, "-o", out / "gotcha_raw.h5"],
            ["pfa2", out / "gotcha_raw.h5", "--config", cfg, "-o", out / "gotcha_pfa.h5"],
            ["backproject", out / "gotcha_raw.h5", "--config", cfg, "-o", out / "gotcha_bp.h5"],
        ]
    if name == "formats":
        return [
            *chain("demo", out, configs, gotcha)[:2],
            ["export-sicd", out / "demo_backproject.h5", "-o", out / "demo.nitf"],
            ["export-cphd", out / "demo_raw.h5", "-o", out / "demo.cphd"],
            ["import-cphd", out / "demo.cphd", "-o", out / "demo_from_cphd.h5"],
        ]
    base = VARIANTS.get(name, name)
    cfg = configs / f"{name}.yaml"
    if base == "gotcha":  # real data: focused, no truth to evaluate against
        return [["pfa2", out / "gotcha_raw.h5", "--config", cfg, "-o", out / f"{name}_pfa.h5"]]
    stages = FOCUS_OF.get(base) or FOCUS[base.split("_")[0]]
    steps = [] if name in VARIANTS else [["simulate", configs / f"{base}.yaml", "-o", out / f"{base}_raw.h5"]]
    source = out / f"{base}_raw.h5"
    for stage in stages:
        target = out / f"{name}_{stage}.h5"
        steps.append([stage, source, "--config", cfg, "-o", target])
        source = target
    steps.append(["evaluate", source, "--config", cfg, "-o", out / f"{name}_report.json"])
    steps.append(["quicklook", source, "-o", out / f"{name}_quicklook.png"])
    return steps


def all_chains(configs: Path) -> list[str]:
    """Every shipped config of ``configs`` (``*_expect`` files excluded) as a chain name, each variant right
    after its base, then "gotcha" (the Gotcha files; configs/gotcha.yaml) with its variants, and "formats"."""
    names = [p.stem for p in sorted(configs.glob("*.yaml")) if not p.stem.endswith("_expect")]
    bases = [n for n in names if n not in VARIANTS and n != "gotcha"] + ["gotcha"]
    order: list[str] = []
    for base in bases:
        order += [base, *(n for n in names if VARIANTS.get(n) == base)]
    return order + ["formats"]
