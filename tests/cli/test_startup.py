"""Start-up cost and import side effects: what `import sarproc` and `sarproc --help` load and change.

Module-set checks, not timings: a stage's process pays for every library it imports (numba and scipy.fft
are ~0.2-0.5 s each here; docs/performance.md, "Per-process overhead"), so the command group and its help
import none of them, and importing the package leaves the process's environment as it was.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from sarproc.cli.main import COMMANDS, THREAD_DEFAULTS, set_thread_defaults

# Libraries that only a stage's own work needs; loading them for `--help` would cost a second or more.
HEAVY = ("numba", "llvmlite", "scipy", "h5py", "dask", "distributed", "matplotlib", "xarray", "sarkit", "PIL")


def _python(code: str, env: dict | None = None) -> str:
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, env=env or dict(os.environ)
    )
    return done.stdout


def _loaded_after(code: str) -> set[str]:
    out = _python(code + "\nimport json, sys\nprint(json.dumps(sorted(sys.modules)))")
    return {m.split(".")[0] for m in json.loads(out.strip().splitlines()[-1])}


def test_import_sarproc_leaves_the_environment_unchanged():
    env = {k: v for k, v in os.environ.items() if k not in THREAD_DEFAULTS}
    out = _python(
        "import os, json\nbefore = dict(os.environ)\nimport sarproc, sarproc.cli.main\n"
        "print(json.dumps(dict(os.environ) == before))",
        env,
    )
    assert json.loads(out) is True


def test_importing_every_library_module_leaves_the_environment_unchanged():
    """Also through what the modules import: threadpoolctl sets KMP_DUPLICATE_LIB_OK when imported, so the
    library imports it where it first limits BLAS (quality.blas, dsp.spline), not at the top of a module."""
    env = {k: v for k, v in os.environ.items() if k not in {*THREAD_DEFAULTS, "KMP_DUPLICATE_LIB_OK"}}
    out = _python(
        "import importlib, json, os, pkgutil\nbefore = dict(os.environ)\nimport sarproc\n"
        "modules = pkgutil.walk_packages(sarproc.__path__, 'sarproc.')\n"
        "names = [m.name for m in modules if m.name != 'sarproc.__main__']\n"
        "for name in names:\n    importlib.import_module(name)\n"
        "changed = {k: v for k, v in os.environ.items() if before.get(k) != v}\n"
        "print(json.dumps([len(names), changed, sorted(set(before) - set(os.environ))]))",
        env,
    )
    count, changed, removed = json.loads(out.strip().splitlines()[-1])
    assert count > 100  # every module of the package was imported
    assert changed == {} and removed == []


def test_the_command_sets_the_wait_policies_unless_the_user_did():
    env = {k: v for k, v in os.environ.items() if k not in THREAD_DEFAULTS}
    # main() ends the process (after the exit handlers): the policies are printed by one
    code = (
        "import atexit, os, sys\nfrom sarproc.cli.main import main\nsys.argv = ['sarproc', '--version']\n"
        "atexit.register(lambda: print(os.environ.get('OMP_WAIT_POLICY'), os.environ.get('OPENBLAS_THREAD_TIMEOUT')))"
        "\nmain()"
    )
    assert _python(code, env).split()[-2:] == ["PASSIVE", "20"]
    users = {"OMP_WAIT_POLICY": "ACTIVE", "OPENBLAS_THREAD_TIMEOUT": "0"}
    assert _python(code, {**env, **users}).split()[-2:] == ["ACTIVE", "0"]
    mine = dict(users)
    set_thread_defaults(mine)
    assert mine == users


BLAS_WORKERS = """
import json, os, time
from sarproc.cli.main import set_thread_defaults
set_thread_defaults()
before = set(os.listdir("/proc/self/task"))
import numpy  # loads OpenBLAS, which starts its worker threads
workers = set(os.listdir("/proc/self/task")) - before
time.sleep(0.2)  # past a default spin (2^28 cycles: ~0.1 s at 2.5 GHz)
print(json.dumps([int(open(f"/proc/self/task/{w}/schedstat").read().split()[0]) for w in workers]))
"""


def test_under_the_commands_defaults_blas_workers_do_not_spin_at_numpys_import():
    """OpenBLAS's workers, started when numpy loads it, otherwise spin for work that is not coming: 33-37 ms
    of CPU each here, on the cores the stage needs (docs/performance.md, fourteenth round); 0.05 ms with the
    command's defaults. schedstat's first field: the thread's time on a CPU, ns."""
    if not os.path.exists("/proc/self/schedstat"):
        pytest.skip("no per-thread scheduler statistics (/proc/PID/task/TID/schedstat)")
    env = {k: v for k, v in os.environ.items() if k not in {*THREAD_DEFAULTS, "OPENBLAS_NUM_THREADS"}}
    on_cpu_ns = json.loads(_python(BLAS_WORKERS, env).strip().splitlines()[-1])
    if not on_cpu_ns:
        pytest.skip("OpenBLAS started no worker threads (one CPU)")
    assert max(on_cpu_ns) < 5e6, on_cpu_ns


