"""Markdown tables, the one layout every table the command line prints or writes uses."""

from __future__ import annotations

from collections.abc import Iterable, Sequence


def markdown_table(columns: Sequence[str], rows: Iterable[Sequence[str]], align: str = "") -> str:
    """A Markdown table: header ``columns``, then one line per row of already formatted cells.

    ``align``: one letter per column, ``r`` right-aligned (numbers), anything else left; default all left.
    """
    sep = "|" + "|".join("---:" if a == "r" else "---" for a in align.ljust(len(columns), "l")) + "|"
    return "\n".join(["| " + " | ".join(columns) + " |", sep] + ["| " + " | ".join(row) + " |" for row in rows])
