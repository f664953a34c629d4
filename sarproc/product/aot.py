"""Ahead-of-time compiled kernels: a stage on a small product runs them without importing numba.

A process that uses numba pays for it before any work: ``import numba`` (~0.15-0.2 s over numpy), loading each
cached kernel (~0.01 s each, ~0.04 s for the first) and starting the threading layer (~0.02 s)
(docs/performance.md, "Per-process overhead"). A module of kernels compiled ahead of time by ``numba.pycc``
(serial variants of the same source: pycc has no parallel loops) loads in about a millisecond, without numba.

The module is built on first use, in the background: the first process runs the numba kernels as before and
starts ``python -m <builder>``, which compiles the serial variants with the C compiler into the user's cache
(``$SARPROC_AOT_DIR``, else ``$XDG_CACHE_HOME/sarproc/aot``, else ``~/.cache/sarproc/aot``); later processes load
it. The file name carries a key of the kernels' source files, the Python and numba installs and the CPU (the
code is compiled for the host's instruction set), so an edit, an upgrade or another machine sharing the home
directory builds its own. Without a C compiler (or when the build fails for any reason) a marker records the
failure and every run keeps using numba; nothing is retried until the key changes. ``SARPROC_AOT=0`` turns
the whole mechanism off (the numba kernels only). This module imports no numba; only the builder does.
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import importlib
import importlib.machinery
import importlib.util
import os
import platform
import stat
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from types import ModuleType
from typing import Any

_LOADED: dict[str, ModuleType | None] = {}
_SERIAL_SPENT = 0.0  # serial seconds of the compiled calls so far (Kernels.pick)
OLD_MODULE_S = 30 * 86400.0
STALE_LOCK_S = 900.0  # a build lock older than this is from a builder that died (a build takes ~10-30 s)
# What a process saves by not starting numba: import, kernel loads, threads (docs/performance.md, s).
NUMBA_STARTUP_S = 0.3
PACKAGE = Path(__file__).parents[1]  # sarproc/


def available_threads() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def serial_pays(serial_seconds: float, workers: int | None = None) -> bool:
    """Whether a serial kernel expected to take ``serial_seconds``, numba not started, finishes first: what
    the parallel kernel saves on ``workers`` threads (default: the CPUs this process may use; 90 % efficient)
    is less than numba's start-up."""
    threads = int(workers) if workers else available_threads()
    return serial_seconds * (1.0 - 1.0 / max(1.0, 0.9 * threads)) < NUMBA_STARTUP_S