def test_the_command_group_and_its_help_import_no_heavy_library():
    loaded = _loaded_after("import sarproc.cli.main")
    assert not loaded & set(HEAVY), sorted(loaded & set(HEAVY))
    out = _python(  # main() ends the process (after the exit handlers): the modules are printed by one
        "import atexit, json, sys\nfrom sarproc.cli.main import main\nsys.argv = ['sarproc', '--help']\n"
        "atexit.register(lambda: print(json.dumps(sorted(sys.modules))))\nmain()"
    )
    loaded = {m.split(".")[0] for m in json.loads(out.strip().splitlines()[-1])}
    assert not loaded & set(HEAVY), sorted(loaded & set(HEAVY))


def test_each_commands_module_imports_no_heavy_library():
    # what `sarproc STAGE --help` loads: the command's module; the stage's work is imported when it runs
    code = "import importlib\n" + "".join(
        f"importlib.import_module({target.split(':')[0]!r})\n" for target in COMMANDS.values()
    )
    loaded = _loaded_after(code)
    assert not loaded & set(HEAVY), sorted(loaded & set(HEAVY))


KERNEL_RUN = """
import json, sys
import numpy as np
from sarproc.focus.squint_deramp.block_copies import pad_rows
src = (np.arange(12, dtype=np.float32) + 1j).astype(np.complex64).reshape(3, 4)
dst = np.full((3, 6), 7, np.complex64)
pad_rows(src, dst, 1)
try:
    pad_rows(src, np.empty((2, 6), np.complex64), 1)
    raised = False
except ValueError:
    raised = True
want = np.zeros((3, 6), np.complex64)
want[:, :4] = src * np.where(np.arange(4) % 2 == 1, -1, 1)
print(json.dumps({"equal": bool(np.array_equal(dst, want)), "raised": raised,
                  "refreshed": "numba.np.arraymath" in sys.modules}))
"""


def test_cached_kernels_load_without_numbas_context_refresh(tmp_path):
    # first process: compiles pad_rows into a fresh cache; second: loads it from there, without the refresh
    # (numba.np.arraymath and the other lowering modules stay unimported) and computes the same
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path)}
    compiled = json.loads(_python(KERNEL_RUN, env).strip().splitlines()[-1])
    loaded = json.loads(_python(KERNEL_RUN, env).strip().splitlines()[-1])
    assert compiled == {"equal": True, "raised": True, "refreshed": True}
    assert loaded == {"equal": True, "raised": True, "refreshed": False}


def test_stages_without_compiled_kernels_import_no_numba():
    # coarse-focus, reconstruct and evaluate run no numba kernel; importing numba would cost them ~0.2 s
    # (docs/performance.md, "Per-process overhead"); evaluate's spline and Cholesky come only where used
    code = (
        "import sarproc.focus.squint_deramp.coarse_focus, sarproc.focus.multichannel.reconstruct\n"
        "import sarproc.quality.metrics\n"
        "import json, sys\nprint(json.dumps(sorted(sys.modules)))"
    )
    loaded = set(json.loads(_python(code).strip().splitlines()[-1]))
    assert not {m for m in loaded if m.split(".")[0] in ("numba", "llvmlite")}, "numba imported"
    assert not loaded & {"scipy.interpolate", "scipy.linalg"}, sorted(loaded & {"scipy.interpolate", "scipy.linalg"})


