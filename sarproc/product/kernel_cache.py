"""Where numba keeps the compiled kernels (``cache=True``), also on read-only installs.

numba caches next to the source (``__pycache__``) or, when that is read-only, under the user's
``~/.cache``. With neither writable (a read-only install run by a service account, a container
or ``nobody``) every ``cache=True`` kernel fails to compile: "no locator available". Then the
kernels are cached in a per-user directory under the system's temporary directory, or, when
that fails too, compiled without caching (each run pays the compile time). Either fallback is
said once at info level (``sarproc -v``). ``NUMBA_CACHE_DIR``, when set, is used as numba
documents.

Every module with compiled kernels decorates them with ``cache=CACHE`` from here (lives in product, the
lowest layer, so that every layer may import it; sarproc.dsp.kernel_cache re-exports it).
Each such module ends with ``lean_cache_loads(globals())``: its kernels then load from the cache without
numba's full start-up (see :func:`lean_cache_loads`).
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import logging
import os
import stat
import tempfile
import types
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numba
from numba.core import caching

log = logging.getLogger(__name__)


def _probe() -> None:  # a function of this package: numba's locators are asked about its source file
    pass


def default_locator_works() -> bool:
    """Whether one of numba's own cache locators can store kernels of this package's source files."""
    try:
        return any(cls.from_function(_probe, __file__) is not None for cls in caching.CacheImpl._locator_classes)
    except Exception:
        return True


def private_temp_cache() -> Path | None:
    """A directory only this user can write, under the temporary directory; None when there is none."""
    path = Path(tempfile.gettempdir()) / f"sarproc-numba-cache-{os.getuid()}"
    try:
        path.mkdir(mode=0o700, exist_ok=True)
        st = os.lstat(path)
        # someone else's directory (or a link planted there) must not receive code that is later loaded
        if not stat.S_ISDIR(st.st_mode) or st.st_uid != os.getuid() or st.st_mode & 0o022:
            return None
        tempfile.TemporaryFile(dir=path).close()
    except OSError:
        return None
    return path


def _configure() -> bool:
    if numba.config.CACHE_DIR or numba.config.DISABLE_JIT or default_locator_works():
        return True
    fallback = private_temp_cache()
    if fallback is not None:
        numba.config.CACHE_DIR = str(fallback)
        log.info(
            "compiled kernels are cached in %s (the install and the home directory are not writable; "
            "set NUMBA_CACHE_DIR to choose)",
            fallback,
        )
        return True
    log.info(
        "compiled kernels are not cached (no writable cache directory: the install, the home directory "
        "and %s are not writable); each run compiles them again; set NUMBA_CACHE_DIR",
        tempfile.gettempdir(),
    )
    return False


# Decided once per process, before the first kernel is decorated.
CACHE: bool = _configure()


def _load_overload_lean(self: Any, sig: object, target_context: object) -> object:
    """numba's ``Cache.load_overload`` without ``target_context.refresh()``; only the runtime (NRT) it links."""
    from numba.core.runtime import rtsys

    rtsys.initialize(target_context)
    with self._guard_against_spurious_io_errors():
        return self._load_overload(sig, target_context)


@functools.cache
def kernel_sources_digest(root: Path | None = None) -> str:
    """SHA-1 of every source file of this package (or under ``root``) that mentions numba, read once per
    process (~15 ms).

    numba keys a cached kernel by its own file's modification time and size only: a kernel calling a
    compiled helper from another module (a phasor, an interpolation weight) keeps loading its stale
    machine code after that helper changes, and computes the old numbers silently. :func:`lean_cache_loads`
    adds this digest to each kernel's cache stamp, so any change to any kernel source recompiles them all."""
    root = Path(__file__).resolve().parent.parent if root is None else root
    digest = hashlib.sha1()
    for path in sorted(root.rglob("*.py")):
        text = path.read_bytes()
        if b"numba" in text:
            digest.update(path.relative_to(root).as_posix().encode() + b"\0" + text + b"\0")
    return digest.hexdigest()


_DIGEST_TAG = "sarproc-kernel-sources"


def _stamped(stamp: object) -> bool:
    return isinstance(stamp, tuple) and len(stamp) == 3 and stamp[1] == _DIGEST_TAG


def lean_cache_loads(namespace: dict) -> int:
    """Let the compiled kernels in ``namespace`` (a module's globals) load from numba's cache without the
    context refresh numba does first; returns how many.

    Before loading a cached kernel numba refreshes its compilation context: it imports its lowering
    libraries (numba.np.arraymath, npyimpl, linalg ... and scipy.linalg) and installs their registries,
    0.3 s on the reference machine, more than all of a small stage's kernels take to load (measured:
    docs/performance.md, "Per-process overhead"). A cached kernel needs none of it, only numba's runtime
    (NRT), which is initialised here; a kernel that is not in the cache compiles as before, and numba's
    compiler refreshes the context itself. Applied per kernel, so other numba users in the process are
    untouched; numba versions without these internals keep their own loading.

    Each kernel's cache stamp also gets :func:`kernel_sources_digest`, so that a change to a helper it calls in
    another module invalidates it (numba's own stamp is only the kernel's file's time and size).
    """
    from numba.core.caching import Cache
    from numba.core.registry import CPUDispatcher

    count = 0
    for obj in list(namespace.values()):
        cache = getattr(obj, "_cache", None)
        if (
            isinstance(obj, CPUDispatcher)
            and isinstance(cache, Cache)
            and hasattr(cache, "_load_overload")
            and hasattr(cache, "_guard_against_spurious_io_errors")
        ):
            cache.load_overload = types.MethodType(_load_overload_lean, cache)
            count += 1
        cache_file = getattr(cache, "_cache_file", None)
        stamp = getattr(cache_file, "_source_stamp", None)
        if isinstance(obj, CPUDispatcher) and cache_file is not None and stamp is not None and not _stamped(stamp):
            cache_file._source_stamp = (stamp, _DIGEST_TAG, kernel_sources_digest())
    return count


@contextlib.contextmanager
def slp_vectorized() -> Iterator[None]:
    """Compile the kernels first called inside this block with LLVM's SLP vectoriser on.

    numba leaves it off by default (``NUMBA_SLP_VECTORIZE=0``) and reads the setting each time it builds a
    compile pipeline, so a kernel whose hot loop is written as independent scalar lanes (e.g.
    simulation.echo_kernel's eight recurrences) gets packed vector code only when it is compiled in here.
    SLP packs IEEE operations without reassociating them (no fast-math), so the results are the scalar
    code's bit for bit. Kernels already compiled or loaded from the cache are unaffected; restored on exit.
    """
    from numba.core import config

    previous = config.SLP_VECTORIZE
    config.SLP_VECTORIZE = 1
    try:
        yield
    finally:
        config.SLP_VECTORIZE = previous
