"""sarproc compare BASE NEW: the products of NEW against those of BASE, as Markdown tables."""

from __future__ import annotations

from pathlib import Path

import click


@click.command()
@click.argument("base", type=click.Path(exists=True, path_type=Path))
@click.argument("new", type=click.Path(exists=True, path_type=Path))
def compare(base: Path, new: Path) -> None:
    """Compare NEW with BASE: two product files, or two folders whose files are paired by path.

    Reads only. HDF5 products: the signal's difference power over its power (dB; "identical" when
    equal) and largest difference, read in blocks; every other dataset and attribute compared exactly.
    evaluate reports (JSON): how many numbers moved and the largest move per metric (irw, pslr_db,
    position, ...). Markdown (reproduction summaries): tables paired by header, rows by first cell,
    the cells that moved. Other files: their bytes. Figures, logs and YAML are skipped. Prints one
    Markdown table per kind of file.
    """
    from sarproc.cli.markdown import markdown_table
    from sarproc.product.errors import InputError
    from sarproc.quality import compare as cmp

    if base.is_dir() != new.is_dir():
        raise InputError(f"compare: {base} and {new} must be two files or two folders")
    pairs = [(base / n, new / n, n) for n in cmp.paired_names(base)] if base.is_dir() else [(base, new, new.name)]
    tables = []
    for kind, (columns, row) in cmp.TABLES.items():
        rows = [row(b, a, name) for b, a, name in pairs if cmp.table_of(name) == kind]
        if rows:
            tables.append(markdown_table(columns, rows))
    click.echo(f"Products of `{new}` against `{base}` (sarproc compare).\n")
    click.echo("\n\n".join(tables) if tables else "No files to compare.")
