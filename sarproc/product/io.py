"""HDF5 product I/O: the one place that reads and writes files (the layout: docs/product.md).

Writes are atomic: everything goes to a temporary file ``.<name>.<host>.<pid>.<random>.sarproc-tmp``
in the target directory (matched by ``.gitignore``); it is published only when complete and
removed on any error or signal. Without ``overwrite`` it is published by hard link then unlink,
which cannot replace a file that another run created meanwhile. Temporary files of runs that
died (SIGKILL, power loss) are removed by the next run writing to the same directory. An output
that is the input, that exists without ``overwrite``, or whose directory is not writable is
refused before any work is done. A failed HDF5 write (full disk, file-size limit, read-only
file system) becomes a one-line ProcessingError; the damaged HDF5 handle is never closed again
(the library can crash doing so), see :func:`hdf5_handles_damaged`.

Special outputs are written through, never replaced: ``-`` (standard output), ``/dev/std*``,
``/dev/fd/N``, and any existing character or block device, FIFO or socket get the finished
file's bytes streamed into them (the temporary file is then in the temporary directory), also
with ``overwrite``. A symbolic link to a regular file is followed: the temporary file is made
next to the link's target and renamed onto it, the link stays. Each regular output is locked
for the run from its check on (:mod:`sarproc.product.run`).
"""

from __future__ import annotations

import contextlib
import dataclasses
import datetime as _dt
import errno as _errno
import json
import math
import os
import re
import stat
import sys
import tempfile
from collections.abc import Iterator, Sequence
from pathlib import Path
from types import EllipsisType, TracebackType
from typing import Any, NamedTuple

import h5py
import numpy as np

from sarproc import __version__
from sarproc.product import run
from sarproc.product.errors import InputError, ProcessingError
from sarproc.product.metadata import FORMAT_VERSION, RadarMetadata
from sarproc.product.model import (
    AUX_DIM_DOC,
    AUX_LAYOUT,
    DATA_ATTR_UNITS,
    DATA_NAME,
    KIND_DIMS,
    MOVING_TARGET_COLUMNS,
    PRODUCT_KINDS,
    TARGET_DTYPE,
    TARGET_IRW_FIELDS,
    TARGET_NULL_FIELDS,
    TARGET_RIDGE_FIELD,
    TARGET_SIDELOBE_FIELDS,
    TARGET_THEORY_FIELDS,
    TARGET_UNITS,
    UNITS,
    Product,
    as_target_table,
)

LONG_NAMES = {
    "azimuth_time": "azimuth (slow) time from aperture centre",
    "range_time": "range (fast) time since transmit",
    "channel": "receive channel index",
    "azimuth": "azimuth position",
    "range": "range position",
    "elevation": "elevation angle",
}

TMP_SUFFIX = ".sarproc-tmp"
_HOST = re.sub(r"[^A-Za-z0-9-]", "-", run.hostname())[:32] or "host"
_DAMAGED: list = []  # h5py objects of files whose write failed: kept alive, never closed


class Stream(NamedTuple):
    """An output written through: a descriptor of this process, or a device, FIFO or socket by path."""

    name: str
    fd: int | None = None
    path: str | None = None
    socket: bool = False


def _stream_path(stream: Stream) -> str:
    """The path of a stream given by path (every Stream has a descriptor or a path)."""
    assert stream.path is not None
    return stream.path


_STD_FDS = {"stdin": 0, "stdout": 1, "stderr": 2}
_FD_PATH = re.compile(r"^(?:/dev/(?P<std>stdin|stdout|stderr)|/dev/fd/(?P<fd>\d+)|/proc/self/fd/(?P<fd2>\d+))$")


def hdf5_handles_damaged() -> bool:
    """True after a failed HDF5 write: the process must end with ``os._exit`` (HDF5 may crash on cleanup)."""
    return bool(_DAMAGED)


def history_entry(command: str, params: dict | None = None) -> dict:
    """One provenance record: command, version, UTC time and the resolved parameters."""
    return {
        "command": command,
        "sarproc_version": __version__,
        "utc": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
        "parameters": params or {},
    }


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def clean_stale_temporaries(directory: str | Path) -> list[Path]:
    """Remove temporaries of dead sarproc runs on this host in ``directory``; returns what went."""
    removed: list[Path] = []
    directory = Path(directory)
    try:
        entries = list(directory.glob(f".*{TMP_SUFFIX}"))
    except OSError:
        return removed
    for p in entries:
        parts = p.name[: -len(TMP_SUFFIX)].rsplit(".", 3)
        if len(parts) != 4 or parts[1] != _HOST or not parts[2].isdigit():
            continue
        if int(parts[2]) != os.getpid() and not _pid_alive(int(parts[2])):
            with contextlib.suppress(OSError):
                p.unlink()
                removed.append(p)
    return removed


def _temporary_name(output: Path) -> Path:
    return (
        output.parent / f".{output.name}.{_HOST}.{os.getpid()}.{os.urandom(4).hex()}{TMP_SUFFIX}"
    )  # = secrets.token_hex(4)


# errno values meaning the output could not be stored (a processing failure, exit 1)
WRITE_ERRNOS = {_errno.ENOSPC, _errno.EFBIG, _errno.EROFS, _errno.EDQUOT, _errno.EIO}