@dataclasses.dataclass(frozen=True)
class Kernels:
    """A module of numba kernels (``module``) and its exports compiled ahead of time (module file ``name``).

    ``sources``: the files, relative to the sarproc package, whose edits change the kernels (the kernel module
    and what its kernels inline); ``exports``: export name -> pycc signature of the kernel of that name in
    ``module``, or -> (kernel name, signature) for a second signature of a kernel (C-contiguous arrays: the
    callers pass such); ``owner``: the importable, numba-free ``module:attribute`` naming this
    object, which the background builder imports (``python -m sarproc.product.aot OWNER KEY``); ``slp``:
    compile with LLVM's SLP vectoriser as the numba kernels are (``kernel_cache.slp_vectorized``).
    """

    name: str
    module: str
    sources: tuple[str, ...]
    exports: dict[str, str | tuple[str, str]]
    owner: str
    slp: bool = False

    @property
    def source_paths(self) -> list[Path]:
        return [PACKAGE / s for s in self.sources]

    def load(self) -> ModuleType | None:
        """The compiled module, or None while it is not built (or building is off, or it failed)."""
        if self.name in _LOADED:  # decided once per process: no paths made on every kernel call
            return _LOADED[self.name]
        return load(self.name, self.source_paths)

    def request_build(self) -> bool:
        return request_build(self.name, self.source_paths, "sarproc.product.aot", self.owner)

    def numba(self) -> ModuleType:
        """The numba kernels' module (imports numba)."""
        return importlib.import_module(self.module)

    def pick(self, serial_seconds: float, workers: int | None = None, *, usable: bool = True) -> ModuleType:
        """The module to call the kernels from for a call of ``serial_seconds`` of serial work.

        The compiled module while the serial work of this process's compiled calls so far, this one included,
        stays small enough that running it serially without numba's start-up finishes first
        (:func:`serial_pays`; so a big product's many small block calls do not all run serially: past that
        budget they go to numba), it is built, numba's kernels of this module are not loaded already, and
        ``usable`` (the caller's arguments have the exported types); else the numba kernels, and for a small
        call a build is started in the background for the next process. Both run the same source (prange as
        range), so the results agree.
        """
        global _SERIAL_SPENT
        if usable and serial_pays(_SERIAL_SPENT + serial_seconds, workers):
            module = self.load()
            if module is None:
                self.request_build()  # also where numba's kernels are loaded (e.g. by the plan's cache check)
            elif self.module not in sys.modules:
                _SERIAL_SPENT += serial_seconds
                return module
        return self.numba()

    def is_compiled(self, module: ModuleType) -> bool:
        """Whether ``module`` (from :meth:`pick`) is the module compiled ahead of time."""
        return module.__name__ != self.module

    def build(self, key: str) -> Path:
        """Compile the module for ``key`` (which must be the current sources' key)."""
        if key != module_key(self.source_paths):
            release_lock()
            raise RuntimeError(f"stale build request {key}: the kernels' sources changed")
        kernels = self.numba()
        exports = {}
        for export, spec in self.exports.items():
            kernel, sig = (export, spec) if isinstance(spec, str) else spec
            exports[export] = (getattr(kernels, kernel), sig)
        if not self.slp:
            return build(self.name, key, exports)
        from sarproc.product.kernel_cache import slp_vectorized

        with slp_vectorized():
            return build(self.name, key, exports)


def owner_kernels(owner: str) -> Kernels:
    """The :class:`Kernels` named by ``owner`` (``module:attribute``)."""
    module, _, attr = owner.partition(":")
    obj = getattr(importlib.import_module(module), attr)
    if not isinstance(obj, Kernels):
        raise TypeError(f"{owner} is not a Kernels")
    return obj


def enabled() -> bool:
    return os.environ.get("SARPROC_AOT", "1").strip().lower() not in ("0", "no", "false", "off")


def cache_dir() -> Path:
    if os.environ.get("SARPROC_AOT_DIR"):
        return Path(os.environ["SARPROC_AOT_DIR"])
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "sarproc" / "aot"


def _private_dir(path: Path, create: bool) -> bool:
    """Whether ``path`` is a directory of this user that nobody else can write (code loaded from it runs)."""
    try:
        if create:
            path.mkdir(mode=0o700, parents=True, exist_ok=True)
        st = os.lstat(path)
    except OSError:
        return False
    if not stat.S_ISDIR(st.st_mode) or st.st_mode & 0o022:
        return False
    return not hasattr(os, "getuid") or st.st_uid == os.getuid()


def _cpu_fingerprint() -> str:
    """The host CPU's model and feature flags (the module is compiled for them); '' where unknown (then no
    module is built or loaded: a home directory shared with another machine must not hand it foreign code)."""
    try:
        text = Path("/proc/cpuinfo").read_text()
    except OSError:  # not Linux: no fingerprint, no module (platform.processor() names only the family)
        return ""
    keep = [line for line in text.splitlines() if line.startswith(("model name", "flags", "Features", "CPU part"))]
    return "\n".join(dict.fromkeys(keep))  # the first CPU's lines (all cores alike)


