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

import pytest
from conftest import build_aot_kernels, compiled_module_env

from sarproc.quality import residual_aot

ROOT = Path(__file__).resolve().parents[2]
HAVE_CC = shutil.which(os.environ.get("CC", "cc")) is not None or shutil.which("gcc") is not None


@pytest.fixture(scope="module")
def built(aot_builds):
    """(directory, module): the residual's kernels built once, through the background builder's own command
    (the session starts the build: tests/conftest.py, aot_builds)."""
    if not HAVE_CC:
        pytest.skip("no C compiler: the kernels run in numba only")
    return build_aot_kernels(residual_aot.RESIDUAL, aot_builds)


# The comparisons run in a process whose numba compiles the kernels itself into a private cache (fresh_numba):
# a cache written by other processes can differ from a fresh compile in the last bits (docs/performance.md,
# "Traced (session 18)"), which a bit-for-bit comparison must not depend on.
COMPARE = """
import sys
import numpy as np
from sarproc.quality import residual_aot, residual_kernels as rk
from sarproc.quality.residual import _strip_count, spectral_orders


def points(rng, ndim, strips):
    # ridge coordinates with the kernels' special points: removable singularities of an order (c + n / 2 = 0)
    # and within 1e-7 of one, the last axis' zero, a Dirichlet pole, a keystoned axis within 1e-3 of its zero
    c = rng.uniform(-60, 60, size=(ndim, 3000))
    c[:, :300] = rng.uniform(-3, 3, size=(ndim, 300))
    c[0, 300:320] = 0.5
    c[0, 320:340] = 0.5 + 1e-9
    c[-1, 340:360] = 0.0
    c[-1, 360:380] = rng.uniform(-1e-4, 1e-4, 20)
    c[-1, 380:400] = 0.5 * strips + rng.uniform(-1e-3, 1e-3, 20)
    c[0, 400:440] = 0.5 + rng.uniform(-1e-3, 1e-3, 40)
    return c


def same(a, b, what):
    assert np.array_equal(a, b) and np.isfinite(a).all(), what


k = residual_aot.RESIDUAL.load()
assert k is not None and residual_aot.RESIDUAL.is_compiled(k), "the compiled module did not load"
for ndim in (2, 3):
    for keystone in (0.003, 0.03, -0.15):
        rng = np.random.default_rng(11)
        orders = np.ascontiguousarray(spectral_orders(ndim, 1, 2), dtype=np.int64)
        kappa = np.linspace(keystone, 0.5 * keystone, ndim - 1)
        strips = _strip_count(kappa)
        coef = rng.normal(size=len(orders)) + 1j * rng.normal(size=len(orders))
        c = points(rng, ndim, strips)
        what = f"ndim {ndim}, keystone {keystone}: "
        a = k.keystone_columns(c, orders, kappa, strips)
        same(a, rk.keystone_columns(c, orders, kappa, strips), what + "columns")
        a = k.keystone_derivatives(c, orders, coef, kappa, strips)
        same(a, rk.keystone_derivatives(c, orders, coef, kappa, strips), what + "derivatives")
        if ndim == 2:  # the box kernel: a skewed box whose rows hit c_az = -n / 2
            box = (np.array([-20.0, -31.5]), np.array([0.5, 0.04]), np.array([0.0, 0.41]), 90, 150)
            a = k.keystone_box_sum(*box, orders, coef, kappa, strips)
            same(a, rk.keystone_box_sum(*box, orders, coef, kappa, strips), what + "box sum")
            warp = (np.array([1e-4, -2e-4]), np.array([3e-4, 5e-5]), np.array([-1e-4, 2e-4]))
            car = np.array([0.3, 0.2, -0.7, 1e-4, -2e-4, 3e-4])
            a = k.keystone_warped_box_sum(*box[:3], *warp, *box[3:], orders, coef, kappa, strips, car)
            b = rk.keystone_warped_box_sum(*box[:3], *warp, *box[3:], orders, coef, kappa, strips, car)
            same(a, b, what + "warped")
# the cuts' line-sum spreading (two blocks of terms)
rng = np.random.default_rng(13)
u = rng.uniform(0, 64, 3000)
args = (rng.normal(size=3000), rng.normal(size=3000), u, np.ceil(u - 8.0), 64, 16, 36.8, 2000)
same(k.spread_bins(*args), rk.spread_bins(*args), "spread")
# the residual's own calls (strided views, int32 orders, a list for kappa) reach the exports, whose signatures
# are C-contiguous float64 / int64 / complex128
residual_aot.kernels = lambda: k  # pick() would take numba's, loaded above
rng = np.random.default_rng(12)
orders = spectral_orders(2, 1, 2).astype(np.int32)
c = np.asfortranarray(points(rng, 2, 3))
coef = (rng.normal(size=len(orders)) + 1j * rng.normal(size=len(orders))).tolist()
got = residual_aot.keystone_derivatives(c[:, ::2], orders, coef, [0.01], 3)
want = rk.keystone_derivatives(
    np.ascontiguousarray(c[:, ::2]), orders.astype(np.int64), np.array(coef), np.array([0.01]), 3
)
same(got, want, "wrapper")
print("equal")
"""


def test_compiled_kernels_equal_numbas(built, fresh_numba):
    """Every export on the same arguments as numba's freshly compiled kernel (2D and 3D, three keystones): the
    same bits (both compile the source without fast-math, for the host CPU), special points included; and the
    residual's wrappers take any layout of their arguments."""
    env = compiled_module_env(built[0], fresh_numba)
    done = subprocess.run([sys.executable, "-c", COMPARE], capture_output=True, text=True, env=env, check=False)
    assert done.returncode == 0 and done.stdout.strip().endswith("equal"), done.stderr[-3000:]


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


def test_evaluate_imports_no_numba_and_reports_numbas_figures(built, fresh_numba, tmp_path):
    """The demo image's evaluate (residual on: every residual kernel runs) with the module built: no numba,
    llvmlite or scipy subpackage imported, the compiled module loaded, and the same report as with numba's
    kernels (SARPROC_AOT=0)."""
    d, _ = built
    on = compiled_module_env(d, fresh_numba)
    off = {**on, "SARPROC_AOT": "0"}
    cfg = str(ROOT / "configs" / "demo.yaml")
    raw, image = tmp_path / "raw.h5", tmp_path / "image.h5"
    # the image both evaluates read: its simulate and backproject load numba's kernels from the session's cache
    # (compiled into fresh_numba they took ~30 s of this test); only the evaluates' kernels are compared
    made = {**os.environ, "SARPROC_AOT": "0", "PYTHONPATH": str(ROOT)}
    for args in (["simulate", cfg, "-o", str(raw)], ["backproject", str(raw), "--config", cfg, "-o", str(image)]):
        done = subprocess.run(
            [sys.executable, "-m", "sarproc", *args, "-q"], env=made, cwd=ROOT, capture_output=True, check=False
        )
        assert done.returncode == 0, done.stderr[-2000:]
    loaded = _evaluate(image, tmp_path / "on.json", on)
    assert not [m for m in loaded if m.split(".")[0] in ("numba", "llvmlite")]
    assert any(m.startswith("_residual_aot_") for m in loaded)
    # nor scipy.special (0.2-0.4 s of CPU), though its targets' bows are fitted (their Fresnel integrals)
    assert not [m for m in loaded if m.startswith("scipy.") and not m.startswith(("scipy._", "scipy.version"))]
    _evaluate(image, tmp_path / "off.json", off)
    on_report, off_report = (json.loads((tmp_path / f"{t}.json").read_text()) for t in ("on", "off"))
    assert on_report["residual"] is not None and on_report == off_report
