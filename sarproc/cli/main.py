"""The ``sarproc`` click group. Subcommands are imported lazily so ``--help`` stays instant.

Each stage lives in its own module under ``sarproc.cli``; a stage registers by adding one line
to COMMANDS. Modules that do not exist yet are simply not listed.
"""

from __future__ import annotations

import importlib
import importlib.util
import logging
import sys

import click

from sarproc import __version__
from sarproc.product.errors import InputError, ProcessingError

COMMANDS = {
    "simulate": "sarproc.cli.simulate:simulate",
    "preprocess": "sarproc.cli.squint_deramp:preprocess",
    "coarse-focus": "sarproc.cli.squint_deramp:coarse_focus",
    "fine-focus": "sarproc.cli.squint_deramp:fine_focus",
    "pfa2": "sarproc.cli.pfa:pfa2",
    "reconstruct": "sarproc.cli.multichannel:reconstruct",
    "array3d": "sarproc.cli.array3d:array3d",
    "backproject": "sarproc.cli.backproject:backproject",
    "evaluate": "sarproc.cli.evaluate:evaluate",
}


class BadInput(click.ClickException):
    """Bad usage or bad input: exit status 2, message on stderr."""

    exit_code = 2


class ProcessingFailed(click.ClickException):
    exit_code = 1


def _available(target: str) -> bool:
    return importlib.util.find_spec(target.split(":")[0]) is not None


class LazyGroup(click.Group):
    def list_commands(self, ctx):
        return [name for name, target in COMMANDS.items() if _available(target)]

    def get_command(self, ctx, name):
        target = COMMANDS.get(name)
        if target is None or not _available(target):
            return None
        module, attr = target.split(":")
        return getattr(importlib.import_module(module), attr)

    def invoke(self, ctx):
        try:
            return super().invoke(ctx)
        except InputError as exc:
            raise BadInput(str(exc)) from None
        except ProcessingError as exc:
            raise ProcessingFailed(str(exc)) from None
        except MemoryError:
            raise ProcessingFailed("out of memory; reduce the scene or the block size") from None


@click.group(cls=LazyGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="sarproc")
@click.option("-v", "--verbose", count=True, help="More log output (repeat for debug).")
@click.option("-q", "--quiet", is_flag=True, help="Only errors.")
def cli(verbose: int, quiet: bool):
    """SAR point-target simulator, focusing processors and quality evaluation.

    Every subcommand reads one HDF5 product (or a scene YAML) and writes another.
    Exit status: 0 success, 1 processing failure, 2 bad usage or bad input.
    """
    level = logging.ERROR if quiet else (logging.WARNING, logging.INFO, logging.DEBUG)[min(verbose, 2)]
    logging.basicConfig(level=level, format="sarproc: %(levelname)s: %(message)s", stream=sys.stderr, force=True)
    logging.captureWarnings(True)


def main():  # pragma: no cover - console entry
    cli()