def module_key(sources: list[Path]) -> str:
    """A key of the kernels' sources, this builder, Python, numba's install and the CPU (16 hex digits)."""
    h = hashlib.sha256()
    for path in [*sources, Path(__file__)]:
        h.update(Path(path).read_bytes())
    h.update(sys.version.encode())
    h.update(platform.machine().encode())
    spec = importlib.util.find_spec("numba")  # the package is found, not imported
    if spec is None or spec.origin is None:
        raise RuntimeError("numba is not installed")
    for name in ("__init__.py", "_version.py"):
        st = os.stat(Path(spec.origin).parent / name)
        h.update(f"{name}:{st.st_size}:{st.st_mtime_ns}".encode())
    cpu = _cpu_fingerprint()
    if not cpu:
        raise RuntimeError("unknown CPU: a module compiled for the host could run on another")
    h.update(cpu.encode())
    return h.hexdigest()[:16]


def module_name(name: str, key: str) -> str:
    return f"_{name}_aot_{key}"


def module_path(name: str, key: str) -> Path:
    return cache_dir() / (module_name(name, key) + importlib.machinery.EXTENSION_SUFFIXES[0])


def load(name: str, sources: list[Path]) -> ModuleType | None:
    """The compiled module of kernels ``name`` for these sources, or None (disabled, not built yet, or not
    loadable). Decided once per process."""
    if name in _LOADED:
        return _LOADED[name]
    module = None
    if enabled():
        try:
            key = module_key(sources)
            path = module_path(name, key)
            if path.exists() and _private_dir(path.parent, create=False):
                loader = importlib.machinery.ExtensionFileLoader(module_name(name, key), str(path))
                spec = importlib.util.spec_from_file_location(module_name(name, key), path, loader=loader)
                if spec is not None:
                    module = importlib.util.module_from_spec(spec)
                    loader.exec_module(module)
        except (OSError, ImportError, RuntimeError):
            module = None
    _LOADED[name] = module
    return module


def request_build(name: str, sources: list[Path], builder: str, *builder_args: str) -> bool:
    """Start ``python -m builder [builder_args] KEY`` in the background to build module ``name`` unless it
    exists, failed before, is being built, or building is off; True when a build was started."""
    if not enabled():
        return False
    try:
        key = module_key(sources)
    except (OSError, RuntimeError):
        return False
    path = module_path(name, key)
    failed = path.with_suffix(".failed")
    lock = path.with_suffix(".lock")
    if path.exists() or failed.exists() or not _private_dir(path.parent, create=True):
        return False
    try:
        if time.time() - os.stat(lock).st_mtime > STALE_LOCK_S:
            os.unlink(lock)
    except OSError:
        pass
    try:
        os.close(os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o600))
    except OSError:
        return False  # another process is building it
    try:
        subprocess.Popen(
            [sys.executable, "-m", builder, *builder_args, key],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            start_new_session=True,
            env={**os.environ, "SARPROC_AOT_LOCK": str(lock)},
        )
    except OSError:
        os.unlink(lock)
        return False
    return True