def test_pfa_modules_import_no_numba():
    # pfa2's kernels (resampling, the column spline) sit in their own modules, imported only where numba runs
    # them: a small two-step PFA runs them compiled ahead of time without numba (docs/performance.md)
    code = "import sarproc.cli.pfa, sarproc.focus.pfa.chain\nimport json, sys\nprint(json.dumps(sorted(sys.modules)))"
    loaded = set(json.loads(_python(code).strip().splitlines()[-1]))
    assert not {m for m in loaded if m.split(".")[0] in ("numba", "llvmlite")}, "numba imported"


def test_python_dash_m_runs_the_command_line():
    """`python -m sarproc` and `python -m sarproc.cli.main` are the sarproc command, not a silent no-op."""
    for module in ("sarproc", "sarproc.cli.main"):
        done = subprocess.run([sys.executable, "-m", module, "--version"], capture_output=True, text=True, check=True)
        assert done.stdout.strip().startswith("sarproc, version"), (module, done.stdout, done.stderr)


def test_stage_modules_import_no_scipy_subpackage():
    # scipy.fft (array-API layer, scipy.special: 0.15-0.2 s) is replaced by sarproc.product.fft, which loads
    # the same pocketfft extension; scipy.ndimage by a numpy maximum filter (docs/performance.md)
    code = (
        "import sarproc.focus.squint_deramp.coarse_focus, sarproc.focus.squint_deramp.fine_focus\n"
        "import sarproc.focus.multichannel.reconstruct, sarproc.focus.backprojection, sarproc.simulation.simulate\n"
        "import sarproc.focus.array3d.linear_array, sarproc.formats.cphd, sarproc.quality.metrics\n"
        "import json, sys\nprint(json.dumps(sorted(sys.modules)))"
    )
    loaded = set(json.loads(_python(code).strip().splitlines()[-1]))
    sub = {m for m in loaded if m.startswith("scipy.") and not m.startswith(("scipy._", "scipy.version"))}
    assert not sub, sorted(sub)


def test_stages_import_yaml_only_to_read_a_config():
    # `import yaml` (~25 ms, its regular expressions) is paid by commands given a YAML file, not at every
    # stage's start (docs/performance.md, eighth round); the stages' parameter models import the config module
    code = (
        "import importlib\n"
        + "".join(f"importlib.import_module({target.split(':')[0]!r})\n" for target in COMMANDS.values())
        + (
            "import sarproc.quality.metrics, sarproc.focus.backprojection, sarproc.product.io, sarproc.product.config\n"
            "import sarproc.formats.cphd, sarproc.formats.sicd\n"
        )
    )
    assert "yaml" not in _loaded_after(code)
    assert "yaml" in _loaded_after(
        "import pathlib, tempfile\nfrom sarproc.product.config import load_yaml\n"
        "p = pathlib.Path(tempfile.mkdtemp()) / 'c.yaml'\np.write_text('a: 1\\n')\nassert load_yaml(p) == {'a': 1}"
    )


def test_products_io_imports_no_socket_or_secrets():
    # every stage imports sarproc.product.io and .run: socket and secrets (with hmac and OpenSSL's _hashlib)
    # cost ~5-10 ms of each start for a host name and 4 random bytes, which os.uname() and os.urandom() give
    # (docs/performance.md, ninth round); a socket is imported only to write to a Unix socket output
    code = "import sarproc.product.io, sarproc.product.run, sarproc.cli.stage, sarproc.cli.main\n"
    loaded = set(json.loads(_python(code + "import json, sys\nprint(json.dumps(sorted(sys.modules)))")))
    assert not loaded & {"socket", "secrets", "hmac"}, sorted(loaded & {"socket", "secrets", "hmac"})
    out = _python(
        "import socket\nfrom pathlib import Path\nfrom sarproc.product import io, run\n"
        "parts = io._temporary_name(Path('/tmp/x.h5')).name[: -len(io.TMP_SUFFIX)].rsplit('.', 3)\n"
        "print(run.hostname() == socket.gethostname(), parts[1] == io._HOST, len(parts[3]), int(parts[3], 16) >= 0)"
    )
    assert out.split() == ["True", "True", "8", "True"], out


