"""One command's run: its stop signals, its outputs' locks, and when it counts as complete.

Signals. SIGTERM, SIGINT and SIGHUP end a run with exit status 128 + N and no output. The
handler raises :class:`Interrupted` wherever Python code is running; when that exception is
swallowed (a C library such as HDF5 calling back into Python reports it as "ignored" and carries
on) the signal is still recorded, and every block write, every publish and the end of the
command check the record. Publishing (the rename and its record) is a critical section: a signal
that lands there is acted on right after it. Once every output the run planned is published the
run is complete: a later signal is ignored and the run ends 0 with its complete outputs.

Locks. A run locks each regular output when it checks it, before any work: ``flock`` on a sibling
``.<name>.sarproc-lock`` file holding the owner's pid and command. The kernel drops the lock when
its process dies, however it dies (SIGKILL included), so it cannot go stale; a second run on the
same output stops at once, exit 2, naming the first. The lock is released when that output is
published (its file removed) or when the run ends.

Without :func:`begin` (the core used as a library, a Dask worker) nothing is locked or recorded.
"""

from __future__ import annotations

import contextlib
import errno as _errno
import fcntl
import os
import shlex
import signal
import sys
import threading
import time
from pathlib import Path
from types import FrameType
from typing import TYPE_CHECKING

from sarproc.product.errors import InputError

if TYPE_CHECKING:
    from collections.abc import Iterator

# Signals a batch scheduler or a terminal sends to end a run; each exits 128 + signal number.
STOP_SIGNALS = tuple(getattr(signal, n) for n in ("SIGTERM", "SIGINT", "SIGHUP") if hasattr(signal, n))
LOCK_SUFFIX = ".sarproc-lock"


class Interrupted(BaseException):
    """A stop signal arrived: unwinds like KeyboardInterrupt so every temporary file is removed."""

    def __init__(self, signum: int) -> None:
        super().__init__(signum)
        self.signum = signum
        self.removed: list[Path] = []  # outputs published before the signal and removed again (the message)


class _Run:
    def __init__(self) -> None:
        self.fired: list[int] = []  # the stop signal received (kept apart from the exception it raised)
        self.defer = 0  # inside a critical section: act on a signal at its end
        self.planned: set[str] = set()
        self.published: list[Path] = []
        self.removable: list[Path] = []  # published regular files (a stream cannot be taken back)
        self.locks: dict[str, tuple[int, Path]] = {}
        self.stdout_taken = False
        self.keep_published = False
        self.temporaries: set[str] = set()  # made and not yet published or removed


_RUN: _Run | None = None
_ENDED = [False]  # the run has ended: its exit status is decided, a late signal changes nothing
_EARLY: list[int] = []  # a signal before the run began: acted on when it begins
_mutex = threading.RLock()  # sweep steps may plan outputs from several threads


def _key(path: str | os.PathLike) -> str:
    return os.path.abspath(os.fspath(path))


# ---- signals -----------------------------------------------------------------------------------------------------


def _handler(signum: int, frame: FrameType | None) -> None:
    run = _RUN
    if run is None:
        # Before the run (argument parsing): recorded, acted on when it begins; raising here could cut a
        # module's import in two, which then fails as an ImportError. After the run: its status stands.
        if not _ENDED[0] and not _EARLY:
            _EARLY.append(signum)
        return
    if run.fired:  # already stopping (cleaning up): later deliveries change nothing
        return
    run.fired.append(signum)
    if run.defer or complete():
        return
    raise Interrupted(signum)


def install_handlers() -> None:
    """Stop signals raise :class:`Interrupted` (main thread only: Python runs handlers there)."""
    _ENDED[0] = False
    _EARLY.clear()
    if threading.current_thread() is threading.main_thread():
        for s in STOP_SIGNALS:
            signal.signal(s, _handler)


def ignore_signals() -> None:
    """After the run: a late signal must not kill the process while it exits (with its status)."""
    if threading.current_thread() is threading.main_thread():
        for s in STOP_SIGNALS:
            signal.signal(s, signal.SIG_IGN)


def fired() -> int | None:
    """The stop signal this run received (or, before it began, the process), if any."""
    run = _RUN
    if run is None:
        return _EARLY[0] if _EARLY else None
    return run.fired[0] if run.fired else None


def check() -> None:
    """Raise :class:`Interrupted` when a stop signal arrived (also one whose exception was swallowed)."""
    run = _RUN
    if run is not None and run.fired and not run.defer and not complete():
        raise Interrupted(run.fired[0])


@contextlib.contextmanager
def deferred() -> Iterator[None]:
    """A short step that must not be cut in two (taking a lock): a signal inside is acted on at its end.

    Only the main thread is ever cut by the handler; other threads (a sweep's Dask workers in this process)
    run their steps as they are."""
    run = _RUN
    if run is None or threading.current_thread() is not threading.main_thread():
        yield
        return
    run.defer += 1
    try:
        yield
    finally:
        run.defer -= 1
    check()


@contextlib.contextmanager
def critical() -> Iterator[None]:
    """Publishing: refuse to start after a signal; a signal inside is acted on at the end (unless complete)."""
    run = _RUN
    if run is not None and run.fired:
        raise Interrupted(run.fired[0])
    with deferred():
        yield