def build(name: str, key: str, exports: dict[str, tuple[Any, str]]) -> Path:
    """Compile ``exports`` (export name -> (numba dispatcher, signature string)) into module ``name``'s file
    for ``key``: each a serial variant of the dispatcher's Python function with its fastmath and error model
    (pycc compiles no parallel loops: prange runs as range), compiled for the host CPU, releasing the GIL while
    it runs (so a caller can spread a kernel's independent parts over threads). Written to a temporary
    directory and moved into place, so a reader never sees half a file; a failure leaves a ``.failed`` marker
    with the error."""
    path = module_path(name, key)
    failed = path.with_suffix(".failed")
    try:
        import tempfile
        import warnings

        import numba
        from numba.core import sigutils

        with warnings.catch_warnings():  # "pending deprecation; replacement being developed": still in numba
            warnings.simplefilter("ignore", numba.NumbaPendingDeprecationWarning)
            from numba.pycc import CC, compiler as pycc_compiler

        class _ReleasingFlags(pycc_compiler.Flags):
            """pycc's compile flags with the GIL released around each call (numba's ``nogil``), which CC does
            not expose: the exports take and return arrays only, and a caller may run them on threads."""

            def __init__(self, *args: Any, **kwargs: Any) -> None:
                super().__init__(*args, **kwargs)
                self.release_gil = True

        flags = pycc_compiler.Flags
        pycc_compiler.Flags = _ReleasingFlags  # what pycc's module compiler makes its flags from
        with tempfile.TemporaryDirectory(dir=path.parent) as tmp, _restored(pycc_compiler, "Flags", flags):
            cc = CC(module_name(name, key))
            cc.output_dir = tmp
            cc.target_cpu = "host"
            cc.verbose = False
            for export, (dispatcher, signature) in exports.items():
                options = {k: v for k, v in dispatcher.targetoptions.items() if k in ("fastmath", "error_model")}
                serial = numba.njit(**options)(dispatcher.py_func)
                n_args = len(sigutils._parse_signature_string(signature).args)
                args = ", ".join(f"a{i}" for i in range(n_args))
                namespace = {"serial": serial}
                exec(f"def {export}({args}):\n    return serial({args})\n", namespace)
                cc.export(export, signature)(namespace[export])
            cc.compile()
            built = Path(tmp) / path.name
            os.chmod(built, 0o700)
            os.replace(built, path)
        for other in path.parent.glob(f"_{name}_aot_*"):  # other keys' modules, unused for a month: old sources
            with contextlib.suppress(OSError):
                if other != path and time.time() - other.stat().st_atime > OLD_MODULE_S:
                    other.unlink()
    except Exception as exc:
        failed.write_text(f"{type(exc).__name__}: {exc}\n")
        raise
    finally:
        release_lock()
    return path


@contextlib.contextmanager
def _restored(obj: Any, attr: str, value: Any) -> Iterator[None]:
    try:
        yield
    finally:
        setattr(obj, attr, value)


def release_lock() -> None:
    """Remove the build lock the starting process handed to this builder (``SARPROC_AOT_LOCK``)."""
    lock = os.environ.get("SARPROC_AOT_LOCK")
    if lock:
        with contextlib.suppress(OSError):
            os.unlink(lock)


@contextlib.contextmanager
def private_numba_cache() -> Iterator[None]:
    """numba's cache in a throwaway directory for the block; must be entered before any kernel module is imported.

    The builder compiles the kernels' callees (interpolation weights, phasors ...) through their own cached
    dispatchers. Written to the user's numba cache, those entries differ in the last bits from what a plain
    process compiles (measured: quality.kernels.ideal_response_box compiled after a build differed in 176 of 240
    values, by up to 7e-17, from a fresh compile), so every later numba run would depend on whether a build had
    run first. Read from it, the module would be built from whatever the cache holds."""
    import tempfile

    previous = os.environ.get("NUMBA_CACHE_DIR")
    with tempfile.TemporaryDirectory(prefix="sarproc-aot-numba-") as private:
        os.environ["NUMBA_CACHE_DIR"] = private
        numba_config = sys.modules.get("numba.core.config")
        if numba_config is not None:  # numba already imported: its config was read from the environment then
            numba_config.CACHE_DIR = private  # type: ignore[attr-defined]
        try:
            yield
        finally:
            if previous is None:
                os.environ.pop("NUMBA_CACHE_DIR", None)
            else:
                os.environ["NUMBA_CACHE_DIR"] = previous
            if numba_config is not None:
                numba_config.CACHE_DIR = previous or ""  # type: ignore[attr-defined]


def main(argv: list[str]) -> None:
    """The background builder: ``python -m sarproc.product.aot OWNER KEY``, with its own numba cache."""
    from sarproc.product import aot  # the importable module: this file runs as __main__, the owners use that one

    with aot.private_numba_cache():
        try:
            kernels = aot.owner_kernels(argv[0])
        except Exception:
            aot.release_lock()  # no Kernels, no name for a .failed marker: the next small run tries again
            raise
        kernels.build(argv[1])


if __name__ == "__main__":
    main(sys.argv[1:])
