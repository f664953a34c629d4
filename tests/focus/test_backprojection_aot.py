"""The backprojection kernels compiled ahead of time (sarproc.product.aot, sarproc.focus.backprojection_aot).

One module build (~10-20 s: numba compiles the serial kernels, the C compiler the module) serves the tests that
need it; the rest check the dispatch and the build bookkeeping without compiling.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import aot_environment, compiled_module_env

from sarproc.dsp.rangecomp import range_compress
from sarproc.focus import backprojection_aot as bpa
from sarproc.product import aot
from sarproc.product.config import load_yaml
from sarproc.product.io import write_product
from sarproc.simulation.scene import scene_from_mapping
from sarproc.simulation.simulate import simulate

ROOT = Path(__file__).resolve().parents[2]
HAVE_CC = shutil.which(os.environ.get("CC", "cc")) is not None or shutil.which("gcc") is not None


@pytest.fixture
def aot_dir(tmp_path, monkeypatch):
    monkeypatch.setenv("SARPROC_AOT", "1")
    monkeypatch.setenv("SARPROC_AOT_DIR", str(tmp_path / "aot"))
    monkeypatch.setattr(aot, "_LOADED", {})
    return tmp_path / "aot"


@pytest.fixture(scope="module")
def built(aot_builds):
    """The module built once into a directory of this test module (skipped without a C compiler), by the
    background builder's own command (started by the session: tests/conftest.py, aot_builds): built inside this
    long process, it would link whatever variants of the callees this process had compiled or loaded from the
    cache, which can differ from a fresh compile in the last bits (the "not bit for bit" failures of a `make test`
    after `make demo`, session 24)."""
    if not HAVE_CC:
        pytest.skip("no C compiler: the kernels run in numba only (the fallback the other tests check)")
    d, done = aot_builds.result(bpa.NAME)
    numba_cache = d / "numba-cache"  # the user's numba cache as the builder sees it: it must stay empty
    assert done.returncode == 0, done.stderr[-2000:]
    key = aot.module_key(bpa.SOURCES)
    # the callees a build compiles differ in the last bits from a plain process's (aot.private_numba_cache)
    assert not numba_cache.exists() or not any(numba_cache.iterdir())
    with aot_environment(d):
        path = aot.module_path(bpa.NAME, key)
    assert path.exists()
    return d, path


@pytest.fixture(scope="module")
def raw():
    return simulate(scene_from_mapping(load_yaml(ROOT / "configs" / "bp_squint30.yaml")))


def test_the_compiled_module_runs_images_up_to_a_few_seconds_on_threads():
    assert bpa.compiled_pays(1e12, workers=1)  # one thread: numba's threads save nothing
    assert bpa.compiled_pays(1e6, workers=64)
    assert bpa.compiled_pays(512 * 512 * 600, workers=2)  # the bench scene: ~0.35 s on two threads
    assert not bpa.compiled_pays(1e10, workers=2)  # a big image: 22 s on two threads, numba's kernel
    # the limit moves up with more threads
    assert [w for w in (2, 4, 16) if bpa.compiled_pays(1.5e9, workers=w)] == [4, 16]


def test_off_switch_and_missing_module_keep_numba(aot_dir, monkeypatch):
    assert bpa.load() is None  # not built
    monkeypatch.setenv("SARPROC_AOT", "0")
    monkeypatch.setattr(aot, "_LOADED", {})
    assert bpa.load() is None
    assert not bpa.request_build()
    assert not aot_dir.exists()


def test_a_build_is_started_once_and_never_after_a_failure(aot_dir, monkeypatch):
    started = []
    monkeypatch.setattr(aot.subprocess, "Popen", lambda args, **kw: started.append((args, kw["env"])))
    assert bpa.request_build()
    assert not bpa.request_build()  # its lock is held: no second builder
    (args, env) = started[0]
    assert args[1:3] == ["-m", "sarproc.focus.backprojection_aot"] and args[3] == aot.module_key(bpa.SOURCES)
    lock = Path(env["SARPROC_AOT_LOCK"])
    assert lock.exists() and oct(aot_dir.stat().st_mode & 0o777) == "0o700"
    lock.unlink()
    aot.module_path(bpa.NAME, args[3]).with_suffix(".failed").write_text("no compiler")
    assert not bpa.request_build()  # a failed build is not retried until the sources change
    assert len(started) == 1


def test_a_stale_lock_is_taken_over(aot_dir, monkeypatch):
    started = []
    monkeypatch.setattr(aot.subprocess, "Popen", lambda args, **kw: started.append(args))
    key = aot.module_key(bpa.SOURCES)
    aot_dir.mkdir(mode=0o700, parents=True)
    lock = aot.module_path(bpa.NAME, key).with_suffix(".lock")
    lock.touch()
    old = lock.stat().st_mtime - aot.STALE_LOCK_S - 1
    os.utime(lock, (old, old))
    assert bpa.request_build() and len(started) == 1


def test_the_key_follows_the_kernel_source(tmp_path):
    src = [tmp_path / "k.py", tmp_path / "p.py"]
    src[0].write_text("a = 1\n")
    src[1].write_text("b = 1\n")
    key = aot.module_key(src)
    assert aot.module_key(src) == key
    src[1].write_text("b = 2\n")
    assert aot.module_key(src) != key


def test_a_module_in_a_directory_others_can_write_is_not_loaded(built, aot_dir):
    d, path = built
    aot_dir.mkdir(mode=0o700, parents=True)
    shutil.copy(path, aot_dir / path.name)
    aot_dir.chmod(0o777)
    assert bpa.load() is None
    aot_dir.chmod(0o700)
    aot._LOADED.clear()
    assert bpa.load() is not None


def test_compiled_module_tiles_like_numba(built, aot_dir, raw):
    from sarproc.focus import backprojection_kernel as bk

    shutil.copytree(built[0], aot_dir)
    k = bpa.load()
    assert k is not None
    rng = np.random.default_rng(3)
    pts = np.asarray(raw.radar.scene_center) + rng.normal(0.0, 30.0, (5000, 3))
    for a, b in zip(bpa.make_tiles(pts, 4.0, k, max_tile=64), bk.make_tiles(pts, 4.0, max_tile=64), strict=True):
        np.testing.assert_array_equal(a, b)


# The compiled module (serial) against numba's kernel on the same arguments, in a process whose numba compiles
# its kernels itself into a private cache (fresh_numba): a cache written by other processes, or kernels this
# long test process compiled earlier, can differ from a fresh compile in the last bits (docs/performance.md,
# "Traced (session 18)"; tests/quality/test_kernels_aot.py), which a bit-for-bit comparison must not depend on.
COMPARE = """
import sys
import numpy as np
from sarproc.focus import backprojection_aot as bpa
from sarproc.focus.backprojection import backproject_points

