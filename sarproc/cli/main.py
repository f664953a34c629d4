"""The ``sarproc`` click group. Subcommands are imported lazily so ``--help`` stays instant.

Each stage lives in its own module under ``sarproc.cli``; a stage registers by adding one line
to COMMANDS. Modules that do not exist yet are simply not listed.
"""

from __future__ import annotations

import atexit
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
from collections.abc import Iterator, MutableMapping, Sequence
from typing import Any, NoReturn

import click

from sarproc import __version__
from sarproc.product.errors import InputError, ProcessingError
from sarproc.product.run import Interrupted

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
    "ghost-test": "sarproc.cli.ghost_test:ghost_test",
    "quicklook": "sarproc.cli.quicklook:quicklook",
    "sweep": "sarproc.cli.sweep:sweep",
    "export-sicd": "sarproc.cli.formats:export_sicd",
    "export-cphd": "sarproc.cli.formats:export_cphd",
    "import-cphd": "sarproc.cli.formats:import_cphd",
    "schema": "sarproc.cli.schema:schema",
    "compare": "sarproc.cli.compare:compare",
}


class BadInput(click.ClickException):
    """Bad usage or bad input: exit status 2, message on stderr."""

    exit_code = 2


class ProcessingFailed(click.ClickException):
    exit_code = 1


@contextlib.contextmanager
def _run_scope() -> Iterator[None]:
    """One command's run (:mod:`sarproc.product.run`): stop signals raise Interrupted, outputs are locked."""
    from sarproc.product import run

    main_thread = threading.current_thread() is threading.main_thread()
    previous = {s: signal.getsignal(s) for s in run.STOP_SIGNALS} if main_thread else {}
    run.begin()
    run.install_handlers()
    try:
        yield
    finally:
        run.end()
        for s, h in previous.items():
            signal.signal(s, h)


def _one_line(text: object) -> str:
    return " ".join(str(text).split())


def _available(target: str) -> bool:
    return importlib.util.find_spec(target.split(":")[0]) is not None


