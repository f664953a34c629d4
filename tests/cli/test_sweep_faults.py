"""sarproc sweep --scheduler local survives a worker killed mid-run: its tasks rerun on the others.

The kill is deterministic: a Dask worker preload (set through the DASK_DISTRIBUTED__WORKER__PRELOAD
environment variable, so the real CLI runs unchanged) wraps the sweep's step runner so that the
first evaluate step of the whole run, on whichever worker it lands, SIGKILLs its own worker process
after the task's backproject step has been written and recorded. Exactly one worker dies (a marker
file is created with O_EXCL); the task it held, and any raw product it held in memory, must be
recomputed elsewhere, and the table must equal the serial run's.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest
import yaml
from conftest import BASE_SCENE, merge

from sarproc.cli.sweep_tasks import TIMING_KEYS, plan_sweep, run_serial

pytest.importorskip("dask.distributed", reason="sweeps on Dask need sarproc[distributed]")

KILLER = """
import os, signal
import sarproc.cli.sweep_tasks as sweep_tasks

MARKER = {marker!r}


def invoke(command, args, _invoke=sweep_tasks.invoke):
    if command == "evaluate":
        try:
            fd = os.open(MARKER, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
        except FileExistsError:
            pass                                  # one kill per run: the restarted worker runs on
        else:
            os.write(fd, f"{{os.getpid()}} {{args[0]}}".encode())
            os.close(fd)
            os.kill(os.getpid(), signal.SIGKILL)
    return _invoke(command, args)


if not hasattr(sweep_tasks, "killer_installed"):   # Dask may load a preload more than once per process
    sweep_tasks.invoke, sweep_tasks.killer_installed = invoke, True


def dask_setup(worker):
    pass
"""


def quality(rows):
    return [{k: v for k, v in r.items() if k not in TIMING_KEYS} for r in rows]


def test_a_killed_worker_s_tasks_rerun_on_the_others(tmp_path):
    mapping = merge(
        BASE_SCENE, {"targets": {"frame": "squint", "points": [{"name": "A"}]}, "backproject": {"margin_cells": 8}}
    )
    (tmp_path / "one.yaml").write_text(yaml.safe_dump(mapping))
    sweep = tmp_path / "sweep.yaml"
    sweep.write_text(
        yaml.safe_dump(
            {"scenes": {"one": "one.yaml"}, "focus": "backproject", "grid": {"backproject.upsample": [1, 4]}}
        )
    )
    marker = tmp_path / "killed"
    preload = tmp_path / "kill_first_evaluate.py"
    preload.write_text(KILLER.format(marker=str(marker)))
    env = {**os.environ, "DASK_DISTRIBUTED__WORKER__PRELOAD": json.dumps([str(preload)])}
    out = tmp_path / "dask"
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "sarproc",
            "sweep",
            str(sweep),
            "-o",
            str(out),
            "--scheduler",
            "local",
            "--workers",
            "2",
        ],
        env=env,
        capture_output=True,
        text=True,
        timeout=240,
    )
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert marker.exists(), "no worker was killed: the preload did not run"
    pid, killed_input = marker.read_text().split(" ", 1)
    doc = json.loads((out / "table.json").read_text())
    assert doc["failures"] == [] and len(doc["rows"]) == 2
    # the killed task was rerun elsewhere: its report exists, and its backproject step (recorded
    # before the kill) was not recomputed (one record, written once)
    killed_task = os.path.basename(os.path.dirname(killed_input))
    assert (out / "tasks" / killed_task / "report.json").exists()
    record = out / "tasks" / killed_task / "backproject.h5.done.json"
    assert record.stat().st_mtime_ns <= marker.stat().st_mtime_ns, "the recorded backproject step was redone"
    serial = run_serial(plan_sweep(sweep, tmp_path / "serial"))
    assert not serial.failures
    # equal to the serial table up to rounding: Dask's worker processes run BLAS/FFT single-threaded,
    # which changes the last bit of a sum (islr_db differed by 1e-15 relative); not a missing or stale row
    expected = quality([{k: v for k, v in r.items() if k != "skipped"} for r in serial.rows])
    assert quality(doc["rows"]) == [
        {k: pytest.approx(v, rel=1e-12) if isinstance(v, float) else v for k, v in row.items()} for row in expected
    ]