a = np.load(sys.argv[1])
args = (a["rc"], a["range_time"], a["pos"], a["rx"], a["pts"], float(a["f_c"]))
calls = []
real_load = bpa.load
bpa.load = lambda: calls.append(1) or real_load()
compiled = backproject_points(*args, interpolation="linear", engine="compiled", workers=1)
assert calls and real_load() is not None, "the compiled module did not run"
# on three threads (uneven groups of tiles, spans of pulses): each tile's sum as on one
threaded = backproject_points(*args, interpolation="linear", engine="compiled", workers=3)
assert np.array_equal(compiled, threaded), "threads changed the image"
bpa.load, bpa.request_build = (lambda: None), (lambda: False)
jit = backproject_points(*args, interpolation="linear", engine="compiled", workers=1)
np.testing.assert_allclose(compiled, jit, rtol=0, atol=1e-6 * np.max(np.abs(jit)))
assert np.array_equal(compiled, jit), "not bit for bit"
print("equal")
"""


@pytest.mark.parametrize("monostatic", [True, False])
def test_compiled_module_image_equals_numbas(built, raw, fresh_numba, tmp_path, monostatic):
    """Same source, serial instead of parallel tiles: each tile sums its pulses in the same order, so the
    images agree to float rounding (here: equal), against a fresh compile of numba's kernel."""
    rc = range_compress(raw.data, raw.radar)
    pos = raw.aux["platform_position"]
    rx = pos if monostatic else pos + np.array([0.0, 40.0, -15.0])
    g = np.arange(-40, 40) * 0.3
    centre = np.asarray(raw.radar.scene_center)
    pts = centre + np.stack([np.repeat(g, len(g)), np.tile(g, len(g)), np.zeros(len(g) ** 2)], 1)
    inputs = tmp_path / "inputs.npz"
    np.savez(
        inputs, rc=rc, range_time=raw.coords["range_time"], pos=pos, rx=rx, pts=pts, f_c=raw.radar.carrier_frequency
    )
    env = compiled_module_env(built[0], fresh_numba)
    done = subprocess.run(
        [sys.executable, "-c", COMPARE, str(inputs)], capture_output=True, text=True, env=env, check=False
    )
    assert done.returncode == 0 and done.stdout.strip().endswith("equal"), done.stderr[-3000:]