def _errno_of(exc: Exception) -> int | None:
    """The errno of an OSError, or the one h5py quotes in its message ('errno = 28')."""
    code = getattr(exc, "errno", None)
    if code is None:
        m = re.search(r"errno = (\d+)", str(exc))
        code = int(m.group(1)) if m else None
    return code


def _os_cause(exc: Exception) -> str:
    """'No space left on device (ENOSPC)' from an OSError, including h5py's wrapped ones."""
    code = _errno_of(exc)
    if code is None:
        return " ".join(str(exc).split())[:200]
    return f"{os.strerror(code)} ({_errno.errorcode.get(code, code)})"


def output_stream(output: str | Path) -> Stream | None:
    """Where bytes written to ``output`` must be streamed instead of renamed into place; None for a regular file.

    ``-`` is standard output; ``/dev/stdin|stdout|stderr``, ``/dev/fd/N`` and ``/proc/self/fd/N`` are that
    descriptor of this process; an existing character or block device, FIFO or socket (also behind a
    symbolic link) is opened and written through. Such a file is never replaced, removed or truncated.
    """
    text = os.fspath(output)
    if text == "-":
        return Stream(text, fd=1)
    m = _FD_PATH.match(text)
    if m:
        number = m.group("fd") or m.group("fd2")
        return Stream(text, fd=int(number) if number else _STD_FDS[m.group("std")])
    try:
        mode = os.stat(text).st_mode  # follows links: a link to /dev/null is /dev/null
    except OSError:
        return None
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode) or stat.S_ISFIFO(mode):
        return Stream(text, path=text)
    if stat.S_ISSOCK(mode):
        return Stream(text, path=text, socket=True)
    return None


def real_output(output: str | Path) -> Path:
    """A regular output named by a symbolic link is its target: written next to it and renamed onto it; the link
    stays (also a dangling one: its target is created)."""
    out = Path(output)
    return Path(os.path.realpath(out)) if out.is_symlink() else out


def _is_stdout(stream: Stream) -> bool:
    if stream.fd == 1:
        return True
    try:
        a = os.fstat(1)
        b = os.fstat(stream.fd) if stream.fd is not None else os.stat(_stream_path(stream))
    except OSError:
        return False
    return os.path.samestat(a, b) and not stat.S_ISREG(a.st_mode) and not stat.S_ISDIR(a.st_mode)


def check_output_path(output: str | Path, inputs: Sequence[str | Path] = (), overwrite: bool = False) -> Path:
    """Refuse to write over an input, over an existing file without ``overwrite``, or where no file can be made;
    lock the output for this run (:mod:`sarproc.product.run`).

    The directory's writability is proven by creating (and removing) a temporary file there, so a
    read-only, full-quota or missing location fails now, before any computation. A stream output
    (:func:`output_stream`) is not refused for existing: it is written through, never replaced.
    """
    out = Path(output)
    try:  # a directory on the way that this user may not search (session 43 row 11: said as "Permission denied")
        os.stat(out)
    except PermissionError as exc:
        raise InputError(
            f"{out}: cannot reach it: {_os_cause(exc)} on a directory of its path; choose a writable location"
        ) from None
    except OSError:
        pass  # missing (the usual case), a dangling link, ...: the checks below say which
    stream = output_stream(out)
    input_paths = [Path(i) for i in inputs if os.fspath(i) != "-"]  # "-" as an input is stdin
    if stream is not None:
        for inp in input_paths:
            if stream.path is not None and inp.exists() and os.path.samefile(inp, stream.path):
                raise InputError(f"{out}: output is the input file; refusing to write over an input")
        if stream.path is not None and not stream.socket and not os.access(stream.path, os.W_OK):
            raise InputError(f"{out}: not writable (permission denied)")
        _probe_directory(out, Path(tempfile.gettempdir()))
        if _is_stdout(stream):
            run.take_stdout()
        run.plan_output(out, lock=False)
        return out
    for inp in input_paths:
        if inp.exists() and out.exists() and os.path.samefile(inp, out):
            raise InputError(f"{out}: output is the input file; refusing to write over an input")
        if inp.resolve() == out.resolve():
            raise InputError(f"{out}: output is the input file; refusing to write over an input")
    if out.is_dir():
        raise InputError(f"{out}: output is a directory; give a file name")
    if out.exists() and not overwrite:
        raise InputError(f"{out}: output exists; pass --overwrite to replace it")
    dest = real_output(out)
    parent = dest.parent
    if not parent.exists():
        raise InputError(f"{out}: output directory {parent} does not exist; create it first")
    if not parent.is_dir():
        raise InputError(f"{out}: {parent} is not a directory")
    clean_stale_temporaries(parent)
    _probe_directory(dest, parent)
    run.plan_output(dest)
    return out


def _probe_directory(out: Path, directory: Path) -> None:
    probe = _temporary_name(directory / out.name)
    run.track_temporary(probe)
    try:
        fd = os.open(probe, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o600)
    except OSError as exc:
        where = "the temporary directory " if directory != out.parent else ""
        raise InputError(
            f"{out}: cannot create files in {where}{directory}: {_os_cause(exc)}; choose a writable location"
        ) from None
    os.close(fd)
    os.unlink(probe)
    run.track_temporary(probe, made=False)