class LazyGroup(click.Group):
    def list_commands(self, ctx: click.Context | None) -> list[str]:  # ctx unused: callers outside click pass None
        return [name for name, target in COMMANDS.items() if _available(target)]

    def get_command(self, ctx: click.Context | None, name: str) -> click.Command | None:
        target = COMMANDS.get(name)
        if target is None or not _available(target):
            return None
        module, attr = target.split(":")
        return getattr(importlib.import_module(module), attr)

    def parse_args(self, ctx: click.Context, args: list[str]) -> list[str]:
        # -q / -v / -vv may come anywhere (also after the subcommand): move them in front of it.
        front: list[str] = []
        rest: list[str] = []
        for i, a in enumerate(args):
            if a == "--":
                rest.extend(args[i:])
                break
            (front if a in ("--quiet", "--verbose") or re.fullmatch(r"-v+|-q+", a) else rest).append(a)
        return super().parse_args(ctx, front + rest)

    def invoke(self, ctx: click.Context) -> Any:
        quiet = int(ctx.params.get("quiet") or 0)
        verbosity = -quiet if quiet else int(ctx.params.get("verbose") or 0)
        ctx.meta["sarproc.verbosity"] = verbosity
        from sarproc.product import run

        try:
            with _run_scope():
                try:
                    try:
                        run.check()  # a signal during argument parsing
                        result = super().invoke(ctx)
                    except click.exceptions.Exit as exc:
                        if exc.exit_code == 0:
                            run.check()
                        raise
                    except KeyboardInterrupt:  # SIGINT outside the run's own handler (a test's runner)
                        raise Interrupted(signal.SIGINT) from None
                    except Interrupted:
                        raise
                    except BaseException:
                        if (fired := run.fired()) is not None and not run.complete():
                            # whatever the signal interrupted failed as a consequence
                            raise Interrupted(fired) from None
                        raise
                    run.check()  # a signal whose exception a library swallowed: the run still stops
                    return result
                except Interrupted as exc:
                    exc.removed = run.remove_published()  # all outputs or none
                    raise
        except InputError as exc:
            raise BadInput(str(exc)) from None
        except ProcessingError as exc:
            raise ProcessingFailed(_one_line(exc)) from None
        except (click.ClickException, click.exceptions.Exit, click.Abort):
            raise
        except Interrupted as exc:
            name = signal.Signals(exc.signum).name
            removed = getattr(exc, "removed", [])
            more = f" (removed {', '.join(map(str, removed))}, published before it)" if removed else ""
            click.echo(f"Error: interrupted by {name}; no output was written{more}", err=True)
            ctx.exit(128 + exc.signum)
        except MemoryError:
            raise ProcessingFailed(
                "out of memory; reduce the scene or the block size (sarproc -v prints each stage's memory estimate)"
            ) from None
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
@click.option(
    "-q",
    "--quiet",
    count=True,
    help="Only errors and the warnings that an image is wrong (ghosts, aliasing, folds); -qq: only errors.",
)
def cli(verbose: int, quiet: int) -> None:
    """SAR point-target simulator, focusing processors and quality evaluation.

    Every subcommand reads one HDF5 product (or a scene YAML) and writes another.
    Exit status: 0 success, 1 processing failure, 2 bad usage or bad input.
    """
    level = logging.ERROR if quiet >= 2 else (logging.WARNING, logging.INFO, logging.DEBUG)[min(verbose, 2)]
    # Only sarproc's own loggers get more verbose; libraries (h5py logs every type conversion at
    # DEBUG) stay at WARNING, or ERROR with -q.
    logging.basicConfig(
        level=logging.ERROR if quiet else logging.WARNING,
        format="sarproc: %(levelname)s: %(message)s",
        stream=sys.stderr,
        force=True,
    )
    logging.getLogger("sarproc").setLevel(level)
    if quiet == 1:  # -q: errors, and the warnings that an image is wrong
        logging.getLogger().handlers[0].addFilter(
            lambda r: r.levelno >= logging.ERROR or getattr(r, "image_defect", False)
        )
    logging.captureWarnings(True)


def run_cli(args: Sequence[str] | None = None) -> int:
    """Run one command as the console does, without leaving the process; returns its exit status."""
    from sarproc.product import run

    default_hook = sys.unraisablehook

    def quiet_unraisable(unraisable: sys.UnraisableHookArgs) -> None:
        from sarproc.product.io import hdf5_handles_damaged

        # h5py objects of a damaged file complain when freed; a stop signal raised inside a callback
        # (a weakref's, HDF5's) is "ignored" by Python but recorded by the run, which acts on it
        if not hdf5_handles_damaged() and not isinstance(unraisable.exc_value, Interrupted):
            default_hook(unraisable)

    quiet_unraisable.sarproc = True  # type: ignore[attr-defined]
    if not getattr(default_hook, "sarproc", False):
        sys.unraisablehook = quiet_unraisable  # for the whole process: freed HDF5 objects complain at its exit
    run.install_handlers()  # before a stage starts (argument parsing, imports): nothing to clean
    code = 0
    try:
        cli.main(args=args, prog_name="sarproc")  # standalone mode: always ends in SystemExit
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
    except Interrupted as exc:
        print(f"Error: interrupted by {signal.Signals(exc.signum).name}", file=sys.stderr)
        code = 128 + exc.signum
    fired = run.fired()
    if fired is not None and code == 0:  # during parsing, and no run began (--help, --version)
        print(f"Error: interrupted by {signal.Signals(fired).name}", file=sys.stderr)
        code = 128 + fired
    run.ignore_signals()  # the run has ended: its status stands, a late signal must not kill the exit
    return code


