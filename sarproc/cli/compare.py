"""sarproc compare BASE NEW: the products of NEW against those of BASE, as Markdown tables."""

from __future__ import annotations

import json
from pathlib import Path

import click


@click.command()
@click.argument("base", type=click.Path(exists=True, path_type=Path))
@click.argument("new", type=click.Path(exists=True, path_type=Path))
@click.option(
    "-o",
    "--output",
    type=click.Path(dir_okay=False, path_type=Path),
    default=None,
    help="Also write the tables as JSON: per file its table and cells, and for products the signal figures as "
    "numbers (signal_db: -Infinity when identical; max_rel; peak_db: NEW's peak over BASE's).",
)
@click.option("--overwrite", is_flag=True, help="Replace an existing -o file.")
def compare(base: Path, new: Path, output: Path | None, overwrite: bool) -> None:
    """Compare NEW with BASE: two product files, or two folders whose files are paired by path.

    Reads only. HDF5 products: the signal's difference power over its power (dB; "identical" when
    equal) and largest difference, read in blocks; every other dataset and attribute compared exactly.
    evaluate reports (JSON): how many numbers moved and the largest move per metric (irw, pslr_db,
    position, ...). Markdown (reproduction summaries): tables paired by header, rows by first cell,
    the cells that moved. Other files: their bytes. Figures, logs and YAML are skipped. Prints one
    Markdown table per kind of file; -o writes them as JSON too, the products' signal figures as numbers.
    """
    from sarproc.cli.markdown import markdown_table
    from sarproc.product.errors import InputError
    from sarproc.quality import compare as cmp

    if base.is_dir() != new.is_dir():
        raise InputError(f"compare: {base} and {new} must be two files or two folders")
    pairs = [(base / n, new / n, n) for n in cmp.paired_names(base)] if base.is_dir() else [(base, new, new.name)]
    if output is not None:
        from sarproc.product.io import atomic_path, check_output_path

        check_output_path(output, [base, new], overwrite=overwrite)
    tables, files = [], []
    for kind, (columns, row) in cmp.TABLES.items():
        rows = []
        for b, a, name in pairs:
            if cmp.table_of(name) != kind:
                continue
            numbers = cmp.product_record(b, a, name) if kind == "h5" else {"row": row(b, a, name)}
            rows.append(numbers.pop("row"))
            files.append({"name": name, "table": kind, "cells": dict(zip(columns, rows[-1])), **numbers})
        if rows:
            tables.append(markdown_table(columns, rows))
    if output is not None:
        doc = {"base": str(base), "new": str(new), "files": files}
        with atomic_path(output, overwrite=overwrite) as tmp:
            tmp.write_text(json.dumps(doc, indent=2) + "\n", encoding="utf-8")
    click.echo(f"Products of `{new}` against `{base}` (sarproc compare).\n")
    click.echo("\n\n".join(tables) if tables else "No files to compare.")