def _publish(tmp: Path, output: Path, overwrite: bool) -> None:
    """Move ``tmp`` to ``output``: replace with ``overwrite``, else link-then-unlink (never replaces)."""
    if overwrite:
        os.replace(tmp, output)
        return
    try:
        os.link(tmp, output)
    except FileExistsError:
        raise InputError(
            f"{output}: another process created this file while this run was writing; "
            "not replaced (pass --overwrite to replace it)"
        ) from None
    except OSError as exc:
        if exc.errno not in (_errno.EPERM, _errno.ENOTSUP, _errno.EOPNOTSUPP, _errno.EXDEV, _errno.EMLINK):
            raise
        # No hard links here (some network/FAT file systems): claim the name exclusively, then replace it.
        try:
            os.close(os.open(output, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o666))
        except FileExistsError:
            raise InputError(
                f"{output}: another process created this file while this run was writing; "
                "not replaced (pass --overwrite to replace it)"
            ) from None
        os.replace(tmp, output)
        return
    os.unlink(tmp)


def _stream_into(tmp: Path, stream: Stream) -> None:
    """Copy the finished temporary file into a stream output, as it is (no truncation, no rename)."""
    if stream.fd == 1:
        with contextlib.suppress(Exception):
            sys.stdout.flush()
    sock = None
    if stream.fd is not None:
        fd, close = stream.fd, False
    elif stream.socket:
        import socket  # only here: ~5 ms of every stage's start otherwise

        sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        sock.connect(_stream_path(stream))
        fd, close = sock.fileno(), False
    else:  # a FIFO waits here for its reader, as any writer does
        fd, close = os.open(_stream_path(stream), os.O_WRONLY | os.O_CLOEXEC), True
    try:
        with open(tmp, "rb") as src:
            while chunk := src.read(1 << 20):
                view = memoryview(chunk)
                while view:
                    run.check()
                    view = view[os.write(fd, view) :]
    finally:
        if close:
            os.close(fd)
        if sock is not None:
            sock.close()


@contextlib.contextmanager
def atomic_path(output: str | os.PathLike, overwrite: bool = True) -> Iterator[Path]:
    """Yield a temporary path; on success publish it as ``output``, on failure remove it.

    A regular file (or a link's target) is published by rename from its own directory; a stream output
    (:func:`output_stream`) gets the finished file's bytes written into it, from a temporary file in the
    temporary directory.
    """
    output = Path(output)
    stream = output_stream(output)
    dest = real_output(output) if stream is None else None
    tmp = _temporary_name(dest if dest is not None else Path(tempfile.gettempdir()) / output.name)
    run.track_temporary(tmp)  # removed at the run's end wherever a signal lands
    fd = os.open(tmp, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o666)  # the umask applies, as for any new file
    os.close(fd)
    try:
        yield tmp
        if stream is not None:
            run.check()  # a signal whose exception was swallowed: nothing is streamed
            _stream_into(tmp, stream)
            os.unlink(tmp)
            run.track_temporary(tmp, made=False)
            with run.critical():
                run.mark_published(output, stream=True)
        else:
            assert dest is not None  # not a stream: a regular destination
            with run.critical():
                _publish(tmp, dest, overwrite)
                run.track_temporary(tmp, made=False)
                run.mark_published(dest)
    except OSError as exc:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        if exc.errno == _errno.EPIPE:
            raise ProcessingError(f"{output}: the reader closed the stream before the end; output incomplete") from None
        if _errno_of(exc) in WRITE_ERRNOS:  # full disk, file-size limit, read-only: name the output
            raise ProcessingError(f"{output}: cannot write: {_os_cause(exc)}; nothing was written") from None
        raise
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def _write_header(
    f: h5py.File, product_kind: str, radar: RadarMetadata, targets: np.ndarray, history: list[dict]
) -> None:
    f.attrs["product"] = product_kind
    f.attrs["sarproc_format"] = FORMAT_VERSION
    f.attrs["history"] = json.dumps(history)
    g = f.create_group("radar")
    for k, v in radar.to_attrs().items():
        g.attrs[k] = v
    t = as_target_table(targets)
    dset = f.create_dataset("targets", data=t)
    dset.attrs["long_name"] = "true point targets, carried from the scene"
    dset.attrs["field_units"] = json.dumps(TARGET_UNITS)
    # A labelled 'target' axis keeps netCDF readers (xarray/h5netcdf) from inventing phony dims.
    scale = f.create_dataset("target", data=np.arange(len(t), dtype=np.int64))
    scale.attrs["units"] = "1"
    scale.attrs["long_name"] = "target index"
    scale.make_scale("target")
    dset.dims[0].attach_scale(scale)


def _write_scales(f: h5py.File, dset: h5py.Dataset, dims: tuple[str, ...], coords: dict[str, np.ndarray]) -> None:
    for i, d in enumerate(dims):
        vals = np.asarray(coords[d])
        sc = f.create_dataset(d, data=vals.astype(np.float64) if d != "channel" else vals.astype(np.int64))
        sc.attrs["units"] = UNITS.get(d, "1")
        sc.attrs["long_name"] = LONG_NAMES.get(d, d)
        sc.make_scale(d)
        dset.dims[i].attach_scale(sc)
        dset.dims[i].label = d


