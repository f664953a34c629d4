"""Markdown tables, the one layout every table the command line prints or writes uses."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from pathlib import Path


def markdown_table(columns: Sequence[str], rows: Iterable[Sequence[str]], align: str = "") -> str:
    """A Markdown table: header ``columns``, then one line per row of already formatted cells.

    ``align``: one letter per column, ``r`` right-aligned (numbers), anything else left; default all left.
    """
    sep = "|" + "|".join("---:" if a == "r" else "---" for a in align.ljust(len(columns), "l")) + "|"
    return "\n".join(["| " + " | ".join(columns) + " |", sep] + ["| " + " | ".join(row) + " |" for row in rows])


def publish(text: str, out: Path | None) -> None:
    """Print a report and, when ``out`` is given, write it there too (its folder made as needed)."""
    if out is not None:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(text)
    print(text)
