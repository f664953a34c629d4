"""The stages' kernels compiled ahead of time (sarproc.product.aot.Kernels): phase fields, resampling, echoes,
fine focusing's block copies and Stolt kernels, the two-step PFA's column spline.

One build of the seven modules (~1-2 min here: numba compiles the serial kernels, the C compiler the modules) serves
the tests that need it: every export equals its numba kernel on the same arguments (bit for bit, or to float32
rounding where a fast-math loop is compiled differently), and small stages run through the command line import no
numba and write the products numba's kernels write (alike). The rest check the dispatch rules without compiling.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest
from conftest import aot_environment

from sarproc.dsp import interp, phasor
from sarproc.focus.pfa import correction
from sarproc.focus.squint_deramp import compiled
from sarproc.product import aot
from sarproc.simulation import echo_aot

ROOT = Path(__file__).resolve().parents[2]
HAVE_CC = shutil.which(os.environ.get("CC", "cc")) is not None or shutil.which("gcc") is not None
GROUPS = (phasor.AOT, interp.AOT, echo_aot.ECHO, echo_aot.IMPULSES, compiled.BLOCKS, compiled.STOLT, correction.AOT)


# Built by the background builder's own command (python -m sarproc.product.aot, as request_build starts it): the
# session starts these builds with its first test, one after another in a thread (tests/conftest.py, aot_builds),
# and the fixture builds the rest in this process meanwhile. The echo module stays in this process: its complex128
# export equals the numba kernel bit for bit only where that kernel is compiled in a process that built the module
# (citime's report, 2026-12-03), which the test does not settle.
BY_COMMAND = (phasor.AOT, echo_aot.IMPULSES, compiled.BLOCKS, compiled.STOLT, correction.AOT)


@pytest.fixture(scope="module")
def built(aot_builds):
    """The seven modules built once into a directory of the session (skipped without a C compiler)."""
    if not HAVE_CC:
        pytest.skip("no C compiler: the kernels run in numba only")
    assert all(group.name in aot_builds.jobs for group in BY_COMMAND)
    d = aot_builds.jobs[BY_COMMAND[0].name][0]
    with aot_environment(d):
        try:
            for group in GROUPS:
                if group not in BY_COMMAND:
                    group.build(aot.module_key(group.source_paths))
            done = {group.name: aot_builds.result(group.name) for group in BY_COMMAND}
            modules = {}
            for group in GROUPS:
                if group in BY_COMMAND:
                    where, run = done[group.name]
                    assert where == d and run.returncode == 0, (group.name, run.stderr[-2000:])
                aot._LOADED.pop(group.name, None)
                modules[group.name] = group.load()
                assert modules[group.name] is not None
        finally:
            for group in GROUPS:
                aot._LOADED.pop(group.name, None)
    return d, modules


def _cx(rng, shape, dtype=np.complex64):
    return (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)).astype(dtype)


def test_phase_field_equals_numbas(built):
    from sarproc.dsp import phasor_kernels as pk

    k = built[1]["phasor"]
    rng = np.random.default_rng(1)
    for shape in ((37, 53), (5, 1024), (1, 7)):
        x = _cx(rng, shape)
        rows, cols = rng.normal(size=(4, shape[0])) * 300, rng.normal(size=(4, shape[1]))
        a, b = x.copy(), x.copy()
        k._separable_kernel(a.view(np.float32), rows, cols, 1 / (2 * np.pi))
        pk._separable_kernel(b.view(np.float32), rows, cols, 1 / (2 * np.pi))
        assert np.array_equal(a, b)


def _equal_to_float32_rounding(a: np.ndarray, b: np.ndarray) -> bool:
    """Bit for bit, or for fast-math float data within 8 float32 ulps of the peak: a fast-math loop compiled
    twice (ahead of time and by numba's JIT in another process, or JIT in another compile context) may
    reassociate its sums differently. Measured in a fresh clone: resampling's (strided data, C positions)
    layout with knab and sinc taps 1.4e-7 and 1.7e-7 of the peak apart; elsewhere bit for bit."""
    if a.dtype.kind not in "fc" or a.size == 0:
        return bool(np.array_equal(a, b))
    if np.array_equal(a, b, equal_nan=True):
        return True
    same_nan = np.array_equal(np.isnan(a), np.isnan(b))
    peak = np.nanmax(np.abs(b))
    return bool(same_nan and np.nanmax(np.abs(a - b)) <= 8 * np.finfo(np.float32).eps * peak)


@pytest.mark.parametrize("kernel", ["knab", "sinc", "linear", "cubic", "nearest"])
def test_resampling_equals_numbas_for_every_layout(built, kernel):
    """One export per layout of data and positions, as numba types them: its fast-math loops are compiled per
    layout and may round differently between layouts (fine focusing passes column slices and transposes)."""
    from sarproc.dsp import interp_kernels as ik

    k = built[1]["interp"]
    rng = np.random.default_rng(2)
    base = _cx(rng, (40, 60))
    pos_c = np.sort(rng.uniform(-4, 63, size=(30, 45)), axis=1)
    pos_c[3, 5] = np.nan
    datas = {"C": base[:30, :50], "A": base[5:35, ::2][:, :25], "F": np.asfortranarray(base[:30, :50])}
    datas["C"] = np.ascontiguousarray(datas["C"])
    poss = {"C": pos_c, "F": np.asfortranarray(pos_c), "A": np.broadcast_to(pos_c[:1], pos_c.shape)}
    taps = interp.kernel_length(kernel, 8)
    mode = interp._MODES.get(kernel, 3)
    table = interp.tap_table(kernel, taps, 1.25, np.float32) if mode == 3 else np.zeros((2, 1), np.float32)
    for dl, data in datas.items():
        for pl, pos in poss.items():
            assert (interp._layout(data), interp._layout(pos)) == (dl, pl)
            n_in = data.shape[1]
            args = (mode, taps, table, interp._TABLE_STEPS, np.complex64(0), -(taps + 1) / 2, n_in - 1 + (taps + 1) / 2)
            a, b = np.empty(pos.shape, np.complex64), np.empty(pos.shape, np.complex64)
            getattr(k, f"resample_{dl}{pl}")(data, pos, a, *args)
            ik._resample_kernel(data, pos, b, *args)
            assert _equal_to_float32_rounding(a, b), (dl, pl)


@pytest.mark.parametrize("dtype", [np.complex64, np.complex128])
def test_echoes_equal_numbas(built, dtype):
    from sarproc.simulation import echo_kernel as ek

    k = built[1]["echo"]
    rng = np.random.default_rng(3)
    n_t, n_tg, n_rg, fs = 6, 9, 700, 100e6
    chirp_a, chirp_b = k.window_chirp(n_rg, fs, 3e12), ek.window_chirp(n_rg, fs, 3e12)
    assert np.array_equal(chirp_a, chirp_b)
    delays = 2e-6 + rng.uniform(0, 5e-6, (n_t, n_tg))
    gains = _cx(rng, (n_t, n_tg), np.complex128)
    gains[2, 3] = 0
    gate = rng.uniform(-1e-7, 1e-7, n_t)
    args = (delays, gains, gate, 1.5e-6, fs, 2e-6, 3e12, 9.6e9, chirp_b)
    a, b = np.zeros((n_t, n_rg), dtype), np.zeros((n_t, n_rg), dtype)
    echo_aot.accumulate_echoes(k, a, *args)
    ek.accumulate_echoes(b, *args)
    assert np.array_equal(a, b) and np.abs(a).max() > 0


def test_impulses_equal_numbas(built):
    from sarproc.simulation import echo_kernel as ek

    k = built[1]["impulses"]
    rng = np.random.default_rng(5)
    n_t, n_tg, n_ext, fs = 5, 7, 400, 120e6
    half_taps, beta = echo_aot.kaiser_design(fs, 100e6)
    table = echo_aot.kaiser_table(half_taps, beta)
    delays = 1e-6 + rng.uniform(0, 2e-6, (n_t, n_tg))
    gains = _cx(rng, (n_t, n_tg), np.complex128)
    gains[1, 2] = 0
    gate = rng.uniform(-1e-7, 1e-7, n_t)
    args = (delays, gains, gate, 0.9e-6, fs, 9.6e9, half_taps, table, float(echo_aot.KAISER_PER_SAMPLE), 40.0)
    a, b = np.zeros((n_t, n_ext), np.complex128), np.zeros((n_t, n_ext), np.complex128)
    echo_aot.accumulate_impulses(k, a, *args)
    ek.accumulate_impulses(b, *args)
    assert np.array_equal(a, b) and np.abs(a).max() > 0


def test_fine_focus_block_kernels_equal_numbas(built):
    from sarproc.focus.squint_deramp import block_copies as bc, stolt_kernels as sk

    kb, ks = built[1]["block_copies"], built[1]["stolt"]
    rng = np.random.default_rng(4)
    src = _cx(rng, (9, 13))
    for start in (-1, 0, 1):
        for name, dst_shape in (("pad_rows", (9, 20)), ("copy_rows", (9, 13))):
            a, b = np.full(dst_shape, 7, np.complex64), np.full(dst_shape, 7, np.complex64)
            getattr(kb, name)(src, a, start)
            getattr(bc, name)(src, b, start)
            assert np.array_equal(a, b)
        fac = _cx(rng, 9)
        a, b = src.copy(), src.copy()
        kb.scale_rows(a, fac, start)
        bc.scale_rows(b, fac, start)
        assert np.array_equal(a, b)
        for axis in (0, 1):
            a, b = src.copy(), src.copy()
            kb.negate_alternate_2d(a, axis, max(start, 0))
            bc.negate_alternate_2d(b, axis, max(start, 0))
            assert np.array_equal(a, b)
    src[4, 6] = np.nan
    out = [np.empty((9, 5), np.complex64) for _ in range(2)]
    bad = [np.zeros(9, np.bool_) for _ in range(2)]
    kb._crop_rows(src, 3, out[0], bad[0])
    bc._crop_rows(src, 3, out[1], bad[1])
    assert np.array_equal(out[0], out[1], equal_nan=True) and np.array_equal(bad[0], bad[1]) and bad[0][4]
    # the Stolt rotation (both models) and the node interpolation
    x = _cx(rng, (11, 40))
    pre = _cx(rng, 40)
    a_, q = rng.uniform(-1e9, 1e9, 11), rng.uniform(-50, 50, 11)
    b_, p = rng.uniform(2e9, 3e9, 40), rng.uniform(1, 2, 40)
    for mode in (0, 1):
        xa, xb = x.copy(), x.copy()
        args = (mode, 0.5, 0.25, 0.866, 0.002, 3.1)
        ks._rotate_G(xa.view(np.float32), xa, pre, True, a_, q, b_, p, *args)
        sk._rotate_G(xb.view(np.float32), xb, pre, True, a_, q, b_, p, *args)
        assert np.array_equal(xa, xb)
    s_n = rng.normal(size=(6, 5)) * 1e6
    ok_n = rng.random((6, 5)) > 0.2
    seg = np.array([0, 0, 1, 2, 3, 3], np.int64)
    w = rng.random(6)
    outs = [np.empty((6, 6)), np.empty((6, 6))]
    ks._node_positions(s_n, ok_n, seg, w, -2e6, 1e5, 1.5e6, outs[0])
    sk._node_positions(s_n, ok_n, seg, w, -2e6, 1e5, 1.5e6, outs[1])
    assert np.array_equal(outs[0], outs[1], equal_nan=True)


def test_column_spline_equals_numbas(built):
    """The two-step PFA's warp read on fixed columns: knots of a FITPACK spline, points inside, outside (clamped)
    and on the knots."""
    from sarproc.focus.pfa import spline_kernels as sk

    k = built[1]["pfa_spline"]
    rng = np.random.default_rng(5)
    t = np.concatenate([np.zeros(3), np.sort(rng.uniform(0, 10, 9)), [0.0, 10.0], np.full(3, 10.0)])
    t = np.sort(t)
    columns = rng.standard_normal((17, len(t) - 4))
    x = rng.uniform(-1, 11, (23, 17))
    x[0, :5] = t[3:8]
    a, b = np.empty_like(x), np.empty_like(x)
    k._column_spline_kernel(t, columns, x, a)
    sk._column_spline_kernel(t, columns, x, b)
    assert np.array_equal(a, b) and np.isfinite(a).all()


def _stage(args: list[str], env: dict, tmp_path: Path) -> list[str]:
    """Run ``sarproc ARGS`` in a fresh process on at most two CPUs (where the compiled modules pay depends on the
    CPUs: aot.serial_pays; pfa2's ~0.5 s of serial work does on two, not on 16); the modules it imported."""
    code = (
        "import json, os, sys\nfrom sarproc.cli.main import run_cli\n"
        "if hasattr(os, 'sched_setaffinity'):\n    os.sched_setaffinity(0, sorted(os.sched_getaffinity(0))[:2])\n"
        f"assert run_cli({args!r}) == 0\nprint(json.dumps(sorted(sys.modules)))"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=False, cwd=ROOT)
    assert done.returncode == 0, done.stderr[-2000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def _datasets(path: Path) -> dict[str, np.ndarray]:
    out = {}
    with h5py.File(path) as f:
        f.visititems(lambda name, obj: out.update({name: obj[()]}) if isinstance(obj, h5py.Dataset) else None)
    return out


def test_small_stages_import_no_numba_and_write_numbas_products(built, tmp_path):
    """simulate (the demo), preprocess and fine-focus (an2012_exp1_small) and the two-step pfa2 (nie2016_small) as
    processes with the modules built:
    no numba or llvmlite imported, each compiled module loaded; the products equal those of the numba kernels
    (SARPROC_AOT=0) in every dataset, to float32 rounding (_equal_to_float32_rounding).

    The two-step's numba-free run is its old mosaic (``subimage_reach: 0``, 0.65 s of serial kernel work counted by
    aot.pick). At the default reach 0.5 the blended seams' warps of the grown cores count 1.09 s, past the 0.675 s
    that two threads allow (aot.serial_pays): numba pays there and is started part-way (docs/pfa.md, session 46:
    even with no spline work at all the resampling alone counts 0.71 s), so that run checks the products only."""
    d, _ = built
    on = {**os.environ, "SARPROC_AOT_DIR": str(d), "SARPROC_AOT": "1", "PYTHONPATH": str(ROOT)}
    off = {**on, "SARPROC_AOT": "0"}
    cfg = "configs/an2012_exp1_small.yaml"
    raw, pre, coarse = tmp_path / "raw.h5", tmp_path / "pre.h5", tmp_path / "coarse.h5"
    _stage(["simulate", cfg, "-o", str(raw), "-q"], off, tmp_path)
    _stage(["preprocess", str(raw), "--config", cfg, "-o", str(pre), "-q"], off, tmp_path)
    _stage(["coarse-focus", str(pre), "--config", cfg, "-o", str(coarse), "-q"], off, tmp_path)
    nie, nie_raw = "configs/nie2016_small.yaml", tmp_path / "nie_raw.h5"
    _stage(["simulate", nie, "-o", str(nie_raw), "-q"], off, tmp_path)
    mosaic = tmp_path / "nie2016_small_reach0.yaml"
    mosaic.write_text(
        (ROOT / nie).read_text().replace("  method: two_step\n", "  method: two_step\n  subimage_reach: 0\n")
    )
    assert "subimage_reach: 0" in mosaic.read_text()
    cases = {  # stage: (arguments, compiled modules loaded, no numba imported)
        "simulate": (["simulate", "configs/demo.yaml"], ("echo",), True),
        "preprocess": (["preprocess", str(raw), "--config", cfg], ("phasor",), True),
        "fine-focus": (
            ["fine-focus", str(coarse), "--config", cfg],
            ("block_copies", "stolt", "interp", "phasor"),
            True,
        ),
        "pfa2 reach 0": (["pfa2", str(nie_raw), "--config", str(mosaic)], ("interp", "pfa_spline"), True),
        "pfa2": (["pfa2", str(nie_raw), "--config", nie], ("interp", "pfa_spline"), False),
    }
    for stage, (args, names, numba_free) in cases.items():
        outs = {}
        for label, env in (("on", on), ("off", off)):
            outs[label] = tmp_path / f"{stage.replace(' ', '_')}_{label}.h5"
            loaded = _stage([*args, "-o", str(outs[label]), "-q"], env, tmp_path)
            if label == "on":
                if numba_free:
                    assert not [m for m in loaded if m.split(".")[0] in ("numba", "llvmlite")], stage
                for name in names:
                    assert any(m.startswith(f"_{name}_aot_") for m in loaded), (stage, name)
        a, b = _datasets(outs["on"]), _datasets(outs["off"])
        assert a.keys() == b.keys()
        for key in a:
            assert _equal_to_float32_rounding(a[key], b[key]), (stage, key)


class _Fake:
    """A stand-in compiled module."""

    __name__ = "_fake_aot_0"


def test_pick_takes_the_compiled_module_only_within_the_serial_budget(monkeypatch):
    group = aot.Kernels(name="fake", module="sarproc.dsp.phasor_kernels", sources=(), exports={}, owner="x:y")
    fake = _Fake()
    builds = []
    monkeypatch.setattr(aot.Kernels, "load", lambda self: fake)
    monkeypatch.setattr(aot.Kernels, "request_build", lambda self: builds.append(1) or True)
    monkeypatch.setattr(aot.Kernels, "numba", lambda self: "numba")
    monkeypatch.setattr(aot, "_SERIAL_SPENT", 0.0)
    monkeypatch.delitem(sys.modules, "sarproc.dsp.phasor_kernels", raising=False)
    assert group.pick(0.1, workers=2) is fake
    assert group.pick(0.1, workers=2) is fake  # 0.2 s serial spent: threads would have saved 0.09 s
    assert group.pick(1.0, workers=2) == "numba"  # past numba's start-up: the parallel kernels
    assert group.pick(0.01, workers=1) is fake  # one thread: nothing to save
    assert group.pick(0.01, workers=2, usable=False) == "numba" and not builds  # other types: never compiled
    monkeypatch.setattr(aot, "_SERIAL_SPENT", 0.0)
    monkeypatch.setattr(aot.Kernels, "load", lambda self: None)
    assert group.pick(0.01, workers=2) == "numba" and builds == [1]  # not built: numba, and a build started
    monkeypatch.setitem(sys.modules, "sarproc.dsp.phasor_kernels", object())
    assert group.pick(0.01, workers=2) == "numba" and builds == [1, 1]  # numba's kernels loaded: built all the same
    monkeypatch.setattr(aot.Kernels, "load", lambda self: fake)
    assert group.pick(0.01, workers=2) == "numba"  # numba's kernels already loaded: no reason to run serially


def test_a_build_request_names_the_owner(monkeypatch, tmp_path):
    monkeypatch.setenv("SARPROC_AOT", "1")
    monkeypatch.setenv("SARPROC_AOT_DIR", str(tmp_path / "aot"))
    started = []
    monkeypatch.setattr(aot.subprocess, "Popen", lambda args, **kw: started.append(args))
    for group in GROUPS:
        assert group.request_build()
        args = started[-1]
        assert args[1:4] == ["-m", "sarproc.product.aot", group.owner]
        assert args[4] == aot.module_key(group.source_paths)
        assert aot.owner_kernels(group.owner) is group
        assert not group.is_compiled(group.numba())
