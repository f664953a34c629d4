"""Up-front resource plans: what a stage will write, hold in memory and take, checked before work.

A stage estimates its :class:`Plan` from the input's metadata (shapes, parameters) before it
reads the data. :func:`check_plan` refuses (InputError, exit 2) a plan that cannot fit: an
output larger than the free space of its directory or the process's file-size limit, or working
memory above ``--max-memory`` or the memory available now. Estimates are deliberately simple
(array sizes times the copies a stage holds), so they are upper bounds within a small factor.
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
    from collections.abc import Sequence

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
