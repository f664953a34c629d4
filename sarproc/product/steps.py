"""Advance a caller's progress bar unit by unit, for stages whose work is not one loop.

Stages accept ``progress``: a callable wrapping an iterable (and optionally ``total=``), such as
the CLI's tqdm factory. A stage made of several steps (whole-array transforms, then block loops)
knows its total work up front; :func:`steps` turns ``progress`` into a function called once per
finished unit, so one bar covers the whole stage with its total.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator
from typing import Any, TypeVar

T = TypeVar("T")

# what stages accept as ``progress``: wraps an iterable (``total=`` optional), e.g. the CLI's tqdm factory
ProgressFactory = Callable[..., Iterable[Any]]


def steps(progress: ProgressFactory | None, total: int) -> Callable[..., None]:
    """A function ``done(n=1)`` advancing ``progress`` over ``total`` units; a no-op when ``progress`` is None.

    The bar opens at once (0 of ``total``) and closes when the ``total``-th unit is done.
    """
    if progress is None or total <= 0:
        return lambda n=1: None
    it = iter(progress(range(total), total=total))
    next(it, None)  # open the bar; each further next() marks one unit done

    def done(n: int = 1) -> None:
        for _ in range(n):
            next(it, None)

    return done


def wrapped(done: Callable[[], object], iterable: Iterable[T]) -> Iterator[T]:
    """Yield from ``iterable``, calling ``done()`` after each item's work (the consumer's loop body)."""
    for item in iterable:
        yield item
        done()
