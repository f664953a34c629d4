"""Options shared by every processing subcommand, and the helpers they all use."""

from __future__ import annotations

import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

import click

from sarproc.product.config import build, load_yaml

output_option = click.option(
    "-o",
    "--output",
    required=True,
    type=click.Path(dir_okay=False, allow_dash=True, path_type=Path),
    help="Output HDF5 product ('-': standard output).",
)
config_option = click.option(
    "--config",
    "config_path",
    type=click.Path(dir_okay=False, allow_dash=True, path_type=Path),
    default=None,
    help=(
        "YAML file whose section for this command sets its parameters (a scene file will do; '-': standard "
        "input). Without it the defaults run, some derived from the input, even where the scene the input was "
        "simulated from has the section (a warning then names what is not applied)."
    ),
)
overwrite_option = click.option("--overwrite", is_flag=True, help="Replace an existing output file.")
progress_option = click.option(
    "--progress/--no-progress", default=None, help="Show progress bars (default: on for a terminal)."
)
input_argument = click.argument("input_path", type=click.Path(path_type=Path))


class SectionCommand(click.Command):
    """A command whose ``--help`` ends with the keys of its YAML section (``section``: a --config
    section, or ``scene`` for a scene file), with units, bounds and defaults, generated from the
    parameter declarations through the stored schema (sarproc.cli.schema: no stage is imported)."""

    def __init__(self, *args: Any, section: str | tuple[str, ...], **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.sections = (section,) if isinstance(section, str) else tuple(section)

    def format_epilog(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        from sarproc.cli.schema import section_rows

        titles = {"scene": "Scene file keys", "sweep": "Sweep file keys", "expect": "Keys of the --expect file"}
        for section in self.sections:
            with formatter.section(titles.get(section, f"Keys of the `{section}:` section of --config")):
                formatter.write_dl(section_rows(section))
        super().format_epilog(ctx, formatter)


def _store_max_memory(ctx: click.Context, param: click.Parameter, value: str | None) -> str | None:
    if value is not None:
        from sarproc.product.budget import parse_size
        from sarproc.product.errors import InputError

        try:
            ctx.meta["sarproc.max_memory"] = parse_size(value)
        except InputError as exc:
            raise click.BadParameter(str(exc).split(": ", 1)[-1]) from None
    return value


# Stored in the context (expose_value=False), so every stage has it without a new argument.
max_memory_option = click.option(
    "--max-memory",
    metavar="SIZE",
    default=None,
    expose_value=False,
    callback=_store_max_memory,
    help="Refuse to start when the planned peak memory exceeds SIZE (e.g. 8G).",
)


def _store_dry_run(ctx: click.Context, param: click.Parameter, value: bool) -> bool:
    if value:
        ctx.meta["sarproc.dry_run"] = True
    return value


# Stored in the context like --max-memory; stage.report_plan ends the run after the plan.
dry_run_option = click.option(
    "--dry-run",
    is_flag=True,
    expose_value=False,
    callback=_store_dry_run,
    help="Check the inputs and outputs, print the plan (output size, peak memory, run "
    "time) and exit 0 without computing or writing anything.",
)


F = TypeVar("F", bound=Callable[..., Any])
T = TypeVar("T")


def common_options(func: F) -> F:
    """-o, --config, --overwrite, --progress, --max-memory, --dry-run in one decorator."""
    for opt in (dry_run_option, max_memory_option, progress_option, overwrite_option, config_option, output_option):
        func = opt(func)
    return func


def verbosity() -> int:
    """-1 with -q, else the number of -v given (0 by default)."""
    ctx = click.get_current_context(silent=True)
    return 0 if ctx is None else int(ctx.meta.get("sarproc.verbosity", 0))


def max_memory() -> int | None:
    ctx = click.get_current_context(silent=True)
    return None if ctx is None else ctx.meta.get("sarproc.max_memory")


def dry_run() -> bool:
    ctx = click.get_current_context(silent=True)
    return ctx is not None and bool(ctx.meta.get("sarproc.dry_run"))


def want_progress(flag: bool | None) -> bool:
    if verbosity() < 0:
        return False
    return sys.stderr.isatty() if flag is None else bool(flag)


def check_sections(data: dict, path: str | Path) -> None:
    """Refuse a top-level key that is no stage's, no other command's and no scene's section (a typo
    would otherwise be ignored and the defaults used)."""
    import dataclasses

    from sarproc.product.config import OTHER_SECTIONS, STAGE_SECTIONS, did_you_mean
    from sarproc.product.errors import InputError
    from sarproc.simulation.scene import SceneParams

    commands = STAGE_SECTIONS + OTHER_SECTIONS
    known = commands + tuple(f.name for f in dataclasses.fields(SceneParams))
    unknown = [k for k in data if k not in known]
    if unknown:
        raise InputError(
            f"{path}: unknown section(s) {', '.join(map(repr, unknown))}{did_you_mean(unknown, known)}; "
            f"a config file holds command sections ({', '.join(commands)}) and scene sections"
        )


def load_config(cls: type[T], path: str | Path | None, section: str | None = None) -> T:
    """Build parameter model ``cls`` from a YAML file (or defaults when ``path`` is None).

    With ``section``, only that top-level key of the file is used, so one YAML file can hold
    the parameters of several stages (and a scene); any other top-level key is refused.
    """
    if path is None:
        return build(cls, {}, source="defaults")
    data = load_yaml(path)
    if section is not None:
        check_sections(data, path)
        data = data.get(section, {})
        data = {} if data is None else data
    return build(cls, data, source=str(path), section=section or "")


def summary(msg: str) -> None:
    """The one success line of a stage (silenced by -q); on stderr when a product goes to stdout."""
    if verbosity() >= 0:
        click.echo(msg, err=stdout_taken())


def stdout_taken() -> bool:
    """An output of this run is standard output (``-o -``): nothing else may be printed there."""
    from sarproc.product.run import stdout_taken as taken

    return taken()


def info(msg: str) -> None:
    """A line shown with -v (plans, chosen defaults), on stderr so pipelines keep stdout clean."""
    if verbosity() >= 1:
        click.echo(msg, err=True)
