#!/usr/bin/env python3
"""Where one ``sarproc evaluate`` process's CPU goes (issue 20 item 5): the command run in this process, with a
CPU timer around its phases (each phase's own time, nested phases subtracted).

    PYTHONPATH=TREE python scripts/evaluate_split.py evaluate IMAGE.h5 -o report.json [evaluate's options]

Prints one line: imports (the command line's and evaluate's modules, numpy and h5py among them), reading the
image, loading the compiled kernels, the residual's fits (``fit_response_models``), the residual floor and false
target (``residual_false_target``), the rest of ``evaluate_image`` (peaks, supports, cuts), writing, plots, and
what is left; with the total of the process after the interpreter's start (``python -c pass``: ~0.02 s). Computes
nothing itself: it only times the command's own calls.
"""

from __future__ import annotations

import resource
import sys
from collections.abc import Callable
from typing import Any


def cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


START = cpu()
own: dict[str, float] = {}
stack: list[float] = []


def timed(module: Any, name: str, label: str) -> None:
    """Replace ``module.name`` by the same call that adds its own CPU time to ``own[label]``."""
    func: Callable[..., Any] = getattr(module, name)

    def wrapper(*args: Any, **kwargs: Any) -> Any:
        begin = cpu()
        stack.append(0.0)
        try:
            return func(*args, **kwargs)
        finally:
            spent, inner = cpu() - begin, stack.pop()
            own[label] = own.get(label, 0.0) + spent - inner
            if stack:
                stack[-1] += spent

    setattr(module, name, wrapper)


def main() -> None:
    import sarproc.cli.evaluate as cli_evaluate
    import sarproc.product.aot as aot
    import sarproc.product.io as io
    import sarproc.quality.metrics as metrics
    from sarproc.cli.main import run_cli, set_thread_defaults

    imports = cpu() - START
    timed(io, "read_product", "reading")
    timed(aot, "load", "compiled kernels' load")
    timed(metrics, "evaluate_image", "peaks, supports, cuts")
    timed(metrics, "fit_response_models", "fits")
    timed(metrics, "residual_false_target", "residual floor / false target")
    timed(cli_evaluate, "_write_text_atomic", "writing")
    timed(cli_evaluate, "_plots", "plots")
    set_thread_defaults()
    begin = cpu()
    code = run_cli(sys.argv[1:])
    run = cpu() - begin
    parts = [f"imports {imports:.3f}"] + [f"{k} {v:.3f}" for k, v in own.items()]
    parts += [f"rest {run - sum(own.values()):.3f}", f"total {cpu() - START:.3f} s CPU"]
    print(" | ".join(parts), file=sys.stderr)
    sys.exit(code)


if __name__ == "__main__":
    main()