def test_a_small_image_runs_numbas_kernels_where_they_are_loaded(raw, monkeypatch):
    """Numba's kernels loaded already (a library caller's earlier image, the bench): their threads cost no
    start-up, so a small image runs them, not the serial module (as Kernels.pick; 512^2 x 600 ran serially at
    CPU/wall 1.0 in the bench before, 0.71x FastSAR's exact rate: docs/performance.md, ninth round)."""
    import sarproc.focus.backprojection_kernel  # noqa: F401
    from sarproc.focus.backprojection import backproject_points

    rc = range_compress(raw.data, raw.radar)
    pos = raw.aux["platform_position"]
    g = np.arange(-20, 20) * 0.3
    pts = np.asarray(raw.radar.scene_center) + np.stack(
        [np.repeat(g, len(g)), np.tile(g, len(g)), np.zeros(len(g) ** 2)], 1
    )
    assert bpa.compiled_pays(len(pts) * len(pos), workers=2)  # small: compiled where numba is not loaded
    calls = []
    monkeypatch.setattr(bpa, "load", lambda: calls.append(1))
    monkeypatch.setattr(bpa, "request_build", lambda: calls.append(2) or False)
    img = backproject_points(
        rc, raw.coords["range_time"], pos, pos, pts, raw.radar.carrier_frequency, engine="compiled", workers=2
    )
    # the module is not looked for, but its build is asked for the next process (numba's kernels are loaded in a
    # command's process by the plan's cache check while the module is not built)
    assert calls == [2] and np.all(np.isfinite(img))


REQUESTED = """
import json, sys
from sarproc.focus import backprojection_aot as bpa
from sarproc.cli.main import run_cli
asked = []
bpa.request_build = lambda: asked.append(1) or False
assert run_cli(sys.argv[1:]) == 0
print(json.dumps({"asked": bool(asked), "numba": "numba" in sys.modules}))
"""


def test_a_backproject_process_without_the_module_asks_for_its_build(raw, tmp_path):
    """The command's plan checks numba's cache (loading its kernels) while the module is not built; the image then
    ran numba's kernels and, before, never asked for the module, so every later process started numba too."""
    raw_path, img = tmp_path / "raw.h5", tmp_path / "img.h5"
    write_product(raw_path, raw)
    scene = load_yaml(ROOT / "configs" / "bp_squint30.yaml")
    cfg = tmp_path / "bp.yaml"
    cfg.write_text(json.dumps({"backproject": {**scene.get("backproject", {}), "azimuth_extent": "12 m"}}))
    env = {**os.environ, "SARPROC_AOT_DIR": str(tmp_path / "aot"), "SARPROC_AOT": "1"}
    argv = ["backproject", str(raw_path), "--config", str(cfg), "-o", str(img), "-q"]
    done = subprocess.run([sys.executable, "-c", REQUESTED, *argv], capture_output=True, text=True, env=env)
    assert done.returncode == 0, done.stderr[-2000:]
    assert json.loads(done.stdout.strip().splitlines()[-1]) == {"asked": True, "numba": True}


def test_a_small_backproject_process_imports_no_numba(built, tmp_path):
    d, _ = built
    env = {**os.environ, "SARPROC_AOT_DIR": str(d), "SARPROC_AOT": "1"}
    raw_path, img = tmp_path / "raw.h5", tmp_path / "img.h5"
    scene = load_yaml(ROOT / "configs" / "demo.yaml")
    scene["backproject"].update(azimuth_extent="20 m", range_extent="20 m")  # small on any number of cores
    cfg = str(tmp_path / "demo.yaml")
    Path(cfg).write_text(json.dumps(scene))
    subprocess.run([sys.executable, "-m", "sarproc", "simulate", cfg, "-o", str(raw_path), "-q"], check=True, env=env)
    code = (
        "import json, sys\nfrom sarproc.cli.main import run_cli\n"
        f"assert run_cli(['backproject', {str(raw_path)!r}, '--config', {cfg!r}, '-o', {str(img)!r}, '-q']) == 0\n"
        "print(json.dumps(sorted(sys.modules)))"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=False)
    assert done.returncode == 0, done.stderr[-2000:]
    loaded = json.loads(done.stdout.strip().splitlines()[-1])
    assert not [m for m in loaded if m.split(".")[0] in ("numba", "llvmlite")]
    assert any(m.startswith("_backprojection_aot_") for m in loaded)
