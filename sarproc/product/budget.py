"""Up-front resource plans: what a stage will write, hold in memory and take, checked before work.

A stage estimates its :class:`Plan` from the input's metadata (shapes, parameters) before it
reads the data. :func:`check_plan` refuses (InputError, exit 2) a plan that cannot fit: an
output larger than the free space of its directory or the process's file-size limit, or working
memory above ``--max-memory`` or the memory available now. Estimates are deliberately simple
(array sizes times the copies a stage holds), so they are upper bounds within a small factor.

Each stage's estimate lives beside its family (``sarproc.focus.budget``, ``sarproc.quality.budget``,
``sarproc.simulation.budget``, ``sarproc.formats.budget``); the command line only calls them. A plan is for
the whole process, as ``/usr/bin/time`` would measure it: peak RSS and wall time. Each stage's estimate
models its own arrays (sizes times the copies it holds at its peak) and its work (FFT and kernel rates);
:func:`whole_process` adds what every run costs besides, measured on the reference machine (2-core
x86-64, 2026-12; ``scripts/plan_accuracy.py``): the interpreter with numpy, scipy, h5py, numba and the
stage's modules, and, while the compiled kernels are not yet in numba's cache, their compilation.
``make plan-accuracy`` sets every plan against the measured run (docs/plans.md); the aim is within 2x of
both.
"""

from __future__ import annotations

import dataclasses
import math
import os
import re
from pathlib import Path
from typing import TYPE_CHECKING

from sarproc.product.errors import InputError

if TYPE_CHECKING:
    from collections.abc import Iterable, Sequence
    from typing import Any

    from sarproc.product.model import Product

_SIZE = re.compile(r"^\s*(\d+(?:\.\d*)?|\.\d+)\s*([kKMGT]?)(i?)(B?)\s*$")
_FACTOR = {"": 1, "k": 1e3, "K": 1e3, "M": 1e6, "G": 1e9, "T": 1e12}


def parse_size(text: str, where: str = "--max-memory") -> int:
    """Bytes of ``'4G'``, ``'500 MB'``, ``'2GiB'`` or a plain byte count."""
    m = _SIZE.match(str(text))
    if not m:
        raise InputError(f"{where}: cannot read {text!r} as a size; write e.g. '8G', '500 MB' or '2 GiB'")
    number, prefix, binary = float(m.group(1)), m.group(2), m.group(3)
    power = {"": 0, "k": 1, "K": 1, "M": 2, "G": 3, "T": 4}[prefix]
    factor = 1024**power if binary else _FACTOR[prefix]
    out = int(number * factor)
    if out <= 0:
        raise InputError(f"{where}: {text!r} must be positive")
    return out


def human(n: float) -> str:
    """Bytes as a short decimal string ('1.2 GB')."""
    for unit in ("B", "kB", "MB", "GB", "TB"):
        if abs(n) < 1000 or unit == "TB":
            return f"{n:.3g} {unit}" if unit != "B" else f"{int(n)} B"
        n /= 1000
    return f"{n:.3g} TB"


def human_time(s: float) -> str:
    if s < 60:
        return f"{s:.2g} s"
    if s < 3600:
        return f"{s / 60:.2g} min"
    return f"{s / 3600:.2g} h"


@dataclasses.dataclass
class Plan:
    """A stage's estimate: output bytes (per output file), the process's peak memory (RSS) and run time."""

    stage: str
    output_bytes: float
    memory_bytes: float
    seconds: float
    detail: str = ""
    # the numba modules the run will load (None: the stage's in KERNELS); () where it runs none
    kernel_modules: tuple[str, ...] | None = None

    def describe(self) -> str:
        return (
            f"{self.stage}: plan: output ~{human(self.output_bytes)}, peak memory ~{human(self.memory_bytes)}, "
            f"run time ~{human_time(self.seconds)}" + (f" ({self.detail})" if self.detail else "")
        )


def available_memory() -> int | None:
    """Bytes of memory available to new allocations now (MemAvailable, bounded by a cgroup limit)."""
    avail = None
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    avail = int(line.split()[1]) * 1024
                    break
    except OSError:
        pass
    for path in ("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"):
        try:
            text = Path(path).read_text().strip()
        except OSError:
            continue
        if text.isdigit() and int(text) < 1 << 60:
            used = 0
            for cur in ("/sys/fs/cgroup/memory.current", "/sys/fs/cgroup/memory/memory.usage_in_bytes"):
                try:
                    used = int(Path(cur).read_text().strip())
                    break
                except (OSError, ValueError):
                    continue
            room = int(text) - used
            avail = room if avail is None else min(avail, room)
            break
    return avail


