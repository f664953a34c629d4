"""Shared fixtures: small scenes built as mappings, so each test states what it changes."""

from __future__ import annotations

import contextlib
import copy
import dataclasses
import os
from pathlib import Path

import numpy as np
import pytest
import yaml

# The backprojection kernels compiled ahead of time (sarproc.product.aot) are off in the tests unless a test
# turns them on: otherwise the first small backprojection would start a background build and later tests would
# run one kernel or the other depending on when it finished. tests/focus/test_backprojection_aot.py builds its
# own module and checks it against numba's.
os.environ.setdefault("SARPROC_AOT", "0")

BASE_SCENE = {
    "radar": {
        "carrier_frequency": "10 GHz",
        "bandwidth": "100 MHz",
        "pulse_duration": "1 us",
        "range_sampling_rate": "120 MHz",
        "prf": "400 Hz",
    },
    "platform": {"velocity": "100 m/s", "altitude": "0 m"},
    "geometry": {"reference_range": "2 km", "squint": "0 deg"},
    "acquisition": {"mode": "spotlight", "aperture_time": "0.5 s"},
    "targets": {"frame": "squint", "points": [{"name": "A"}]},
    # the suite's small scenes check the continuous chirp's echo equation (band-limited echoes: their own tests,
    # tests/simulation/test_band_limited.py, and the campaign scenes)
    "simulation": {"waveform": "continuous"},
}

# scripts/evaluate_campaign.py's squinted stripmap (2 deg beam, 150 MHz, 1.2 s track), imaged in its zero-Doppler
# frame; a test merges in its squint, antenna pattern and targets.
CAMPAIGN_STRIPMAP = yaml.safe_load(
    (Path(__file__).resolve().parents[1] / "configs" / "evaluate_campaign.yaml").read_text()
)


def merge(base: dict, changes: dict) -> dict:
    """Deep-merge ``changes`` into a copy of ``base`` (None deletes a key)."""
    out = copy.deepcopy(base)
    for k, v in changes.items():
        if v is None:
            out.pop(k, None)
        elif isinstance(v, dict) and isinstance(out.get(k), dict):
            out[k] = merge(out[k], v)
        else:
            out[k] = copy.deepcopy(v)
    return out


def with_ghost(image, ghost, level_db: float):
    """``image`` with ``ghost`` (a product of one extra scatterer on the same grid) added at ``level_db`` of
    ``image``'s peak: a scatterer left out of the truth table."""
    assert ghost.data.shape == image.data.shape
    scale = 10 ** (level_db / 20) * np.abs(image.data).max() / np.abs(ghost.data).max()
    return dataclasses.replace(image, data=(image.data + scale * ghost.data).astype(np.complex64))


def assert_ghost_listed_once(report, image, ghost, level_db: float, name: str = "G", above_db: float = -np.inf) -> None:
    """The report lists one false target over ``above_db``: ``ghost``'s scatterer ``name``, within 1 dB of
    ``level_db`` and two of ``image``'s theoretical IRWs of its place along each axis."""
    entries = [e for e in report.false_targets.entries if e.pixel_level_db > above_db]
    assert len(entries) == 1
    assert entries[0].pixel_level_db == pytest.approx(level_db, abs=1.0)
    names = [str(n.decode() if isinstance(n, bytes) else n) for n in ghost.targets["name"]]
    irw = dict(zip(image.dims, image.attrs["theoretical_irw"]))
    for d in image.dims:
        assert abs(entries[0].position[d] - float(ghost.targets[d][names.index(name)])) <= 2 * irw[d], d


@pytest.fixture
def scene_mapping():
    """Factory: scene_mapping(**section_changes) -> a small valid scene mapping."""

    def make(**changes):
        return merge(BASE_SCENE, changes)

    return make


@pytest.fixture(scope="module")
def fresh_numba(tmp_path_factory):
    """A numba cache that only this module's subprocesses write: their numba kernels are compiled there from the
    sources by a plain process. A cache written by other processes, or kernels a long test process compiled
    earlier, can differ from a fresh compile in the last bits (docs/performance.md, "Traced (session 18)"),
    which a bit-for-bit comparison with a compiled module must not depend on."""
    return tmp_path_factory.mktemp("numba-cache")


def compiled_module_env(directory, numba_cache):
    """The environment of a subprocess that loads the compiled modules in ``directory`` (SARPROC_AOT=1), imports
    this tree and compiles numba's kernels into ``numba_cache`` (a :func:`fresh_numba`)."""

    root = str(Path(__file__).resolve().parents[1])
    return {
        **os.environ,
        "SARPROC_AOT_DIR": str(directory),
        "SARPROC_AOT": "1",
        "PYTHONPATH": root,
        "NUMBA_CACHE_DIR": str(numba_cache),
    }


