"""Run sarproc commands in this one process, each stopped by a signal at a given moment (issue 18).

A timer thread sends the signal to this process, as a batch scheduler would, ``fraction`` times
the command's own run time after it starts (the shortest whole run of the same ``key`` before it; the first
are unsignalled, and also compile and load every kernel: an interrupted first numba call leaves numba
half-initialised in the process, which a real run never outlives). The moments fall in argument
parsing, the compute, inside h5py's writes, in publishing and after it. Paying Python's start-up
once makes many deliveries cheap. Prints one JSON line per run: exit status, signal, delay, wall time.

    python signal_driver.py RUNS.json   # [{"key": "sim", "args": [...]}, {"key": "sim", "args": [...],
                                        #   "signal": 15, "fraction": 0.4}, ...]
"""

from __future__ import annotations

import json
import os
import sys
import threading
import time

from sarproc.cli.main import run_cli


def main(path: str) -> None:
    with open(path) as fh:
        runs = json.load(fh)
    durations: dict[str, float] = {}
    for r in runs:
        delay = r.get("fraction", 0.0) * durations.get(r["key"], 0.0)
        timer = threading.Timer(delay, os.kill, (os.getpid(), r["signal"])) if r.get("signal") else None
        start = time.perf_counter()
        if timer:
            timer.start()
        code = run_cli(r["args"])
        seconds = time.perf_counter() - start
        if code == 0:  # a whole run (unsignalled, or the signal came after it): the shortest sets the delays,
            # so that warm-up runs stretched by load do not push the later signals past the end of the run
            durations[r["key"]] = min(seconds, durations.get(r["key"], seconds))
        if timer:
            timer.join()  # a signal sent after the run ended must change nothing
            time.sleep(0.005)  # let it be delivered (ignored) before the next run installs its handlers
        print(json.dumps({"code": code, "signal": r.get("signal"), "delay": delay, "seconds": seconds}), flush=True)


if __name__ == "__main__":
    main(sys.argv[1])