def file_size_limit() -> int | None:
    """The process's RLIMIT_FSIZE soft limit in bytes, or None when unlimited."""
    try:
        import resource
    except ImportError:  # pragma: no cover - not on POSIX
        return None
    soft, _ = resource.getrlimit(resource.RLIMIT_FSIZE)
    return None if soft == resource.RLIM_INFINITY else int(soft)


def _why(plan: Plan) -> str:
    return f" ({plan.detail})" if plan.detail else ""


def check_plan(plan: Plan, outputs: Sequence[str | os.PathLike] = (), max_memory: int | None = None) -> None:
    """Refuse (InputError) a plan whose output or memory cannot fit; a message says the fix."""
    import tempfile

    from sarproc.product.io import output_stream

    for out in outputs:
        out = Path(out)
        # a stream output (-, a device, a FIFO) is finished in the temporary directory first
        folder = Path(tempfile.gettempdir()) if output_stream(out) is not None else out.parent
        try:
            st = os.statvfs(folder if str(folder) else ".")
            free = st.f_bavail * st.f_frsize
        except OSError:
            free = None
        for room, where, fix in (
            (free, f"{folder} has only {{}} free", "free space, write elsewhere"),
            (file_size_limit(), "this process may write files of at most {} (ulimit -f)", "raise the limit"),
        ):
            if room is not None and plan.output_bytes > room:
                raise InputError(
                    f"{out}: the output needs ~{human(plan.output_bytes)}{_why(plan)} but "
                    f"{where.format(human(room))}; {fix} or shrink the scene"
                )
    for room, where, fix in (
        (max_memory, "above --max-memory {}", "raise --max-memory"),
        (available_memory(), "but only {} is available", "run on a larger machine"),
    ):
        if room is not None and plan.memory_bytes > room:
            raise InputError(
                f"{plan.stage}: needs ~{human(plan.memory_bytes)} of working memory{_why(plan)}, "
                f"{where.format(human(room))}; {fix} or shrink the scene or its blocks"
            )


def complex_bytes(*shape: float, itemsize: int = 8) -> float:
    """Bytes of a complex array of ``shape`` (complex64 by default)."""
    return float(math.prod(float(s) for s in shape)) * itemsize


def stored_bytes(*shape: int, itemsize: int = 8) -> float:
    """Bytes an HDF5 product's data set of ``shape`` takes on disk: whole chunks (see io._chunks)."""
    from sarproc.product.io import _chunks

    shape = tuple(max(1, int(n)) for n in shape)
    chunk = _chunks(shape)
    n_chunks = math.prod(math.ceil(n / c) for n, c in zip(shape, chunk))
    return float(n_chunks * math.prod(chunk) * itemsize)


def fft_seconds(shape: tuple[int, ...], repeats: int = 2) -> float:
    """Best wall time (s) of one complex64 2-D FFT (scipy.fft.fft2 over the last two axes, all cores) of an
    array of ``shape``, after a warm-up on its first rows: the time unit benchmarks and reproductions quote
    stage times in ("FFT units"), so that they compare across machines."""
    import time

    import numpy as np
    import scipy.fft as sfft

    if repeats < 1:
        raise ValueError(f"fft_seconds: repeats must be >= 1, got {repeats}")
    x = np.ones(shape, np.complex64)
    sfft.fft2(x[:64], workers=-1)  # plans and thread pool
    best = math.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        sfft.fft2(x, workers=-1)
        best = min(best, time.perf_counter() - t0)
    return best


