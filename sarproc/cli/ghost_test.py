"""sarproc ghost-test CLEAN.h5 GHOSTED.h5 [--levels DB,...] [-o report.json] [--config FILE.yaml]"""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING

import click

from sarproc.cli.markdown import markdown_table
from sarproc.cli.options import (
    SectionCommand,
    config_option,
    load_config,
    progress_option,
    stdout_taken,
    verbosity,
    want_progress,
)

if TYPE_CHECKING:
    from sarproc.quality.ghost_test import GhostTest


def ghost_table(test: GhostTest) -> str:
    """The ghost test as Markdown: the clean image's figures, then one row per injected level."""
    head = (
        f"Ghost G at {test.ghost_position} (strongest pixel of its response); clean image: residual floor "
        f"{test.floor_db:.2f} dB, residual false target {test.false_target_db:.2f} dB, guard-window figure "
        f"{test.guard_db:.2f} dB."
    )
    columns = (
        ["injected (dB)", "found (dB)", "error (dB)"]
        + [f"{d} error (cells)" for d in test.dims]
        + ["guard-window figure (dB)", "residual floor (dB)"]
    )
    rows = [
        [f"{r.injected_db:.1f}", f"{r.found_db:.2f}", f"{r.error_db:+.2f}"]
        + [f"{r.error_cells[d]:+.2f}" for d in test.dims]
        + [f"{r.guard_db:.2f}", f"{r.floor_db:.2f}"]
        for r in test.rows
    ]
    return head + "\n\n" + markdown_table(columns, rows, "r" * len(columns))


def _levels(text: str) -> list[float]:
    from sarproc.product.errors import InputError

    try:
        levels = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise InputError(f"--levels: expected comma-separated dB values, got {text!r}") from None
    if not levels or any(not v < 0 for v in levels):
        raise InputError(f"--levels: expected negative dB values (below the strongest target), got {text!r}")
    return levels


@click.command(cls=SectionCommand, section=("evaluate",))
@click.argument("clean_path", type=click.Path(path_type=Path))
@click.argument("ghosted_path", type=click.Path(path_type=Path))
@click.option(
    "--levels",
    default="-40,-45,-50",
    show_default=True,
    help="Levels of the injected ghost: its strongest pixel against the strongest truth target's peak, dB.",
)
@click.option(
    "-o",
    "--output",
    type=click.Path(dir_okay=False, allow_dash=True, path_type=Path),
    default=None,
    help="Write the figures as JSON (an existing file needs --overwrite; '-': standard output).",
)
@click.option("--overwrite", is_flag=True, help="Replace an existing -o report.")
@config_option
@progress_option
def ghost_test(
    clean_path: Path,
    ghosted_path: Path,
    levels: str,
    output: Path | None,
    overwrite: bool,
    config_path: Path | None,
    progress: bool | None,
) -> None:
    """Injected-ghost test of evaluate's residual false-target search on two images of one scene.

    CLEAN and GHOSTED are the same scene made the same way (simulate + a focusing stage, one grid), GHOSTED
    with one more target G that CLEAN's targets table does not hold. G's response (GHOSTED - CLEAN) is added
    to CLEAN at each --levels value and the sum evaluated with CLEAN's targets table and the residual search
    on: the table gives the false target found (pixel level, error against the injected level, offset from
    G's strongest pixel in resolution cells), the guard-window figure and the residual floor, after the
    clean image's own. Parameters come from the `evaluate:` section of --config. Exit status 2 on bad input
    (the two grids differ, a 3D cube).
    """
    from sarproc.cli.progress import progress_factory
    from sarproc.product.io import atomic_path, check_output_path, read_product
    from sarproc.quality.ghost_test import injected_ghosts
    from sarproc.quality.metrics import EvaluateParams

    params = load_config(EvaluateParams, config_path, section="evaluate")
    wanted = _levels(levels)
    if output is not None:
        check_output_path(output, [clean_path, ghosted_path], overwrite=overwrite)
    clean = read_product(clean_path, kinds=("image",))
    ghosted = read_product(ghosted_path, kinds=("image",))
    test = injected_ghosts(clean, ghosted, params, wanted, progress_factory(want_progress(progress), "ghost-test"))
    if output is not None:
        doc = {"clean": str(clean_path), "ghosted": str(ghosted_path), **test.to_dict()}
        with atomic_path(output, overwrite=overwrite) as tmp:
            tmp.write_text(json.dumps(doc, indent=2, allow_nan=False) + "\n", encoding="utf-8")
    if verbosity() >= 0:
        click.echo(ghost_table(test), err=stdout_taken())
