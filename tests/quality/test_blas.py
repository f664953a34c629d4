"""One BLAS thread while any thread is inside one_blas_thread, whatever order the threads leave in."""

from __future__ import annotations

import threading

import numpy as np  # loads numpy's BLAS
import pytest
from threadpoolctl import threadpool_info

from sarproc.quality.blas import one_blas_thread


def blas_threads() -> set[int]:
    return {lib["num_threads"] for lib in threadpool_info() if lib["user_api"] == "blas"}


def test_the_first_thread_out_does_not_restore_threaded_blas_under_another():
    before = blas_threads()
    assert np.ones(2) @ np.ones(2) == 2.0 and before
    if before == {1}:
        pytest.skip("BLAS runs on one thread here anyway")
    a_in, b_in, a_out, b_checked = (threading.Event() for _ in range(4))
    seen: dict[str, set[int]] = {}

    def a() -> None:
        with one_blas_thread():
            a_in.set()
            b_in.wait(5)
        a_out.set()

    def b() -> None:
        a_in.wait(5)
        with one_blas_thread():
            b_in.set()
            a_out.wait(5)  # a has left: b must still run on one thread
            seen["b after a left"] = blas_threads()
            b_checked.set()

    threads = [threading.Thread(target=a), threading.Thread(target=b)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(10)
    assert b_checked.is_set()
    assert seen["b after a left"] == {1}
    assert blas_threads() == before  # the last one out restored what was there
