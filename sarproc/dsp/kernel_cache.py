"""Where numba keeps the compiled kernels (``cache=True``), also on read-only installs.

numba caches next to the source (``__pycache__``) or, when that is read-only, under the user's
``~/.cache``. With neither writable (a read-only install run by a service account, a container
or ``nobody``) every ``cache=True`` kernel fails to compile: "no locator available". Then the
kernels are cached in a per-user directory under the system's temporary directory, or, when
that fails too, compiled without caching (each run pays the compile time). Either fallback is
said once at info level (``sarproc -v``). ``NUMBA_CACHE_DIR``, when set, is used as numba
documents.

Every module with compiled kernels decorates them with ``cache=CACHE`` from here.
"""

from __future__ import annotations

import logging
import os
import stat
import tempfile
from pathlib import Path

import numba
from numba.core import caching

log = logging.getLogger(__name__)


def _probe():  # a function of this package: numba's locators are asked about its source file
    pass


def default_locator_works() -> bool:
    """Whether one of numba's own cache locators can store kernels of this package's source files."""
    try:
        return any(cls.from_function(_probe, __file__) is not None for cls in caching.CacheImpl._locator_classes)
    except Exception:  # numba's private API changed: assume it works, as numba does
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
