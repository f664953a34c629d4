"""The one place that owns progress bars (tqdm), for block drivers in the core."""

from __future__ import annotations

from collections.abc import Sized
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from collections.abc import Iterable

    from sarproc.product.steps import ProgressFactory


def progress_factory(enabled: bool, desc: str) -> ProgressFactory | None:
    """A callable wrapping an iterable in a tqdm bar (total from ``len`` or ``total=``), or None when off."""
    if not enabled:
        return None
    from tqdm import tqdm

    def bar(it: Iterable, total: int | None = None) -> Iterable:
        if total is None and isinstance(it, Sized):
            total = len(it)
        return tqdm(it, desc=desc, unit="block", total=total, leave=False)

    return bar