def _write_aux(f: h5py.File, aux: dict) -> None:
    """Aux arrays under ``aux/`` with named dims (index scales in the group) and CF units."""
    g = f.create_group("aux")
    scales: dict[tuple[str, int], h5py.Dataset] = {}

    def scale(name: str, n: int) -> h5py.Dataset:
        key = (name, n)
        if key not in scales:
            dname = name if name not in g else f"{name}_{n}"
            sc = g.create_dataset(dname, data=np.arange(n, dtype=np.int64))
            sc.attrs["units"] = "1"
            sc.attrs["long_name"] = AUX_DIM_DOC.get(name, f"index along {name}")
            sc.make_scale(dname)
            scales[key] = sc
        return scales[key]

    for k, v in aux.items():
        arr = np.asarray(v)
        d = g.create_dataset(k, data=arr)
        dims, units, doc = AUX_LAYOUT.get(k, (None, None, None))
        if dims is None or len(dims) != arr.ndim:
            dims = tuple(f"{k}_axis{i}" for i in range(arr.ndim))
        if units is not None:
            d.attrs["units"] = units
        if doc:
            d.attrs["long_name"] = doc
        for i, name in enumerate(dims):
            d.dims[i].attach_scale(scale(name, arr.shape[i]))


def _chunks(shape: tuple[int, ...]) -> tuple[int, ...]:
    # About 4 MiB complex64 chunks, whole rows along the last axis.
    row = shape[-1]
    rows = max(1, min(int(np.prod(shape[:-1])), (4 << 20) // (8 * max(row, 1))))
    lead = [1] * (len(shape) - 1)
    if len(shape) >= 2:
        lead[-1] = min(shape[-2], rows)
    return tuple(lead) + (row,)


def _write_attrs(obj: h5py.HLObject, attrs: dict) -> None:
    for k, v in attrs.items():
        if isinstance(v, (dict, list)) and not (isinstance(v, list) and v and isinstance(v[0], (int, float))):
            v = json.dumps(v)
        obj.attrs[k] = v


class ProductWriter:
    """Stream a product's data in blocks along its first non-channel axis, atomically.

    Use as a context manager; the file appears at ``output`` only if the block exits cleanly.
    A write error (full disk, file-size limit, read-only file system) raises ProcessingError
    naming the output and the cause; the temporary file is removed either way.
    """

    def __init__(
        self,
        output: str | Path,
        kind: str,
        dims: tuple[str, ...],
        coords: dict[str, np.ndarray],
        radar: RadarMetadata,
        targets: np.ndarray,
        *,
        attrs: dict | None = None,
        aux: dict | None = None,
        history: Sequence[dict] = (),
        dtype: np.dtype | type = np.complex64,
        inputs: Sequence[str | Path] = (),
        overwrite: bool = False,
    ):
        if kind not in PRODUCT_KINDS:
            raise ValueError(f"unknown product kind {kind!r}")
        self.output = check_output_path(output, inputs, overwrite)
        self.overwrite = overwrite
        self.kind, self.dims, self.coords = kind, tuple(dims), coords
        self.shape = tuple(len(coords[d]) for d in self.dims)
        self._args = (radar, targets, list(history), attrs or {}, aux or {}, dtype)
        self.file: h5py.File | None = None

    @classmethod
    def like(
        cls,
        output: str | Path,
        header: Product,
        *,
        dtype: np.dtype | type = np.complex64,
        inputs: Sequence[str | Path] = (),
        overwrite: bool = False,
    ) -> ProductWriter:
        """A writer of ``header``'s grid, metadata and history (its data is not read)."""
        return cls(
            output,
            header.kind,
            header.dims,
            header.coords,
            header.radar,
            header.targets,
            attrs=header.attrs,
            aux=header.aux,
            history=header.history,
            dtype=dtype,
            inputs=inputs,
            overwrite=overwrite,
        )

    def _failed(self, exc: Exception) -> ProcessingError:
        # HDF5 cannot be trusted with this file any more: keep its objects alive, never close them.
        if self.file is not None:
            _DAMAGED.append((self.file, getattr(self, "dset", None)))
            self.file = None
        return ProcessingError(f"{self.output}: cannot write the product: {_os_cause(exc)}; nothing was written")

    def __enter__(self) -> ProductWriter:
        self._ctx = atomic_path(self.output, overwrite=self.overwrite)
        tmp = self._ctx.__enter__()
        radar, targets, history, attrs, aux, dtype = self._args
        try:
            self.file = h5py.File(tmp, "w")
            _write_header(self.file, self.kind, radar, targets, history)
            self.dset = self.file.create_dataset(
                DATA_NAME[self.kind], shape=self.shape, dtype=dtype, chunks=_chunks(self.shape)
            )
            self.dset.attrs["units"] = "1"  # complex amplitude, arbitrary (uncalibrated) scale
            self.dset.attrs["long_name"] = (
                "complex baseband echo samples" if DATA_NAME[self.kind] == "signal" else "complex image"
            )
            _write_attrs(self.dset, attrs)
            known = {k: DATA_ATTR_UNITS[k] for k in attrs if k in DATA_ATTR_UNITS}
            if known:
                self.dset.attrs["attribute_units"] = json.dumps(known)
            _write_scales(self.file, self.dset, self.dims, self.coords)
            if aux:
                _write_aux(self.file, aux)
        except (OSError, RuntimeError) as exc:  # h5py reports some failed writes as RuntimeError
            err = self._failed(exc)
            self._ctx.__exit__(type(err), err, None)
            raise err from None
        except BaseException as exc:
            self._close_quietly()
            self._ctx.__exit__(type(exc), exc, exc.__traceback__)
            raise
        return self

    def write(self, index: tuple[slice, ...] | EllipsisType, block: np.ndarray) -> None:
        run.check()  # a stop signal whose exception HDF5 swallowed ends the run at the next block
        try:
            self.dset[index] = block
        except (OSError, RuntimeError) as exc:
            raise self._failed(exc) from None

    def _close_quietly(self) -> None:
        if self.file is not None:
            f, self.file = self.file, None
            try:
                f.close()
            except (OSError, RuntimeError):
                _DAMAGED.append((f, getattr(self, "dset", None)))

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> bool | None:
        if exc_type is None:
            assert self.file is not None  # open from __enter__ until closed here
            try:
                self.file.close()
                self.file = None
            except (OSError, RuntimeError) as err:
                failure = self._failed(err)
                self._ctx.__exit__(type(failure), failure, None)
                raise failure from None
        else:
            self._close_quietly()
        return self._ctx.__exit__(exc_type, exc, tb)


class WriteBehind:
    """Store a :class:`ProductWriter`'s blocks on a second thread while the caller computes the next ones.

    ``write`` queues a block (at most ``depth`` wait, so memory stays bounded) and returns; the blocks
    are written in the order given. The first error of the writing thread (a full disk, a stop signal seen
    by ``run.check``) is raised by the next ``write`` or on leaving; an error in the caller drops the
    queued blocks and waits for the block being written, so the writer is closed by one thread only.
    The overlap needs the caller's compute to release the GIL (numpy, nogil numba kernels).
    """

    _DONE = object()

    def __init__(self, writer: ProductWriter, depth: int = 1) -> None:
        import queue
        import threading

        self.writer = writer
        self._queue: queue.Queue = queue.Queue(maxsize=depth)
        self._error: BaseException | None = None
        self._abort = threading.Event()
        self._thread = threading.Thread(target=self._drain, name="sarproc-write-behind", daemon=True)

    def _drain(self) -> None:
        while True:
            item = self._queue.get()
            if item is self._DONE:
                return
            if self._error is not None or self._abort.is_set():
                continue  # keep taking blocks so the caller never waits on a dead writer
            try:
                self.writer.write(*item)
            except BaseException as exc:  # handed to the caller's thread
                self._error = exc

    def _raise_error(self) -> None:
        if self._error is not None:
            raise self._error

    def write(self, index: Any, block: np.ndarray) -> None:
        """Queue ``block`` for ``writer.write(index, block)``; the caller must not change it afterwards."""
        self._raise_error()
        # Deferred: a stop signal raised inside Queue.put can leave the queue's condition with a stale waiter
        # (threading's primitives are not signal-safe), and the writer thread then never sees the end marker.
        # The wait is at most one block's write.
        with run.deferred():
            self._queue.put((index, block))

    def __enter__(self) -> WriteBehind:
        self._thread.start()
        return self

    def __exit__(self, exc_type: type | None, exc: BaseException | None, tb: Any) -> None:
        if exc_type is not None:
            self._abort.set()
        with run.deferred():  # a stop signal now is acted on once the thread has let go of the file
            self._queue.put(self._DONE)
            self._thread.join()
        if exc_type is None:
            self._raise_error()


def write_product(
    output: str | Path, product: Product, *, inputs: Sequence[str | Path] = (), overwrite: bool = False
) -> Path:
    """Write ``product`` to ``output`` atomically."""
    dtype = np.complex64 if np.iscomplexobj(product.data) else product.data.dtype
    with ProductWriter.like(output, product, dtype=dtype, inputs=inputs, overwrite=overwrite) as w:
        w.write(Ellipsis, product.data)
    return Path(output)


_INTERNAL_ATTRS = ("DIMENSION_LIST", "REFERENCE_LIST", "CLASS", "NAME", "units", "long_name", "attribute_units")


def _attr_value(v: Any) -> Any:
    if isinstance(v, bytes):
        v = v.decode()
    if isinstance(v, str) and v[:1] in "[{":
        try:
            return json.loads(v)
        except json.JSONDecodeError:
            return v
    if isinstance(v, np.generic):
        return v.item()
    if isinstance(v, np.ndarray) and v.ndim == 1 and v.dtype.kind in "fiu":
        return v.tolist()  # the same list an in-memory product carries
    return v


def read_product(
    path: str | Path, kinds: tuple[str, ...] | None = None, *, load: bool = True, check_finite: bool = True
) -> Product:
    """Read a product; see :func:`_read_product`. Low-level HDF5 errors become InputError."""
    try:
        return _read_product(path, kinds, load=load, check_finite=check_finite)
    except (OSError, RuntimeError, KeyError, TypeError, ValueError) as exc:
        if isinstance(exc, InputError):
            raise
        if isinstance(exc, PermissionError) or _errno_of(exc) in (_errno.EACCES, _errno.EPERM):
            # a file, or a directory on its path, this user may not read (session 43 row 11: it was called
            # "damaged or non-conforming")
            raise InputError(f"{path}: cannot read it: {_os_cause(exc)}") from None
        raise InputError(f"{path}: damaged or non-conforming product: {' '.join(str(exc).split())[:300]}") from None


def _is_scale(dset: h5py.Dataset) -> bool:
    cls = dset.attrs.get("CLASS")
    return (cls.decode() if isinstance(cls, bytes) else cls) == "DIMENSION_SCALE"


def _check_aux(path: Path, aux: dict, kind: str, n_pulses: int | None, n_channels: int | None) -> None:
    """Aux arrays: numeric, finite, and shaped like the product they travel with."""
    for k, v in aux.items():
        where = f"{path}: dataset 'aux/{k}'"
        if v.dtype.kind not in "fiuc":
            raise InputError(f"{where} must be numeric, got {v.dtype}")
        if not np.all(np.isfinite(v)):
            raise InputError(f"{where} contains NaN or Inf")
        dims = AUX_LAYOUT.get(k, (None,))[0]
        if dims is None:
            continue
        if v.ndim != len(dims) or (dims[-1] == "xyz" and v.shape[-1] != 3):
            want = " x ".join("3" if d == "xyz" else f"n_{d}" for d in dims)
            raise InputError(f"{where} has shape {v.shape}, expected ({want})")
        if dims[-1] == "moving_target_field" and v.shape[-1] != len(MOVING_TARGET_COLUMNS):
            raise InputError(
                f"{where} has {v.shape[-1]} columns, expected {len(MOVING_TARGET_COLUMNS)} "
                "(sarproc.product.model.MOVING_TARGET_COLUMNS)"
            )
        if dims[0] == "pulse" and n_pulses is not None and len(v) != n_pulses:
            raise InputError(
                f"{where} has {len(v)} rows but the product has {n_pulses} pulses (azimuth_time); "
                "one row per pulse is needed"
            )
        if dims[0] == "receiver" and n_channels is not None and len(v) != n_channels:
            raise InputError(f"{where} has {len(v)} receivers but the signal has {n_channels} channels")


@dataclasses.dataclass(frozen=True)
class _Header:
    """A product file's root attributes and radar group."""

    kind: str  # product type (PRODUCT_KINDS)
    history: list  # processing history entries
    radar: RadarMetadata


def _open_hdf5(path: Path) -> h5py.File:
    """The file opened for reading; a missing, unreadable or non-HDF5 path is refused by name."""
    if not path.exists():
        raise InputError(f"{path}: file not found")
    if path.is_dir():
        raise InputError(f"{path}: is a directory, expected an HDF5 product")
    if not os.access(path, os.R_OK):
        raise InputError(f"{path}: not readable (permission denied)")
    if not h5py.is_hdf5(path):
        raise InputError(f"{path}: not an HDF5 file")
    try:
        return h5py.File(path, "r")
    except OSError as exc:
        raise InputError(f"{path}: cannot open as HDF5: {exc}") from None


def _read_header(f: h5py.File, path: Path, kinds: tuple[str, ...] | None) -> _Header:
    """Product type (one of ``kinds`` if given), format version, history and radar metadata."""
    kind = _attr_value(f.attrs.get("product"))
    if kind is None:
        raise InputError(f"{path}: missing root attribute 'product' (not a sarproc product)")
    if not isinstance(kind, str) or kind not in PRODUCT_KINDS:
        raise InputError(f"{path}: root attribute 'product' is {kind!r}, not one of {list(PRODUCT_KINDS)}")
    if kinds is not None and kind not in kinds:
        raise InputError(f"{path}: product type is {kind!r}; this stage needs {' or '.join(map(repr, kinds))}")
    fmt = _attr_value(f.attrs.get("sarproc_format"))
    if fmt is None:
        raise InputError(f"{path}: missing root attribute 'sarproc_format'")
    if str(fmt) != FORMAT_VERSION:
        raise InputError(f"{path}: sarproc_format {fmt!r} is not supported (expected {FORMAT_VERSION!r})")
    history = _attr_value(f.attrs.get("history", "[]"))
    if not isinstance(history, list):
        raise InputError(f"{path}: root attribute 'history' is not a JSON list")
    if "radar" not in f or not isinstance(f["radar"], h5py.Group):
        raise InputError(f"{path}: missing group 'radar'")
    return _Header(kind, history, RadarMetadata.from_attrs(f["radar"].attrs, where=f"{path}: radar"))


def _signal_dataset(f: h5py.File, path: Path, kind: str) -> h5py.Dataset:
    """The product's complex signal dataset, with the number of dims its type needs."""
    name = DATA_NAME[kind]
    if name not in f or not isinstance(f[name], h5py.Dataset):
        raise InputError(f"{path}: missing dataset {name!r}")
    dset = f[name]
    if dset.dtype.kind != "c":
        raise InputError(
            f"{path}: dataset {name!r} is {dset.dtype} but must be complex (I/Q, complex64); "
            "real-valued samples cannot be focused; convert them to complex baseband"
        )
    if dset.ndim != len(KIND_DIMS[kind]):
        raise InputError(
            f"{path}: dataset {name!r} has {dset.ndim} dims {dset.shape}; a {kind!r} product needs "
            f"{len(KIND_DIMS[kind])} dims {KIND_DIMS[kind]}"
        )
    return dset


def _read_axes(dset: h5py.Dataset, path: Path, kind: str, radar: RadarMetadata) -> tuple[list, dict]:
    """(dims, coords) from the dataset's dimension scales: 1-D, finite, strictly increasing (channels
    excepted), one value per sample, in the order the product type needs."""
    name = DATA_NAME[kind]
    dims, coords = [], {}
    for i, dim in enumerate(dset.dims):
        if len(dim) == 0:
            raise InputError(f"{path}: dataset {name!r} axis {i} has no dimension scale attached")
        scale = dim[0]
        dname = scale.name.lstrip("/")
        values = scale[()]
        if np.ndim(values) != 1 or np.asarray(values).dtype.kind not in "fiu":
            raise InputError(f"{path}: dimension scale {dname!r} must be a 1-D numeric array")
        if len(values) != dset.shape[i]:
            raise InputError(
                f"{path}: dataset {name!r} has {dset.shape[i]} samples along {dname!r} but the "
                f"dimension scale {dname!r} holds {len(values)} values; they must agree"
            )
        if not np.all(np.isfinite(values)):
            raise InputError(f"{path}: dimension scale {dname!r} contains NaN or Inf")
        if dname != "channel" and len(values) > 1 and not np.all(np.diff(values) > 0):
            raise InputError(f"{path}: dimension scale {dname!r} must increase strictly")
        dims.append(dname)
        coords[dname] = values
    if tuple(dims) != KIND_DIMS[kind]:
        raise InputError(f"{path}: dataset {name!r} has dims {tuple(dims)}; a {kind!r} product needs {KIND_DIMS[kind]}")
    if "channel" in dims and len(coords["channel"]) != radar.n_channels:
        raise InputError(
            f"{path}: dataset {name!r} has {len(coords['channel'])} channels but radar attribute "
            f"'n_channels' is {radar.n_channels}"
        )
    return dims, coords


def _read_targets(f: h5py.File, path: Path) -> np.ndarray:
    """The targets table, completed to TARGET_DTYPE (theory fields of older files: 0, not recorded), with
    finite positions and valid theory fields."""
    if "targets" not in f:
        raise InputError(f"{path}: missing dataset 'targets'")
    targets = np.asarray(f["targets"][()])
    missing = [
        n for n in TARGET_DTYPE.names or () if n not in (targets.dtype.names or ()) and n not in TARGET_THEORY_FIELDS
    ]  # theory fields are optional (older files): 0, not recorded
    if missing:
        raise InputError(f"{path}: dataset 'targets' lacks field(s) {missing}")
    targets = as_target_table(targets)
    for field in ("x", "y", "z", "azimuth", "range", "elevation"):
        if not np.all(np.isfinite(targets[field])):
            raise InputError(f"{path}: dataset 'targets' field {field!r} contains NaN or Inf")
    for field in TARGET_IRW_FIELDS:
        v = targets[field]
        if not np.all(np.isfinite(v) & (v >= 0)):
            raise InputError(f"{path}: dataset 'targets' field {field!r} must be a positive IRW or 0 (not recorded)")
    for field in TARGET_NULL_FIELDS:
        v = targets[field]
        if not np.all(np.isfinite(v) & (v >= 0)):
            raise InputError(
                f"{path}: dataset 'targets' field {field!r} must be a positive null spacing or 0 (not recorded)"
            )
    v = targets[TARGET_RIDGE_FIELD]
    if not np.all(np.isfinite(v) & (v >= 0) & (v <= 90)):
        raise InputError(
            f"{path}: dataset 'targets' field {TARGET_RIDGE_FIELD!r} must be an angle in [0, 90] deg (0: not recorded)"
        )
    for field in TARGET_SIDELOBE_FIELDS:  # a PSLR is <= 0 dB; an ISLR may exceed it (side lobes only)
        v = targets[field]
        if not np.all(np.isfinite(v) & ((v <= 0) if field.startswith("pslr") else True)):
            raise InputError(
                f"{path}: dataset 'targets' field {field!r} must be a finite level in dB"
                f"{' <= 0' if field.startswith('pslr') else ''} (0: not recorded)"
            )
    return targets


def _read_data_attrs(dset: h5py.Dataset, path: Path, kind: str, dims: list) -> dict:
    """The signal dataset's own attributes, with numeric ones finite and an image's frame and theoretical
    IRW well formed."""
    name = DATA_NAME[kind]
    attrs = {k: _attr_value(v) for k, v in dset.attrs.items() if k not in _INTERNAL_ATTRS}
    for key in DATA_ATTR_UNITS:
        v = attrs.get(key)
        values = v if isinstance(v, list) else [v]
        if v is not None and not all(
            isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) for x in values
        ):
            raise InputError(
                f"{path}: dataset {name!r} attribute {key!r} must be a finite number or list of "
                f"numbers ({DATA_ATTR_UNITS[key]}), got {v!r}"
            )
    if kind in ("image", "image3d"):
        frame = attrs.get("frame")
        if not (isinstance(frame, dict) and isinstance(frame.get("name"), str)):
            raise InputError(f"{path}: dataset {name!r} attribute 'frame' must be a JSON object with a 'name'")
        irw = attrs.get("theoretical_irw")
        if irw is not None and not (
            isinstance(irw, list)
            and len(irw) == len(dims)
            and all(isinstance(x, (int, float)) and math.isfinite(x) and x > 0 for x in irw)
        ):
            raise InputError(
                f"{path}: dataset {name!r} attribute 'theoretical_irw' must list {len(dims)} "
                f"positive widths (one per axis {tuple(dims)}), got {irw!r}"
            )
    return attrs


def _read_aux(f: h5py.File, path: Path, kind: str, coords: dict, radar: RadarMetadata) -> dict:
    """The aux group's per-pulse / per-receiver arrays (scales left out), their shapes checked."""
    aux = {}
    if "aux" in f:
        for k, v in f["aux"].items():
            if isinstance(v, h5py.Dataset) and not _is_scale(v):
                aux[k] = v[()]
    n_pulses = len(coords["azimuth_time"]) if kind in ("raw", "raw_multichannel", "raw_array", "preprocessed") else None
    _check_aux(path, aux, kind, n_pulses, len(coords["channel"]) if "channel" in coords else radar.n_channels)
    return aux


def _read_signal(dset: h5py.Dataset, path: Path, check_finite: bool) -> np.ndarray:
    """The signal samples, refused if any is NaN or Inf (``check_finite``)."""
    data = dset[()]
    if check_finite and not np.all(np.isfinite(data)):
        bad = int(np.count_nonzero(~np.isfinite(data)))
        raise InputError(f"{path}: dataset {dset.name.lstrip('/')!r} contains {bad} NaN or Inf value(s)")
    return data


def _read_product(
    path: str | Path, kinds: tuple[str, ...] | None = None, *, load: bool = True, check_finite: bool = True
) -> Product:
    """Read a product; ``kinds`` restricts the accepted product types (the error names them).

    With ``load=False`` only metadata is read: ``data`` is an empty array of the right dtype
    and ``attrs['shape']`` holds the stored shape (cheap inspection of big files). Every check
    of the layout (dims, scales, dtypes, attribute types, aux shapes) runs in both modes.
    """
    path = Path(path)
    with _open_hdf5(path) as f:
        header = _read_header(f, path, kinds)
        dset = _signal_dataset(f, path, header.kind)
        dims, coords = _read_axes(dset, path, header.kind, header.radar)
        targets = _read_targets(f, path)
        attrs = _read_data_attrs(dset, path, header.kind, dims)
        aux = _read_aux(f, path, header.kind, coords, header.radar)
        if load:
            data = _read_signal(dset, path, check_finite)
        else:
            data = np.empty((0,) * dset.ndim, dtype=dset.dtype)
            attrs["shape"] = dset.shape
    fields: dict[str, Any] = dict(
        kind=header.kind,
        data=data,
        dims=tuple(dims),
        coords=coords,
        radar=header.radar,
        targets=targets,
        attrs=attrs,
        aux=aux,
        history=header.history,
    )
    if not load:  # no shape checks against the empty data array
        prod = Product.__new__(Product)
        prod.__dict__.update(fields)
        return prod
    return Product(**fields)


# Complex bytes a magnitude preview reads at a time. Its peak is ~2.5x this (h5py's read buffer, the block, its
# float32 magnitude; traced: 42 MB for 16.8 MB blocks of the du2010 cube) plus the preview; at 64 MiB a 49 MB
# cube was read whole
PREVIEW_BLOCK_BYTES = 16 << 20


def preview_shape(shape: tuple[int, ...], max_side: int) -> tuple[tuple[int, ...], tuple[int, ...]]:
    """(per-axis reduction factors, preview shape) of :func:`read_magnitude_preview` for an image of ``shape``."""
    factors = tuple(max(1, -(-n // max_side)) for n in shape)
    return factors, tuple(-(-n // f) for n, f in zip(shape, factors))


def read_magnitude_preview(
    path: str | Path, max_side: int = 2048, block_bytes: int = PREVIEW_BLOCK_BYTES, header: Product | None = None
) -> tuple[np.ndarray, tuple[str, ...], dict[str, np.ndarray], tuple[int, ...]]:
    """Peak-preserving preview of an image product's magnitude, read in blocks.

    Every axis longer than ``max_side`` is reduced by an integer factor, each output pixel
    being the *maximum* |pixel| of its block, so a point target of one pixel survives any
    reduction (a mean would dilute it). Returns ``(magnitude float32, dims, coords, factors)``;
    ``coords`` are the block centres. Memory stays at one block of ``block_bytes`` plus the
    preview, so a picture of an image larger than memory can be drawn.
    """
    if header is None:  # a caller that has read the header already passes it
        header = read_product(path, kinds=("image", "image3d"), load=False)
    dims = header.dims
    shape = tuple(len(header.coords[d]) for d in dims)
    factors, out_shape = preview_shape(shape, max_side)
    preview = np.zeros(out_shape, dtype=np.float32)
    row_bytes = 8 * int(np.prod(shape[1:], dtype=np.int64))
    rows = max(factors[0], (block_bytes // max(row_bytes, 1)) // factors[0] * factors[0])
    with h5py.File(path, "r") as f:
        dset = f[DATA_NAME[header.kind]]
        for start in range(0, shape[0], rows):
            block = np.abs(dset[start : start + rows]).astype(np.float32, copy=False)
            block[~np.isfinite(block)] = 0.0
            start_out = start // factors[0]
            pooled = _max_pool(block, factors)
            preview[start_out : start_out + pooled.shape[0]] = pooled
    coords = {d: _block_centres(np.asarray(header.coords[d], dtype=float), f) for d, f in zip(dims, factors)}
    return preview, dims, coords, factors


def _max_pool(block: np.ndarray, factors: tuple[int, ...]) -> np.ndarray:
    # Zero-pad every axis to a whole number of blocks (|x| >= 0, so padding never wins a maximum),
    # then take the maximum over each block.
    pad = [(0, -n % f) for n, f in zip(block.shape, factors)]
    if any(p for _, p in pad):
        block = np.pad(block, pad)
    shape = []
    for n, f in zip(block.shape, factors):
        shape += [n // f, f]
    return block.reshape(shape).max(axis=tuple(range(1, 2 * block.ndim, 2)))


def _block_centres(values: np.ndarray, factor: int) -> np.ndarray:
    if factor == 1:
        return values
    ends = np.minimum(np.arange(0, len(values), factor) + factor, len(values)) - 1
    starts = np.arange(0, len(values), factor)
    return 0.5 * (values[starts] + values[ends])
