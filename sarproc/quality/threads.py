"""evaluate's independent pieces of work on threads, their results taken in the serial loop's order (issue 20 item 5).

A piece (one target's peak, support or cuts; one group's fit where it reads no other group's model) reads shared
inputs that no piece writes and returns what it found; the caller takes the results in the order the serial loop
made them and applies them there, so whatever it accumulates is accumulated in the same order, and the report is
the serial one bit for bit (tests/quality/test_evaluate_threads.py). What overlaps: numpy's loops, pocketfft and
the compiled kernels (built releasing the GIL, :mod:`sarproc.product.aot`); the pieces' small-array Python runs
one thread at a time. BLAS stays at one thread (:mod:`sarproc.quality.blas`, set by the calling thread).
"""

from __future__ import annotations

import collections
import os
import threading
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from typing import TYPE_CHECKING, TypeVar

if TYPE_CHECKING:
    from concurrent.futures import Executor, Future

T = TypeVar("T")
R = TypeVar("R")

_WORKERS: ContextVar[int | None] = ContextVar("sarproc_evaluate_workers", default=None)
_PREFIX = "sarproc-evaluate"


@contextmanager
def workers(n: int | None) -> Iterator[None]:
    """Within: evaluate's pieces on ``n`` threads (1: in the calling thread, the serial loop; None: every core)."""
    token = _WORKERS.set(n)
    try:
        yield
    finally:
        _WORKERS.reset(token)


def worker_count() -> int:
    """The threads :func:`ordered_map` uses here: the :func:`workers` asked for, else ``os.cpu_count()``; 1 inside
    one of its threads (no pool in a pool)."""
    if threading.current_thread().name.startswith(_PREFIX):  # a piece's own pieces: in its thread
        return 1
    n = _WORKERS.get()
    return max(1, n if n is not None else os.cpu_count() or 1)


def ordered_map(func: Callable[[T], R], items: Iterable[T], serial: bool = False) -> Iterator[R]:
    """``map(func, items)`` with the calls on :func:`worker_count` threads, at most twice that many in flight, the
    results yielded in the items' order (an exception where the serial loop would meet it first). ``serial``
    (e.g. ``EvaluateParams.exact``, whose numerics switch is process-wide): the plain map."""
    items = list(items)
    n = 1 if serial else min(worker_count(), len(items))
    if n <= 1:
        yield from map(func, items)
        return
    from concurrent.futures import ThreadPoolExecutor  # only where a pool runs: evaluate's start stays as it was

    with ThreadPoolExecutor(max_workers=n, thread_name_prefix=_PREFIX) as pool:
        pending: collections.deque[Future[R]] = collections.deque()
        rest = iter(items)
        for item in rest:
            pending.append(pool.submit(func, item))
            if len(pending) >= 2 * n:
                break
        try:
            while pending:
                result = pending.popleft().result()
                for item in rest:
                    pending.append(pool.submit(func, item))
                    break
                yield result
        finally:
            for future in pending:
                future.cancel()


@contextmanager
def pool(serial: bool = False) -> Iterator[Executor | None]:
    """Within: a pool of :func:`worker_count` - 1 threads (the calling thread works too) for pieces asked for ahead
    of the serial loop that reads them, or None where that is one thread (or ``serial``); its pieces not started
    are cancelled at the end."""
    n = 1 if serial else worker_count()
    if n <= 1:
        yield None
        return
    from concurrent.futures import ThreadPoolExecutor

    executor = ThreadPoolExecutor(max_workers=n - 1, thread_name_prefix=_PREFIX)
    try:
        yield executor
    finally:
        executor.shutdown(wait=True, cancel_futures=True)