# stage: (peak RSS bytes, seconds) of a run on a tiny scene: imports (numpy, scipy, h5py ~55 MB), reading and
# writing the products, the kernels loaded. Fitted (session 17) to each stage's best of three runs on the
# reference machine, idle (scripts/plan_accuracy.py --small --repeat 3, both SARPROC_AOT=1 and 0), so that
# a plan is ~1x a quiet run: the 2x band then holds for a machine up to ~2x slower (a loaded CI runner,
# measured ~1.1-1.3x) or faster. The earlier fit, to ~0.75x the CPU time of loaded runs, left the numba
# runs at 0.5-0.55x on an idle machine and CI failed below 0.5 (backproject 0.48, coarse-focus 0.42).
# For the stages of NUMBA_STAGES the figures are a run without numba (its kernels compiled ahead of time, or
# none to run); NUMBA_PROCESS is added where the run starts numba.
PROCESS = {
    "simulate": (55e6, 0.47),  # AOT: nie2016_sliding_small 0.48 s, 61 MB; xu_small 0.46 s, 72 MB
    "preprocess": (55e6, 0.42),  # AOT: an2012_exp1_small 0.41 s, 56 MB
    # an2012_exp1_small 0.48 s, 58 MB (plan was 0.25 s); idle in session 24 0.23-0.24 s (CPU 0.33-0.35 s), where
    # 0.47 s planned it at 2.01-2.11x and failed CI: the plan now ~1.5x that run; session 39's idle CI run on this
    # machine 0.153 s wall and CPU, planned at 0.31 s (2.03x, failed): 0.26 s plans it at ~1.8x and the loaded
    # 0.48 s at ~0.56x
    "coarse-focus": (55e6, 0.26),
    "fine-focus": (72e6, 0.48),  # AOT: an2012_exp1_small 0.49 s, 75 MB
    # AOT: demo 0.98 s, 94 MB (0.40 s of kernel planned); xu_small 0.67 s, 95 MB; less the targets' theory, which
    # focus.budget.THEORY_SECONDS_PER_TARGET now plans (0.3 s of the demo's run)
    "backproject": (50e6, 0.45),
    # pfa2 runs its kernels ahead-of-time compiled and serial while that beats numba's start (issue 23):
    # nie2016_sliding_small 1.44 s, 142 MB (AOT) and 2.31 s, 253 MB (numba), against 1.7 s and 300 MB planned;
    # since its de-aliasing imports no scipy (session 25), idle: 0.54-0.57 s, 99 MB (AOT) and 0.80 s, 252 MB
    # (numba, as the tests run it), where (240 MB, 1.35 s) planned them at 2.5x / 2.1x: between the two now
    "pfa2": (150e6, 0.55),
    "reconstruct": (170e6, 0.55),  # its model (0.55 us a sample) counts 0.52 s on xu_small, whose run takes 1.1 s
    "array3d": (215e6, 0.45),
    "evaluate": (85e6, 0.3),  # idle: the demo's process 0.40-0.44 s, 74 MB peak RSS (plan was 1.7-1.8x both)
    "export-sicd": (85e6, 0.55),
    "export-cphd": (125e6, 1.25),
    "import-cphd": (120e6, 0.4),
    "import-gotcha": (88e6, 0.6),
    # builtin renderer (matplotlib's import: sarproc.quality.budget.MATPLOTLIB_IMPORT): demo 0.45 s, 59 MB and
    # du2010 cube 0.50 s, 82 MB on a loaded machine; the demo 0.22 s wall on an idle CI run, where 0.42 s planned
    # it at 2.1x (session 23): the plan now sits between the two; session 37's faster machine (AVX-512) ran the
    # demo's in 0.14 s idle, planned at 0.31 s (2.2x, CI failed): 0.22 s plans it at ~1.8x there, ~1.1x on the
    # idle CI run above and ~0.55x on the loaded 0.45 s
    "quicklook": (60e6, 0.22),
}

# What starting numba adds to a run of NUMBA_STAGES: its import and runtime and its cached kernels loaded
# (measured as the same run with SARPROC_AOT=0 against 1: simulate +0.67-0.74 s and +98 MB, preprocess
# +0.61 s, backproject +0.49-0.51 s and +103 MB; on the idle machine of session 24, best of 3: simulate
# +0.28 s, preprocess +0.26 s, +97 MB, where 0.6 s planned preprocess at 2.0-2.1x its run and failed CI; on
# session 37's faster machine (AVX-512, the AOT runs 0.27 s for 0.47 here), simulate +0.17 s idle, where 0.4 s
# planned simulate and preprocess at 2.1-2.2x their runs (0.39, 0.37 s): 0.2 s holds both machines in 2x)
NUMBA_PROCESS = (100e6, 0.2)
NUMBA_STAGES = ("simulate", "preprocess", "fine-focus", "backproject")