@contextlib.contextmanager
def aot_environment(directory):
    """SARPROC_AOT=1 with modules in ``directory`` for the block, both variables as they were after it (a
    module-scoped fixture cannot use monkeypatch)."""
    keys = ("SARPROC_AOT_DIR", "SARPROC_AOT")
    old = [os.environ.get(key) for key in keys]
    os.environ["SARPROC_AOT_DIR"], os.environ["SARPROC_AOT"] = str(directory), "1"
    try:
        yield
    finally:
        for key, value in zip(keys, old, strict=True):
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value


# The compiled modules the AOT test modules check (tests/focus/test_backprojection_aot.py, tests/product/
# test_aot_kernels.py, tests/quality/test_kernels_aot.py and test_residual_aot.py), each built by the background
# builder's own command in a process of its own, into a directory of the session, in the environment its module's
# fixture built it in before. Those fixtures ran their builds while the session waited (~75 s on CI's two cores);
# now the builds start with the session's first test, one after another in a thread, niced (a build is one core's
# work: it takes the core the session's tests leave idle, and yields it to them), and a fixture waits for its own.
AOT_TEST_FILES = ("test_backprojection_aot.py", "test_aot_kernels.py", "test_kernels_aot.py", "test_residual_aot.py")

# Numba kernels that a late test file is the first in the suite to call and that take long to compile, compiled
# ahead by a plain process into the session's numba cache after the builds (the same thread, niced the same way,
# never waited for): the test that first calls them loads them instead of compiling them while the session waits.
# A plain process compiles them as the test process would from the sources (docs/performance.md, "Traced
# (session 18)": two plain processes agree bit for bit). ffbp's two parallel kernels (merge_level, final_points)
# were ~30 s of one core here and the first ffbp test's ~50 s in CI. The inputs only give numba the types the
# engine passes (its buffers are typed inside ffbp_points); a warm-up that fails changes nothing but the time.
FFBP_WARMUP = """
import numpy as np
from sarproc.focus.ffbp import ffbp_points

n_az, n_rg, fs = 64, 200, 120e6
rng = np.random.default_rng(0)
rc = (rng.standard_normal((n_az, n_rg)) + 1j * rng.standard_normal((n_az, n_rg))).astype(np.complex64)
range_time = 2 * 2000.0 / 299792458.0 + (np.arange(n_rg) - n_rg / 2) / fs
pos = np.zeros((n_az, 3))
pos[:, 0], pos[:, 1] = (np.arange(n_az) - n_az / 2) * 0.25, -2000.0
a, r = np.meshgrid(np.linspace(-10, 10, 24), np.linspace(-10, 10, 20), indexing="ij")
pts = np.stack([a.ravel(), r.ravel(), np.zeros(a.size)], 1)
for reads in ({}, {"ffbp_interpolation": "cubic", "first_factor": 4}):
    ffbp_points(rc, range_time, pos, pts, 10e9, 100e6, grid_shape=a.shape, **reads)  # a lattice
    ffbp_points(rc, range_time, pos, pts[::3], 10e9, 100e6, **reads)  # points one by one
"""
NUMBA_WARMUPS = {"test_ffbp.py": FFBP_WARMUP}


def _aot_build_jobs(tmp_path_factory, files):
    """Kernels name -> (directory, argv, env) of the builds that the AOT test ``files`` check, in their order."""
    import sys

    from sarproc.product import aot

    root = str(Path(__file__).resolve().parents[1])
    jobs = {}

    def directory(label):
        d = tmp_path_factory.mktemp(label)
        d.chmod(0o700)
        return d

    def by_owner(group):
        return [sys.executable, "-m", "sarproc.product.aot", group.owner, aot.module_key(group.source_paths)]

    for file in files:
        if file == "test_backprojection_aot.py":
            from sarproc.focus import backprojection_aot as bpa

            d = directory("aot-backprojection")
            argv = [sys.executable, "-m", bpa.BUILDER, aot.module_key(bpa.SOURCES)]
            # the user's numba cache as the builder sees it: it must stay empty (the fixture checks)
            jobs[bpa.NAME] = (d, argv, compiled_module_env(d, d / "numba-cache"))
        elif file == "test_aot_kernels.py":
            from sarproc.dsp import phasor
            from sarproc.focus.pfa import correction
            from sarproc.focus.squint_deramp import compiled

            d = directory("aot-stages")
            env = {**os.environ, "SARPROC_AOT_DIR": str(d), "SARPROC_AOT": "1", "PYTHONPATH": root}
            from sarproc.simulation import echo_aot

            for group in (phasor.AOT, echo_aot.IMPULSES, compiled.BLOCKS, compiled.STOLT, correction.AOT):  # BY_COMMAND
                jobs[group.name] = (d, by_owner(group), env)
        elif file in ("test_kernels_aot.py", "test_residual_aot.py"):
            from sarproc.quality import kernels_aot, residual_aot

            group = kernels_aot.QUALITY if file == "test_kernels_aot.py" else residual_aot.RESIDUAL
            d = directory(f"aot-{group.name}")
            jobs[group.name] = (d, by_owner(group), compiled_module_env(d, d / "numba-cache"))
    return jobs


