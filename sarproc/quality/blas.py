"""One BLAS thread while evaluate's small matrices are worked on, also when several threads evaluate at once.

threadpoolctl's limits are process-wide, and with this OpenBLAS (0.3.31, scipy-openblas) a limit asked for
from a worker thread did not take effect once the main thread had set one (measured: the worker read 2
threads inside its own one-thread limit). A Dask sweep on local threads therefore ran evaluate's fits on
threaded BLAS, while the serial run used one thread, and the residual false-target levels differed in the
ninth digit. So the sweep runners hold the limit in the calling thread for the whole run, and here the
first caller in sets it and the last one out restores it (no thread restores threaded BLAS under
another); a BLAS loaded inside (scipy's own, by a lazy ``import scipy.linalg``) is limited too, by
:func:`limit_loaded`.
"""

from __future__ import annotations

import functools
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING, Any, TypeVar

if TYPE_CHECKING:
    from threadpoolctl import threadpool_limits

F = TypeVar("F", bound=Callable[..., Any])

_lock = threading.Lock()
_inside = 0
_limiters: list[threadpool_limits] = []


def _one_thread_limit() -> threadpool_limits:
    """A one-thread BLAS limit, threadpoolctl imported here: importing it sets KMP_DUPLICATE_LIB_OK in the
    process's environment, which importing sarproc must not do (issue 21)."""
    from threadpoolctl import threadpool_limits

    return threadpool_limits(limits=1, user_api="blas")


@contextmanager
def one_blas_thread() -> Iterator[None]:
    """BLAS limited to one thread from the first caller's entry to the last caller's exit."""
    global _inside
    with _lock:
        if _inside == 0:
            _limiters.append(_one_thread_limit())
        _inside += 1
    try:
        yield
    finally:
        with _lock:
            _inside -= 1
            if _inside == 0:
                while _limiters:
                    _limiters.pop().restore_original_limits()


def limit_loaded() -> None:
    """Inside :func:`one_blas_thread`, limit the BLAS libraries loaded since it began (threadpoolctl limits
    only those loaded when asked); restored with the others at the last exit. Once per entry: a scan of the
    loaded libraries costs milliseconds, and a caller may ask on every fit."""
    with _lock:
        if _inside > 0 and len(_limiters) == 1:
            _limiters.append(_one_thread_limit())


def single_blas(func: F) -> F:
    """``func`` run inside :func:`one_blas_thread`."""

    @functools.wraps(func)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        with one_blas_thread():
            return func(*args, **kwargs)

    return wrapper  # type: ignore[return-value]
