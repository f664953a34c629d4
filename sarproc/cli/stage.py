"""The order every processing subcommand follows; each stage's resource estimate is the package's
(sarproc.product.budget and the families' ``budget`` modules).

1. parameters (``--config`` section), 2. the input's header (every layout check, no data read),
3. the output location (exists? writable?), 4. the plan (output size, peak memory, run time;
printed with -v, refused when it cannot fit), 5. the data, 6. the work, 7. the atomic write.
So a bad scene or config is reported before "output exists", and nothing is computed for an
output that cannot be written. Errors from the core that name no file get the input's name.
"""

from __future__ import annotations

import contextlib
from pathlib import Path
from typing import TYPE_CHECKING

import click

from sarproc.cli.options import dry_run, info, load_config, max_memory
from sarproc.product.budget import Plan, check_plan, generic_estimate, whole_process
from sarproc.product.errors import InputError

if TYPE_CHECKING:
    from collections.abc import Callable, Iterator, Sequence
    from typing import Any

    from sarproc.product.model import Product


@contextlib.contextmanager
def naming(
    input_path: str | Path | None, config_path: str | Path | None = None, section: str | None = None
) -> Iterator[None]:
    """Give a core InputError the file it is about: the config for ``section.key`` messages, else the input."""
    try:
        yield
    except InputError as exc:
        msg = str(exc)
        if str(input_path) in msg or (config_path is not None and str(config_path) in msg):
            raise
        if config_path is not None and section and msg.startswith((section + ".", section + ":")):
            raise InputError(f"{config_path}: {msg}") from None
        raise InputError(f"{input_path}: {msg}") from None


def prepare(
    stage: str,
    input_path: Path,
    outputs: Sequence[Path | None],
    config_path: Path | None,
    overwrite: bool,
    kinds: tuple[str, ...],
    params_cls: type,
    section: str,
    estimate: Callable[..., Plan] | None = None,
) -> tuple[Any, Product]:
    """Steps 1-5 above; returns (params, product) ready for the work."""
    from sarproc.product.io import read_product

    params: Any = load_config(params_cls, config_path, section=section)
    header = read_product(input_path, kinds=kinds, load=False)
    if config_path is None:
        unapplied_scene_section(header, params_cls, section, input_path)
    plan_outputs(
        input_path,
        outputs,
        overwrite,
        lambda: (estimate or generic_estimate)(stage, header, params),
        config_path=config_path,
        section=section,
    )
    product = read_product(input_path, kinds=kinds)
    return params, product


def unapplied_scene_section(product: Product, params_cls: type, section: str, input_path: str | Path) -> None:
    """Without --config a stage runs on its defaults: say so when the scene the product was simulated from
    has a ``section`` that would change them (recorded in the simulate history entry), naming the keys."""
    import logging

    from sarproc.product.config import build

    entry = next((h for h in product.history if isinstance(h, dict) and "stage_sections" in h), None)
    data = (entry or {}).get("stage_sections", {}).get(section) or {}
    if not isinstance(data, dict) or not data:
        return
    defaults: Any = build(params_cls, {}, source="defaults")
    theirs: Any
    try:
        theirs = build(params_cls, data, source="scene", section=section)
    except InputError:
        changed = sorted(data)  # not even valid: certainly not what runs
    else:
        changed = [k for k in data if getattr(theirs, k, None) != getattr(defaults, k, None)]
    if not changed:
        return
    command = str(entry.get("command", "")) if entry else ""
    scene = command.split(" ", 2)[2] if command.startswith("sarproc simulate ") else "its scene file"
    logging.getLogger(__name__).warning(
        "%s comes from a simulation of %s, whose `%s:` section (%s) is not applied: without --config the defaults "
        "run "
        "(%s); pass --config %s to apply it",
        input_path,
        scene,
        section,
        ", ".join(f"{k}: {data[k]}" for k in changed),
        ", ".join(f"{k}: {getattr(defaults, k, '?')}" for k in changed),
        scene if entry and command.startswith("sarproc simulate ") else "SCENE.yaml",
    )


def plan_outputs(
    input_path: str | Path,
    outputs: Sequence[Path | None],
    overwrite: bool,
    estimate: Callable[[], Plan],
    inputs: Sequence[Path] | None = None,
    config_path: Path | None = None,
    section: str | None = None,
) -> Plan:
    """Steps 3-4 above for a checked input: every output writable, then ``estimate()``'s plan printed
    with -v and refused when it cannot fit. ``inputs``: the files the outputs must not replace
    (default ``[input_path]``). Returns the plan."""
    from sarproc.product.io import check_output_path

    paths = [Path(o) for o in outputs if o is not None]
    for out in paths:
        check_output_path(out, [input_path] if inputs is None else inputs, overwrite)
    with naming(input_path, config_path, section):
        plan = estimate()
    report_plan(plan, paths, input_path)
    return plan


def report_plan(plan: Plan, outputs: Sequence[Path], input_path: str | Path | None) -> None:
    """Step 4: the plan printed (with -v), refused when it cannot fit; with --dry-run printed on
    stdout, and the run ends here (exit 0, nothing computed or written)."""
    plan = whole_process(plan)
    if not dry_run():
        info(plan.describe())
    with naming(input_path):
        check_plan(plan, [Path(o) for o in outputs if o is not None], max_memory())
    if dry_run():
        click.echo(plan.describe())
        raise click.exceptions.Exit(0)