def _numba_warmup_jobs(files):
    """Label -> (None, argv, env) of the numba warm-ups (above) for the test ``files``, in their order."""
    import sys

    root = str(Path(__file__).resolve().parents[1])
    env = {**os.environ, "PYTHONPATH": root}
    return {f"numba-warmup:{file}": (None, [sys.executable, "-c", NUMBA_WARMUPS[file]], env) for file in files}


class AotBuilds:
    """The session's module builds (above), run one after another in a thread, then its numba warm-ups (``warmups``,
    the same kind of jobs; always niced, never waited for)."""

    def __init__(self, jobs, warmups=None):
        import threading

        self.warmups = set(warmups or ())
        jobs = {**jobs, **(warmups or {})}
        self.jobs = jobs
        self.done = {name: threading.Event() for name in jobs}
        self.results = {}
        self.stopped = False
        self.waited = False
        self.running = None
        self.running_name = None
        self.thread = threading.Thread(target=self._run, name="aot-builds", daemon=True)
        self.thread.start()

    def _run(self):
        import shutil
        import subprocess

        nice = ["nice", "-n", "10"] if shutil.which("nice") else []
        for name, (_, argv, env) in self.jobs.items():
            try:
                if not self.stopped:
                    self.running_name = name
                    self.running = subprocess.Popen(
                        [*([] if self.waited and name not in self.warmups else nice), *argv],
                        env=env,
                        stdout=subprocess.PIPE,
                        stderr=subprocess.PIPE,
                        text=True,
                    )
                    if self.waited and name not in self.warmups:  # a test waits: at the session's priority
                        self._unnice()
                    out, err = self.running.communicate()
                    self.results[name] = subprocess.CompletedProcess(argv, self.running.returncode, out, err)
            except OSError as exc:
                self.results[name] = subprocess.CompletedProcess(argv, -1, "", str(exc))
            finally:
                self.done[name].set()

    def _unnice(self):
        """The running build back at the session's priority, where the system lets a process raise another's."""
        proc = self.running
        if proc is not None and hasattr(os, "setpriority") and self.running_name not in self.warmups:
            with contextlib.suppress(OSError):
                os.setpriority(os.PRIO_PROCESS, proc.pid, os.getpriority(os.PRIO_PROCESS, 0))

    def result(self, name):
        """(directory, finished process) of the build of kernels ``name``, once it has ended. A test that has to
        wait for it has nothing else to run: from then on the builds are not niced (other processes on the
        machine would otherwise starve them while the session waits)."""
        assert name in self.jobs, f"the session started no build of {name}"
        if not self.done[name].is_set():
            self.waited = True
            self._unnice()
        self.done[name].wait()
        return self.jobs[name][0], self.results[name]

    def stop(self):
        self.stopped = True
        proc = self.running
        if proc is not None and proc.poll() is None:
            proc.kill()
        self.thread.join()


@pytest.fixture(scope="session", autouse=True)
def aot_builds(request, tmp_path_factory):
    """The builds of the compiled modules that the session's AOT tests check (those with a ``built`` fixture),
    started now (see above; none without a C compiler: the tests are skipped), then the numba warm-ups of its
    files in NUMBA_WARMUPS."""
    import shutil

    files, warm = [], []
    have_cc = shutil.which(os.environ.get("CC", "cc")) is not None or shutil.which("gcc") is not None
    first = Path(str(request.session.items[0].path)).name if request.session.items else None
    for item in request.session.items:
        file = Path(str(item.path)).name
        if have_cc and file in AOT_TEST_FILES and "built" in getattr(item, "fixturenames", ()) and file not in files:
            files.append(file)
        if file in NUMBA_WARMUPS and file != first and file not in warm:  # the first file would race its own
            warm.append(file)
    builds = AotBuilds(_aot_build_jobs(tmp_path_factory, files), _numba_warmup_jobs(warm))
    yield builds
    builds.stop()


def build_aot_kernels(group, builds):
    """``group``'s (a :class:`sarproc.product.aot.Kernels`) compiled module, built by the session (``builds``, the
    :func:`aot_builds` fixture) into a directory of its own through the background builder's own command, and
    loaded as a process with SARPROC_AOT=1 would; the build writes nothing into numba's cache. (directory, module)"""
    from sarproc.product import aot

    directory, done = builds.result(group.name)
    numba_cache = directory / "numba-cache"  # the user's numba cache as the builder sees it: it must stay empty
    assert done.returncode == 0, done.stderr[-2000:]
    # its callees compiled in a build differ in the last bits from a plain process's (aot.private_numba_cache)
    assert not numba_cache.exists() or not any(numba_cache.iterdir())
    aot._LOADED.pop(group.name, None)
    try:
        with aot_environment(directory):
            module = group.load()
    finally:
        aot._LOADED.pop(group.name, None)
    assert module is not None and group.is_compiled(module)
    return directory, module