# ---- the run -----------------------------------------------------------------------------------------------------


def begin() -> None:
    """Start recording a run (the CLI, around one command)."""
    global _RUN
    _ENDED[0] = False
    _RUN = _Run()
    _RUN.fired.extend(_EARLY[:1])  # a signal during argument parsing: the caller's first check() stops the run
    _EARLY.clear()


def end() -> None:
    """Remove the temporary files left, release every lock still held; stop recording."""
    global _RUN
    run, _RUN = _RUN, None
    _ENDED[0] = True
    if run is not None:
        # a signal between a temporary file's creation and the code that owns it leaves it: remove it
        for tmp in list(run.temporaries):
            with contextlib.suppress(OSError):
                os.unlink(tmp)
        for fd, path in list(run.locks.values()):
            _unlock(fd, path)


def complete() -> bool:
    """Every planned output of the run is published (nothing a signal could still spoil)."""
    run = _RUN
    if run is None or not run.planned:
        return False
    with _mutex:
        return run.planned <= {_key(p) for p in run.published}


def keep_published_on_interrupt() -> None:
    """A command whose outputs are independent results (a sweep's steps): an interrupt keeps those published."""
    if _RUN is not None:
        _RUN.keep_published = True


def remove_published() -> list[Path]:
    """After an interrupt: remove what this run already published (outputs are all or nothing)."""
    run = _RUN
    if run is None or run.keep_published:
        return []
    removed = []
    for p in run.removable:
        with contextlib.suppress(OSError):
            if p.is_file() and not p.is_symlink():
                p.unlink()
                removed.append(p)
    return removed


def plan_output(path: str | os.PathLike, lock: bool = True) -> None:
    """Record ``path`` as an output of this run; lock it (a regular file's real path) unless told not to."""
    run = _RUN
    if run is None:
        return
    with deferred(), _mutex:
        run.planned.add(_key(path))
        if lock and _key(path) not in run.locks:
            run.locks[_key(path)] = _lock(Path(path))


def track_temporary(path: str | os.PathLike, made: bool = True) -> None:
    """``path`` is a temporary file of this run (``made=False``: it is gone, renamed or removed)."""
    run = _RUN
    if run is not None:
        with _mutex:
            (run.temporaries.add if made else run.temporaries.discard)(os.fspath(path))


def mark_published(path: str | os.PathLike, stream: bool = False) -> None:
    """``path`` is complete on disk (or, ``stream``, fully written through); its lock goes."""
    run = _RUN
    if run is None:
        return
    with _mutex:
        run.published.append(Path(path))
        if not stream:
            run.removable.append(Path(path))
        run.planned.add(_key(path))  # an output nobody planned (a sweep's records) counts as planned and done
        held = run.locks.pop(_key(path), None)
    if held is not None:
        _unlock(*held)


def take_stdout(taken: bool = True) -> None:
    """A product goes to standard output: every message goes to stderr (``False``: not yet)."""
    if _RUN is not None:
        _RUN.stdout_taken = taken


def stdout_taken() -> bool:
    return _RUN is not None and _RUN.stdout_taken


# ---- locks -------------------------------------------------------------------------------------------------------


def lock_path(output: Path) -> Path:
    return output.parent / f".{output.name}{LOCK_SUFFIX}"


def hostname() -> str:
    """socket.gethostname() without importing socket (~5 ms of every stage's start): on POSIX (this module
    needs fcntl) both read the kernel's node name, uname(2)."""
    return os.uname().nodename


def _owner() -> str:
    return f"pid {os.getpid()} on {hostname()}: sarproc {shlex.join(sys.argv[1:])}"


def _holder(fd: int) -> str:
    """Who holds the lock, as it wrote itself in the file (it may be writing it right now: retry)."""
    for _ in range(20):
        with contextlib.suppress(OSError):
            text = os.pread(fd, 4096, 0).decode("utf-8", "replace").strip()
            if text:
                return text
        time.sleep(0.025)
    return "a process that has not said who it is"


def _lock(output: Path) -> tuple[int, Path]:
    path = lock_path(output)
    while True:
        try:
            fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o666)
        except PermissionError:  # another user's lock file: locking needs only a readable descriptor
            fd = os.open(path, os.O_RDONLY | os.O_CLOEXEC)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            if exc.errno not in (_errno.EWOULDBLOCK, _errno.EAGAIN, _errno.EACCES):
                os.close(fd)
                raise
            who = _holder(fd)
            os.close(fd)
            raise InputError(
                f"{output}: another sarproc run is writing this output ({who}); "
                "wait for it to end or choose another output"
            ) from None
        # The previous holder removes the file before it lets go: locked a removed file? Start again.
        try:
            same = os.path.samestat(os.fstat(fd), os.stat(path))
        except FileNotFoundError:
            same = False
        if same:
            break
        os.close(fd)
    with contextlib.suppress(OSError):
        os.ftruncate(fd, 0)
        os.pwrite(fd, (_owner() + "\n").encode(), 0)
    return fd, path


def _unlock(fd: int, path: Path) -> None:
    with contextlib.suppress(OSError):
        os.unlink(path)  # while still held: a run that opened it meanwhile sees it removed and retries
    with contextlib.suppress(OSError):
        os.close(fd)
