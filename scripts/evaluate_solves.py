#!/usr/bin/env python3
"""How many Gauss-Newton solves one ``sarproc evaluate`` makes (issue 20 item 5): the command run in this process,
the residual's group fits counted.

    PYTHONPATH=TREE python scripts/evaluate_solves.py [--set NAME=VALUE ...] evaluate IMAGE.h5 -o report.json [...]

Prints one line: the group fits (``residual._fit_group`` calls) and their CPU seconds, the Gauss-Newton solves
(``residual._gauss_newton_step`` calls, the re-solves with parameters held at a bound included), the rows they
solved (samples summed over the solves), and the command's CPU seconds. ``--set`` replaces a constant of
:mod:`sarproc.quality.residual` for this run (a number: e.g. ``--set FIT_TOLERANCE=1e-10``), to see how far the
report moves with where the fits stop. Computes nothing itself: it only counts the command's own calls.
"""

from __future__ import annotations

import resource
import sys
from typing import Any


def cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def main() -> None:
    import sarproc.cli.evaluate  # noqa: F401 (the command's modules, as the command line loads them)
    import sarproc.quality.residual as residual
    from sarproc.cli.main import run_cli, set_thread_defaults

    args = sys.argv[1:]
    while args and args[0] == "--set":
        name, value = args[1].split("=", 1)
        old = getattr(residual, name)  # only a constant the module has
        setattr(residual, name, type(old)(float(value)))
        args = args[2:]
    count = {"fits": 0, "fit_cpu": 0.0, "solves": 0, "rows": 0}
    step, fit = residual._gauss_newton_step, residual._fit_group

    def counted_step(normal: Any, r: Any, J: Any, free: Any) -> Any:
        count["solves"] += 1
        count["rows"] += int(r.shape[0])
        return step(normal, r, J, free)

    def counted_fit(*a: Any, **k: Any) -> Any:
        count["fits"] += 1
        begin = cpu()
        try:
            return fit(*a, **k)
        finally:
            count["fit_cpu"] += cpu() - begin

    residual._gauss_newton_step = counted_step
    residual._fit_group = counted_fit
    set_thread_defaults()
    begin = cpu()
    code = run_cli(args)
    print(
        f"group fits {count['fits']} ({count['fit_cpu']:.3f} s CPU) | Gauss-Newton solves {count['solves']} | "
        f"rows solved {count['rows']} | command {cpu() - begin:.3f} s CPU",
        file=sys.stderr,
    )
    sys.exit(code)


if __name__ == "__main__":
    main()
