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
import hashlib
import importlib.machinery
import importlib.util
import os
import platform
import stat
import subprocess
import sys
import time
from pathlib import Path
from types import ModuleType
from typing import Any

_LOADED: dict[str, ModuleType | None] = {}
OLD_MODULE_S = 30 * 86400.0
STALE_LOCK_S = 900.0  # a build lock older than this is from a builder that died (a build takes ~10-30 s)


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


def request_build(name: str, sources: list[Path], builder: str) -> bool:
    """Start ``python -m builder`` in the background to build module ``name`` unless it exists, failed before,
    is being built, or building is off; True when a build was started."""
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
            [sys.executable, "-m", builder, key],
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
    (pycc compiles no parallel loops: prange runs as range), compiled for the host CPU. Written to a temporary
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
            from numba.pycc import CC

        with tempfile.TemporaryDirectory(dir=path.parent) as tmp:
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


def release_lock() -> None:
    """Remove the build lock the starting process handed to this builder (``SARPROC_AOT_LOCK``)."""
    lock = os.environ.get("SARPROC_AOT_LOCK")
    if lock:
        with contextlib.suppress(OSError):
            os.unlink(lock)
