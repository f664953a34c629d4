"""The ``sarproc`` click group. Subcommands are imported lazily so ``--help`` stays instant.

Each stage lives in its own module under ``sarproc.cli``; a stage registers by adding one line
to COMMANDS. Modules that do not exist yet are simply not listed.
"""

from __future__ import annotations

import contextlib
import importlib
import importlib.util
import logging
import os
import re
import signal
import sys
import threading
import traceback

import click

from sarproc import __version__
from sarproc.product.errors import InputError, ProcessingError

COMMANDS = {
    "simulate": "sarproc.cli.simulate:simulate",
    "preprocess": "sarproc.cli.squint_deramp:preprocess",
    "coarse-focus": "sarproc.cli.squint_deramp:coarse_focus",
    "fine-focus": "sarproc.cli.squint_deramp:fine_focus",
    "pfa2": "sarproc.cli.pfa:pfa2",
    "import-gotcha": "sarproc.cli.pfa:import_gotcha",
    "reconstruct": "sarproc.cli.multichannel:reconstruct",
    "array3d": "sarproc.cli.array3d:array3d",
    "backproject": "sarproc.cli.backproject:backproject",
    "evaluate": "sarproc.cli.evaluate:evaluate",
    "quicklook": "sarproc.cli.quicklook:quicklook",
    "sweep": "sarproc.cli.sweep:sweep",
    "export-sicd": "sarproc.cli.formats:export_sicd",
    "export-cphd": "sarproc.cli.formats:export_cphd",
    "import-cphd": "sarproc.cli.formats:import_cphd",
}


class BadInput(click.ClickException):
    """Bad usage or bad input: exit status 2, message on stderr."""

    exit_code = 2


class ProcessingFailed(click.ClickException):
    exit_code = 1


class Interrupted(BaseException):
    """A termination signal arrived: unwinds like KeyboardInterrupt so every temporary file is removed."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


# Signals a batch scheduler or a terminal sends to end a run; each exits 128 + signal number.
_STOP_SIGNALS = tuple(getattr(signal, n) for n in ("SIGTERM", "SIGINT", "SIGHUP") if hasattr(signal, n))


# The signal that ended this run. Kept apart from the exception because a C library (HDF5) can
# swallow an exception raised inside one of its callbacks and report its own error instead.
_FIRED: list[int] = []


@contextlib.contextmanager
def _signals_unwind():
    """Turn SIGTERM/SIGINT/SIGHUP into :class:`Interrupted` (once; later ones are ignored while cleaning up)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    _FIRED.clear()

    def handler(signum, frame):
        if _FIRED:
            return
        _FIRED.append(signum)
        raise Interrupted(signum)

    previous = {s: signal.signal(s, handler) for s in _STOP_SIGNALS}
    try:
        yield
    finally:
        for s, h in previous.items():
            signal.signal(s, h)


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


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

    def parse_args(self, ctx, args):
        # -q / -v / -vv may come anywhere (also after the subcommand): move them in front of it.
        front, rest = [], []
        for i, a in enumerate(args):
            if a == "--":
                rest.extend(args[i:])
                break
            (front if a in ("-q", "--quiet", "--verbose") or re.fullmatch(r"-v+", a) else rest).append(a)
        return super().parse_args(ctx, front + rest)

    def invoke(self, ctx):
        verbosity = -1 if ctx.params.get("quiet") else int(ctx.params.get("verbose") or 0)
        ctx.meta["sarproc.verbosity"] = verbosity
        try:
            try:
                with _signals_unwind():
                    return super().invoke(ctx)
            except (click.exceptions.Exit, KeyboardInterrupt):
                raise
            except BaseException:
                if _FIRED:   # whatever the signal interrupted failed as a consequence
                    raise Interrupted(_FIRED[0]) from None
                raise
        except InputError as exc:
            raise BadInput(str(exc)) from None
        except ProcessingError as exc:
            raise ProcessingFailed(_one_line(exc)) from None
        except (click.ClickException, click.exceptions.Exit, click.Abort):
            raise
        except Interrupted as exc:
            name = signal.Signals(exc.signum).name
            click.echo(f"Error: interrupted by {name}; no output was written", err=True)
            ctx.exit(128 + exc.signum)
        except KeyboardInterrupt:
            click.echo("Error: interrupted by SIGINT; no output was written", err=True)
            ctx.exit(128 + signal.SIGINT)
        except MemoryError:
            raise ProcessingFailed("out of memory; reduce the scene or the block size "
                                   "(sarproc -v prints each stage's memory estimate)") from None
        except OSError as exc:
            if verbosity >= 2:
                traceback.print_exc()
            from sarproc.product.io import WRITE_ERRNOS, _os_cause

            name = f"{exc.filename}: " if exc.filename else ""
            if exc.errno in WRITE_ERRNOS or exc.errno is None:
                raise ProcessingFailed(f"{name}{_os_cause(exc)}") from None
            raise BadInput(f"{name}{exc.strerror or _one_line(exc)}") from None
        except Exception as exc:  # a bug: one line, the traceback with -vv
            if verbosity >= 2:
                traceback.print_exc()
            hint = "" if verbosity >= 2 else " (run with -vv for the traceback)"
            raise ProcessingFailed(f"internal error: {type(exc).__name__}: {_one_line(exc)[:300]}{hint}") from None


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
    # Only sarproc's own loggers get more verbose; libraries (h5py logs every type conversion at
    # DEBUG) stay at WARNING, or ERROR with -q.
    logging.basicConfig(level=logging.ERROR if quiet else logging.WARNING,
                        format="sarproc: %(levelname)s: %(message)s", stream=sys.stderr, force=True)
    logging.getLogger("sarproc").setLevel(level)
    logging.captureWarnings(True)


def main(args=None):  # pragma: no cover - console entry (exercised by subprocess tests)
    """Console entry: run the group; after a failed HDF5 write end without HDF5's cleanup (it can crash)."""
    default_hook = sys.unraisablehook

    def quiet_after_failed_write(unraisable):  # h5py objects of a damaged file complain when freed
        from sarproc.product.io import hdf5_handles_damaged

        if not hdf5_handles_damaged():
            default_hook(unraisable)

    sys.unraisablehook = quiet_after_failed_write

    def early(signum, frame):   # before a stage starts (argument parsing, imports): nothing to clean
        raise Interrupted(signum)

    for s in _STOP_SIGNALS:
        signal.signal(s, early)
    try:
        cli.main(args=args, prog_name="sarproc")
        code = 0
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
    except Interrupted as exc:
        print(f"Error: interrupted by {signal.Signals(exc.signum).name}", file=sys.stderr)
        code = 128 + exc.signum
    from sarproc.product.io import hdf5_handles_damaged

    if hdf5_handles_damaged():
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)
    sys.exit(code)
