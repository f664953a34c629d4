"""Options shared by every processing subcommand, and the helpers they all use."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from sarproc.product.config import build, load_yaml

output_option = click.option("-o", "--output", required=True, type=click.Path(dir_okay=False, path_type=Path),
                             help="Output HDF5 product.")
config_option = click.option("--config", "config_path", type=click.Path(dir_okay=False, path_type=Path),
                             default=None, help="YAML file of algorithm parameters (defaults from the product).")
overwrite_option = click.option("--overwrite", is_flag=True, help="Replace an existing output file.")
progress_option = click.option("--progress/--no-progress", default=None,
                               help="Show progress bars (default: on for a terminal).")
input_argument = click.argument("input_path", type=click.Path(path_type=Path))


def common_options(func):
    """-o, --config, --overwrite, --progress in one decorator."""
    for opt in (progress_option, overwrite_option, config_option, output_option):
        func = opt(func)
    return func


def want_progress(flag) -> bool:
    return sys.stderr.isatty() if flag is None else bool(flag)


def load_config(cls, path, section: str | None = None):
    """Build parameter model ``cls`` from a YAML file (or defaults when ``path`` is None).

    With ``section``, only that top-level key of the file is used, so one YAML file can hold
    the parameters of several stages.
    """
    if path is None:
        return build(cls, {}, source="defaults")
    data = load_yaml(path)
    if section is not None:
        data = data.get(section, {}) or {}
    return build(cls, data, source=str(path), section=section or "")


def summary(msg: str) -> None:
    click.echo(msg)
