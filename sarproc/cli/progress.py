"""The one place that owns progress bars (tqdm), for block drivers in the core."""

from __future__ import annotations


def progress_factory(enabled: bool, desc: str):
    """A callable wrapping an iterable in a tqdm bar, or None when bars are off."""
    if not enabled:
        return None
    from tqdm import tqdm

    return lambda it: tqdm(it, desc=desc, unit="block", leave=False)
