"""Cached kernels are recompiled when a compiled helper they call in another module changes (numba's own
cache stamp is only the kernel's file)."""

import os
import shutil
import subprocess
import sys
import textwrap

from sarproc.product.kernel_cache import kernel_sources_digest

CALLER = """
import numba
from sarproc.product.kernel_cache import lean_cache_loads
from callee_mod import helper

@numba.njit(cache=True)
def kern(x):
    return helper(x)

lean_cache_loads(globals())
"""


def _callee(tmp_path, add):
    (tmp_path / "callee_mod.py").write_text(f"import numba\n\n@numba.njit\ndef helper(x):\n    return x + {add}\n")
    # the rewrite keeps the file's size and can keep its mtime second, which Python's bytecode cache compares:
    # without this, the process may run the old helper's bytecode (CI, where bytecode is written)
    shutil.rmtree(tmp_path / "__pycache__", ignore_errors=True)


def _run(tmp_path, digest):
    """kern(1) in a fresh process whose kernel-sources digest is ``digest``."""
    code = textwrap.dedent(f"""
        import sys
        sys.path.insert(0, {str(tmp_path)!r})
        import sarproc.product.kernel_cache as kc
        kc.kernel_sources_digest = lambda root=None: {digest!r}
        import caller_mod
        print(caller_mod.kern(1))
    """)
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    return int(out.stdout.strip())


def test_a_changed_callee_recompiles_its_cached_caller(tmp_path):
    (tmp_path / "caller_mod.py").write_text(CALLER)
    _callee(tmp_path, 1)
    assert _run(tmp_path, "a") == 2
    _callee(tmp_path, 2)  # the caller's file (numba's stamp) is untouched
    stale = _run(tmp_path, "a")
    assert stale in (2, 3)  # 2: numba loaded the stale kernel, which the digest is there to prevent
    assert _run(tmp_path, "b") == 3  # the sources' digest changed: recompiled


def test_the_digest_follows_kernel_sources_only(tmp_path):
    (tmp_path / "kern.py").write_text("import numba\n")
    (tmp_path / "plain.py").write_text("x = 1\n")
    first = kernel_sources_digest(tmp_path)
    (tmp_path / "plain.py").write_text("x = 2\n")
    kernel_sources_digest.cache_clear()
    assert kernel_sources_digest(tmp_path) == first
    (tmp_path / "kern.py").write_text("import numba  # changed\n")
    kernel_sources_digest.cache_clear()
    assert kernel_sources_digest(tmp_path) != first