def _exit_run(setup: str, code: int = 3) -> subprocess.CompletedProcess:
    """A process that registers an exit handler and an object whose finalizer prints, runs ``setup`` and ends
    through the command's exit (sarproc.cli.main.exit_without_teardown) with status ``code``."""
    program = (
        "import atexit, sys\nfrom sarproc.cli.main import exit_without_teardown\n"
        "atexit.register(lambda: print('exit handler ran'))\n"
        "class Freed:\n    def __del__(self):\n        print('teardown ran')\n"
        f"kept = Freed()\nsys.stdout.write('buffered output')\n{setup}\nexit_without_teardown({code})\n"
    )
    return subprocess.run([sys.executable, "-c", program], capture_output=True, text=True, check=False)


NUMPY_MA_IMPORTERS = """
import json, sys, traceback
from sarproc.cli.main import run_cli
importers = []


class Watch:
    def find_spec(self, name, path=None, target=None):
        if name == "numpy.ma":  # the line outside numpy and the import system whose call imported it
            frames = [f for f in traceback.extract_stack()[:-1] if "importlib" not in f.filename]
            while frames and "/numpy/" in frames[-1].filename:
                frames.pop()
            if frames and "/sarproc/" in frames[-1].filename:
                importers.append(f"{frames[-1].filename}:{frames[-1].lineno}")
        return None


sys.meta_path.insert(0, Watch())
assert run_cli(ARGS) == 0
print(json.dumps(importers))
"""


@pytest.mark.parametrize(
    "config, stage", [("demo.yaml", "backproject"), ("nie2016_small.yaml", "pfa2"), ("demo.yaml", "simulate")]
)
def test_stages_import_no_numpy_ma_through_sarprocs_own_calls(tmp_path, config, stage):
    # np.median's NaN check and np.unique's mask check imported numpy.ma (10-25 ms of a process) for a median
    # spacing or a few survey indices (docs/performance.md, fourteenth round); numba's own import of it, where
    # a test runs the kernels without their compiled modules, is not sarproc's call
    config = str(Path(__file__).resolve().parents[2] / "configs" / config)
    raw, out = str(tmp_path / "raw.h5"), str(tmp_path / "out.h5")
    run = ["simulate", config, "-o", raw, "-q"]
    if stage != "simulate":  # the raw product from another process
        _python(f"from sarproc.cli.main import run_cli\nassert run_cli({run!r}) == 0")
        run = [stage, raw, "--config", config, "-o", out, "-q"]
    importers = json.loads(_python(NUMPY_MA_IMPORTERS.replace("ARGS", repr(run))).strip().splitlines()[-1])
    assert importers == [], importers


def test_the_command_ends_after_its_exit_handlers_without_the_interpreters_teardown():
    # freeing every module and object at exit took 0.07-0.16 s of each stage's process (docs/performance.md,
    # eleventh round): the command skips it, after the exit handlers and with its output flushed
    done = _exit_run("import numpy, h5py")
    assert done.returncode == 3, done.stderr
    assert done.stdout.startswith("buffered output") and "exit handler ran" in done.stdout, done.stdout
    assert "teardown ran" not in done.stdout, done.stdout


def test_the_command_exits_as_python_does_while_the_teardown_has_work():
    # an HDF5 file still open (HDF5's exit flushes it) or a thread still running (Python waits for it)
    still_open = "import h5py, tempfile, os\nf = h5py.File(os.path.join(tempfile.mkdtemp(), 'x.h5'), 'w')"
    running = (
        "import threading, time\nthreading.Thread(target=lambda: (time.sleep(0.3), print('thread ended'))).start()"
    )
    for setup, said in ((still_open, "teardown ran"), (running, "thread ended")):
        done = _exit_run(setup)
        assert done.returncode == 3, done.stderr
        assert "exit handler ran" in done.stdout and said in done.stdout, (setup, done.stdout)
