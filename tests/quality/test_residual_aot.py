"""The residual's kernels compiled ahead of time (sarproc.quality.residual_aot): equal to numba's bit for bit, and
an evaluate of a 2D image with the module built imports no numba and writes the report numba's kernels write.

One build (~20-30 s here) serves the module; skipped without a C compiler.
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
from conftest import build_aot_kernels

from sarproc.quality import residual_aot
from sarproc.quality.residual import _strip_count, spectral_orders

ROOT = Path(__file__).resolve().parents[2]
HAVE_CC = shutil.which(os.environ.get("CC", "cc")) is not None or shutil.which("gcc") is not None


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """(directory, module): the residual's kernels built once, through the background builder's own command."""
    if not HAVE_CC:
        pytest.skip("no C compiler: the kernels run in numba only")
    d = tmp_path_factory.mktemp("aot")
    return d, build_aot_kernels(residual_aot.RESIDUAL, d)


def _points(rng, ndim: int, strips: int) -> np.ndarray:
    """Ridge coordinates with the kernels' special points: removable singularities of an order (c + n / 2 = 0)
    and within 1e-7 of one, the last axis' zero, a Dirichlet pole, a keystoned axis within 1e-3 of its zero."""
    c = rng.uniform(-60, 60, size=(ndim, 3000))
    c[:, :300] = rng.uniform(-3, 3, size=(ndim, 300))
    c[0, 300:320] = 0.5
    c[0, 320:340] = 0.5 + 1e-9
    c[-1, 340:360] = 0.0
    c[-1, 360:380] = rng.uniform(-1e-4, 1e-4, 20)
    c[-1, 380:400] = 0.5 * strips + rng.uniform(-1e-3, 1e-3, 20)
    c[0, 400:440] = 0.5 + rng.uniform(-1e-3, 1e-3, 40)
    return c


@pytest.mark.parametrize("ndim", [2, 3])
@pytest.mark.parametrize("keystone", [0.003, 0.03, -0.15])
def test_compiled_kernels_equal_numbas(built, ndim, keystone):
    """Every export on the same arguments as numba's kernel: the same bits (both compile the source without
    fast-math, for the host CPU), special points included."""
    from sarproc.quality import residual_kernels as rk

    k = built[1]
    rng = np.random.default_rng(11)
    orders = np.ascontiguousarray(spectral_orders(ndim, 1, 2), dtype=np.int64)
    kappa = np.linspace(keystone, 0.5 * keystone, ndim - 1)
    strips = _strip_count(kappa)
    coef = rng.normal(size=len(orders)) + 1j * rng.normal(size=len(orders))
    c = _points(rng, ndim, strips)
    a, b = k.keystone_columns(c, orders, kappa, strips), rk.keystone_columns(c, orders, kappa, strips)
    assert np.array_equal(a, b) and np.isfinite(a).all()
    a = k.keystone_derivatives(c, orders, coef, kappa, strips)
    b = rk.keystone_derivatives(c, orders, coef, kappa, strips)
    assert np.array_equal(a, b) and np.isfinite(a).all()
    if ndim == 2:  # the box kernel: a skewed box whose rows hit c_az = -n / 2
        c0, d_row, d_col = np.array([-20.0, -31.5]), np.array([0.5, 0.04]), np.array([0.0, 0.41])
        a = k.keystone_box_sum(c0, d_row, d_col, 90, 150, orders, coef, kappa, strips)
        b = rk.keystone_box_sum(c0, d_row, d_col, 90, 150, orders, coef, kappa, strips)
        assert np.array_equal(a, b) and np.isfinite(a).all()


def test_the_wrappers_take_any_layout(built, monkeypatch):
    """The residual's calls (strided views, int32 orders, a list for kappa) reach the compiled exports, whose
    signatures are C-contiguous float64 / int64 / complex128."""
    from sarproc.quality import residual_kernels as rk

    monkeypatch.setattr(residual_aot, "kernels", lambda: built[1])
    rng = np.random.default_rng(12)
    orders = spectral_orders(2, 1, 2).astype(np.int32)
    c = np.asfortranarray(_points(rng, 2, 3))
    coef = (rng.normal(size=len(orders)) + 1j * rng.normal(size=len(orders))).tolist()
    got = residual_aot.keystone_derivatives(c[:, ::2], orders, coef, [0.01], 3)
    want = rk.keystone_derivatives(
        np.ascontiguousarray(c[:, ::2]), orders.astype(np.int64), np.array(coef), np.array([0.01]), 3
    )
    assert np.array_equal(got, want)


def _evaluate(image: Path, out: Path, env: dict) -> list[str]:
    """``sarproc evaluate`` in a fresh process; the modules it imported."""
    code = (
        "import json, sys\nfrom sarproc.cli.main import run_cli\n"
        f"assert run_cli(['evaluate', {str(image)!r}, '-o', {str(out)!r}, '-q']) == 0\n"
        "print(json.dumps(sorted(sys.modules)))"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=False, cwd=ROOT)
    assert done.returncode == 0, done.stderr[-2000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_evaluate_imports_no_numba_and_reports_numbas_figures(built, tmp_path):
    """The demo image's evaluate (residual on: every residual kernel runs) with the module built: no numba or
    llvmlite imported, the compiled module loaded, and the same report as with numba's kernels (SARPROC_AOT=0)."""
    d, _ = built
    on = {**os.environ, "SARPROC_AOT_DIR": str(d), "SARPROC_AOT": "1", "PYTHONPATH": str(ROOT)}
    off = {**on, "SARPROC_AOT": "0"}
    cfg = str(ROOT / "configs" / "demo.yaml")
    raw, image = tmp_path / "raw.h5", tmp_path / "image.h5"
    for args in (["simulate", cfg, "-o", str(raw)], ["backproject", str(raw), "--config", cfg, "-o", str(image)]):
        done = subprocess.run(
            [sys.executable, "-m", "sarproc", *args, "-q"], env=off, cwd=ROOT, capture_output=True, check=False
        )
        assert done.returncode == 0, done.stderr[-2000:]
    loaded = _evaluate(image, tmp_path / "on.json", on)
    assert not [m for m in loaded if m.split(".")[0] in ("numba", "llvmlite")]
    assert any(m.startswith("_residual_aot_") for m in loaded)
    _evaluate(image, tmp_path / "off.json", off)
    on_report, off_report = (json.loads((tmp_path / f"{t}.json").read_text()) for t in ("on", "off"))
    assert on_report["residual"] is not None and on_report == off_report