# The compiled kernels (numba's OpenMP layer, GNU libgomp here) alternate with scipy.fft's own worker threads.
# libgomp's default wait policy keeps its workers spinning after every parallel region, on cores the next FFT
# needs: full exp. 2 fine-focus took 2.19-2.24 s with it and 1.62 s with passive waits (docs/performance.md),
# backprojection the same either way. Read once, when libgomp starts: set by the command before any stage
# imports numba; a value the user set wins. Dask workers the command starts inherit it.
# OpenBLAS (numpy's, and scipy's own where evaluate loads its LAPACK) starts its worker threads when it is
# loaded, at numpy's import, and each spins for 2^28 TSC cycles (~0.1 s) waiting for work, before and after
# every threaded BLAS call, on the cores the stage needs: 0.05 s of CPU per library in every process
# (docs/performance.md, fourteenth round). 2^20 cycles (~0.4 ms) still bridges the calls of a batched matmul
# (2^4 made one 4x slower: every call woke sleeping workers); the number of BLAS threads, hence every product,
# is unchanged. Read when the library loads.
THREAD_DEFAULTS = {"OMP_WAIT_POLICY": "PASSIVE", "OPENBLAS_THREAD_TIMEOUT": "20"}


def set_thread_defaults(environ: MutableMapping[str, str] | None = None) -> None:
    """Put :data:`THREAD_DEFAULTS` into ``environ`` (default ``os.environ``) where the user set nothing."""
    target = os.environ if environ is None else environ
    for key, value in THREAD_DEFAULTS.items():
        target.setdefault(key, value)


def keep_bytecode_under_a_file_size_limit() -> None:
    """Under ``ulimit -f`` write no bytecode caches: Python ignores SIGXFSZ and does not check the length of
    its .pyc writes, so a module first imported under the limit left a truncated .pyc in the install that
    broke every later import of it ("marshal data too short": a 9 KB limit cut quality/plotting's)."""
    import resource

    if resource.getrlimit(resource.RLIMIT_FSIZE)[0] != resource.RLIM_INFINITY:
        sys.dont_write_bytecode = True


def main(
    args: Sequence[str] | None = None,
) -> NoReturn:  # pragma: no cover - console entry (exercised by subprocess tests)
    """Console entry: run the group; after a failed HDF5 write end without HDF5's cleanup (it can crash), else
    without the interpreter's teardown where nothing needs it (:func:`exit_without_teardown`)."""
    keep_bytecode_under_a_file_size_limit()
    set_thread_defaults()
    code = run_cli(args)
    io = sys.modules.get("sarproc.product.io")  # not imported: no HDF5 file was opened (--help stays light)

    if io is not None and io.hdf5_handles_damaged():
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)
    exit_without_teardown(code)


def exit_without_teardown(code: int) -> NoReturn:
    """End the process with ``code`` after the exit handlers (``atexit``: logging's flush, finalizers, h5py's),
    skipping the interpreter's teardown: freeing every module and object took 0.07-0.09 s of each process's
    exit with numpy and h5py loaded and 0.14-0.16 s with matplotlib (quicklook) (docs/performance.md, eleventh
    round), work whose only effect is memory the system reclaims anyway. Where the teardown could still do
    something (a thread still running, which Python would wait for; an HDF5 file still open, which HDF5's own
    exit handler flushes; standard output that cannot be flushed, which Python reports), the ordinary exit."""
    threads = [t for t in threading.enumerate() if t is not threading.main_thread() and not t.daemon]
    h5py = sys.modules.get("h5py")
    open_files = h5py is not None and h5py.h5f.get_obj_count(h5py.h5f.OBJ_ALL, h5py.h5f.OBJ_FILE) > 0
    if threads or open_files:
        sys.exit(code)
    try:
        sys.stdout.flush()
        sys.stderr.flush()
    except Exception:
        sys.exit(code)
    atexit._run_exitfuncs()
    with contextlib.suppress(Exception):
        sys.stdout.flush()
        sys.stderr.flush()
    os._exit(code)


if __name__ == "__main__":  # python -m sarproc.cli.main behaves like the sarproc command, not silently nothing
    main()