# stage: (the numba modules it runs, seconds and bytes to compile them when numba's cache lacks them)
KERNELS = {
    "simulate": (("sarproc.simulation.echo_kernel",), 12.0, 60e6),
    "preprocess": (("sarproc.dsp.phasor_kernels",), 0.5, 10e6),
    "fine-focus": (
        (
            "sarproc.focus.squint_deramp.stolt_kernels",
            "sarproc.focus.squint_deramp.block_copies",
            "sarproc.dsp.interp_kernels",
            "sarproc.dsp.phasor_kernels",
        ),
        10.0,
        70e6,
    ),
    "backproject": (("sarproc.focus.backprojection_kernel", "sarproc.dsp.phasor_kernels"), 14.0, 105e6),
    # the residual's kernels (evaluate_estimate names them only where the residual runs); measured on the
    # demo from a fresh clone: 3.9 s and 234 MB compiling, 1.1 s and 185 MB cached
    "evaluate": (("sarproc.quality.residual_kernels", "sarproc.quality.kernels"), 2.8, 50e6),
}


# stage: the kernels compiled ahead of time (sarproc.product.aot, ``module:attribute`` of their Kernels) that
# run all of its numba work on a small product
AOT_KERNELS = {
    "preprocess": ("sarproc.dsp.phasor:AOT",),
    "simulate": ("sarproc.simulation.echo_aot:ECHO", "sarproc.simulation.echo_aot:IMPULSES"),
    "fine-focus": (
        "sarproc.focus.squint_deramp.compiled:BLOCKS",
        "sarproc.focus.squint_deramp.compiled:STOLT",
        "sarproc.dsp.interp:AOT",
        "sarproc.dsp.phasor:AOT",
    ),
}


def aot_covers(plan: Plan) -> bool:
    """Whether the stage's kernels run compiled ahead of time (no numba, nothing to compile): its work is small
    enough for the serial kernels (the plan's seconds on every CPU) and their modules are built."""
    owners = AOT_KERNELS.get(plan.stage)
    if not owners:
        return False
    from sarproc.product import aot

    if not aot.serial_pays(plan.seconds * aot.available_threads()):
        return False
    return all(aot.owner_kernels(owner).load() is not None for owner in owners)


def kernels_cached(modules: Iterable[str]) -> bool:
    """Whether numba's cache holds the kernels of ``modules``: each module with cached kernels has
    the index file of at least one (a kernel a stage never calls, e.g. cubic interpolation's table
    in a linear run, is never compiled, so not every index exists after a run)."""
    import importlib
    import os

    from numba.core.registry import CPUDispatcher

    for name in modules:
        indexes = [
            obj._cache._cache_file._index_path
            for obj in vars(importlib.import_module(name)).values()
            if isinstance(obj, CPUDispatcher) and hasattr(obj._cache, "_cache_file")
        ]
        if indexes and not any(os.path.exists(p) for p in indexes):
            return False
    return True


def whole_process(plan: Plan) -> Plan:
    """``plan`` (the stage's own arrays and work) plus the process around it (see the module doc)."""
    memory, seconds = PROCESS.get(plan.stage, (200e6, 1.0))
    detail = plan.detail
    modules, compile_s, compile_bytes = KERNELS.get(plan.stage, ((), 0.0, 0.0))
    if plan.kernel_modules is not None:
        modules = plan.kernel_modules
    elif modules and aot_covers(plan):
        modules = ()
    if modules and plan.stage in NUMBA_STAGES:  # through numba: a large scene, modules not built, SARPROC_AOT=0
        memory += NUMBA_PROCESS[0]
        seconds += NUMBA_PROCESS[1]
    if modules and not kernels_cached(modules):
        seconds += compile_s
        memory += compile_bytes
        detail = (detail + "; " if detail else "") + f"compiling its kernels first (~{compile_s:.0f} s, then cached)"
    return dataclasses.replace(
        plan, memory_bytes=plan.memory_bytes + memory, seconds=plan.seconds + seconds, detail=detail
    )


def header_shape(header: Product) -> tuple[int, ...]:
    """The data's shape, from a header read with load=False or from a loaded product."""
    return tuple(int(n) for n in header.attrs.get("shape", header.data.shape))


def generic_estimate(stage: str, header: Product, params: Any) -> Plan:
    """Output as large as the input, four input-sized arrays in memory, FFT-like cost."""
    n = math.prod(header_shape(header))
    b = complex_bytes(n)
    return Plan(stage, b, 4 * b, n * 60e-9 * max(1.0, math.log2(max(n, 2)) / 10))
