"""evaluate's 3D kernels compiled ahead of time (sarproc.quality.kernels_aot): every export equal to numba's bit
for bit, and a small cube's evaluation with the module built imports no numba and reports numba's figures.

One build (~1 min here) serves the module; skipped without a C compiler.
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

from sarproc.product import aot
from sarproc.quality import kernels_aot

ROOT = Path(__file__).resolve().parents[2]
HAVE_CC = shutil.which(os.environ.get("CC", "cc")) is not None or shutil.which("gcc") is not None


@pytest.fixture(scope="module")
def built(aot_builds):
    """(directory, module): the 3D kernels built once, through the background builder's own command
    (the session starts the build: tests/conftest.py, aot_builds)."""
    if not HAVE_CC:
        pytest.skip("no C compiler: the kernels run in numba only")
    return build_aot_kernels(kernels_aot.QUALITY, aot_builds)


# Each export (serial) on the same arguments as numba's kernel (parallel where it is), compared in a process
# whose numba compiles its kernels itself (a private cache, see fresh_numba): the same bits.
COMPARE = """
import numpy as np
from sarproc.quality import kernels as nk, kernels_aot

k = kernels_aot.QUALITY.load()
assert k is not None and kernels_aot.QUALITY.is_compiled(k)
rng = np.random.default_rng(21)
cand = rng.standard_normal((700, 3))
cand /= np.linalg.norm(cand, axis=1)[:, None]
u = rng.standard_normal((900, 3))
u /= np.linalg.norm(u, axis=1)[:, None]
w = rng.random(900)
from sarproc.quality.metrics import _candidate_blocks
blocks = _candidate_blocks(np.ascontiguousarray(cand).tobytes(), 0.05)
density = k.orientation_density(cand, u, w, 0.05, *blocks)
assert np.array_equal(density, nk.orientation_density(cand, u, w, 0.05, *blocks))
mag = np.abs(rng.standard_normal((9, 11, 7)))
h = np.array([0.3, 0.2, 0.5])
for a, b in zip(k.strong_from_norms(mag, h, k.gradient_norms(mag, h), 0.05), nk.strong_gradients(mag, h, 0.05)):
    assert np.array_equal(a, b) and a.shape[0] > 0
V = np.eye(3) + 0.05 * rng.standard_normal((3, 3))
ridge = np.linalg.inv(V.T) / np.array([2.5, 1.7, 1.2])[:, None]
position, f_c, chirp = np.array([7.0, 5.3, 4.0]), np.array([0.11, -0.27, 0.43]), np.array([0.008, -0.011, 0.003])
q = np.arange(-12, 13) / 8.0
table = np.stack([np.zeros(25), np.zeros(25), np.sinc(q) * (1 - 0.1 * q**2)])
shapes = [
    (np.zeros(3), np.zeros((3, 25)), np.zeros(3)),
    (np.array([6.0, 0.0, 0.0]), table, np.array([0.0, 0.0, 8.0])),
]
origins, sizes = np.array([[0.0, 1.0, 2.0], [3.0, 1.0, 0.0]]), np.array([[7, 6, 5], [5, 8, 6]], dtype=np.int64)
step = np.array([2.0, 1.0, 1.0])
points = np.ascontiguousarray(rng.uniform(0, 12, (3, 400)))
points[:, :5] = position[:, None]  # on the ridge coordinates' zero
inverse = np.arange(7 * 6 * 5 + 5 * 8 * 6, dtype=np.int64) % 300
for hamming in (False, True):
    for period, tab, rate in shapes:
        args = (position, ridge, f_c, chirp, period, tab, rate, hamming)
        for name in ("ideal_response", "ideal_response_serial"):
            assert np.array_equal(getattr(k, name)(points, *args), getattr(nk, name)(points, *args)), name
        a = k.ideal_response_box(origins[1], step, sizes[1], *args)
        assert np.array_equal(a, nk.ideal_response_box(origins[1], step, sizes[1], *args))
        a = k.ideal_response_boxes(origins, step, sizes, inverse, 300, *args)
        assert np.array_equal(a, nk.ideal_response_boxes(origins, step, sizes, inverse, 300, *args))
        a = k.ideal_response_boxes_slopes(origins, step, sizes, inverse, 300, *args)
        assert np.array_equal(a, nk.ideal_response_boxes_slopes(origins, step, sizes, inverse, 300, *args))
coef = rng.standard_normal(5000) + 1j * rng.standard_normal(5000)
x = rng.uniform(-np.pi, np.pi, 5000)
for chunks in (1, 2, 3):
    assert np.array_equal(k.spread(coef, x, 256, 16, 36.8, chunks), nk.spread(coef, x, 256, 16, 36.8, chunks))
g = rng.standard_normal((900, 3))
assert np.array_equal(k.cone_sum(u, g, u[3].copy(), 0.9), nk.cone_sum(u, g, u[3].copy(), 0.9))
print("equal")
"""


def test_compiled_kernels_equal_numbas(built, fresh_numba):
    """Each export (serial) on the same arguments as numba's freshly compiled kernel: the same bits."""
    env = compiled_module_env(built[0], fresh_numba)
    done = subprocess.run([sys.executable, "-c", COMPARE], capture_output=True, text=True, env=env, check=False)
    assert done.returncode == 0 and done.stdout.strip().endswith("equal"), done.stderr[-3000:]


def test_a_cube_reserves_the_compiled_module_only_when_all_its_kernels_pay(monkeypatch):
    """reserve() asks pick for the whole cube's estimated serial work at once, weighed against this module's numba
    start-up (kernels_aot.STARTUP_S): a small cube's and paper 004's (7 targets, chips of 131 x 105 x 41: 0.89 s
    serial, measured) pay on two CPUs; paper 004's does not on 16, nor a cube of 20 such targets on two."""
    asked = []
    monkeypatch.setattr(aot.Kernels, "pick", lambda self, s, workers=None, usable=True: asked.append(s) or s)
    kernels_aot.reserve(3, 20 * 20 * 20)
    kernels_aot.reserve(7, 131 * 105 * 41)
    kernels_aot.reserve(20, 131 * 105 * 41)
    assert aot.serial_pays(asked[0], 2) and aot.serial_pays(asked[1], 2)
    assert not aot.serial_pays(asked[1], 16) and not aot.serial_pays(asked[2], 2)


CUBE = """
import json, sys
import numpy as np
from sarproc.quality.metrics import EvaluateParams, evaluate_image
steps, res = (0.5, 0.4, 0.3), (0.58, 0.46, 0.35)
coords = [(np.arange(n) - n // 2) * s for n, s in zip((30, 34, 26), steps)]
e, a, r = np.meshgrid(*coords, indexing="ij")
img = np.zeros(e.shape, dtype=complex)
targets = [(0.2, -0.3, 0.1), (0.2, 2.9, 0.1), (-3.8, -0.3, 0.4)]
for (te, ta, tr), amp in zip(targets, (1.0, 0.6j, 0.8)):
    de, da, dr = e - te, a - ta, r - tr
    img += (amp * np.sinc(0.886 / res[0] * (de + 0.1 * dr)) * np.sinc(0.886 / res[1] * da)
            * np.sinc(0.886 / res[2] * (dr + 0.12 * da))
            * np.exp(2j * np.pi * (0.3 / steps[1] * da - 0.2 / steps[0] * de)))
params = EvaluateParams(neighbour_orders=0)
rep = evaluate_image(img, ("elevation", "azimuth", "range"), coords, res, targets, params=params)
print(json.dumps(rep.to_dict()))
print(json.dumps(sorted(sys.modules)))
"""


def test_a_small_cube_imports_no_numba_and_reports_numbas_figures(built, fresh_numba):
    """A crowded skewed cube (tests/quality/test_fast_path.py's: neighbours fitted, subtracted, oblique cuts; every
    3D kernel runs) evaluated in a fresh process with the module built: no numba or llvmlite imported, the
    compiled module loaded, and the report equal to the one with numba's kernels (SARPROC_AOT=0)."""
    on = compiled_module_env(built[0], fresh_numba)
    runs = {}
    for label, env in (("on", on), ("off", {**on, "SARPROC_AOT": "0"})):
        done = subprocess.run([sys.executable, "-c", CUBE], capture_output=True, text=True, env=env, check=False)
        assert done.returncode == 0, done.stderr[-2000:]
        report, modules = done.stdout.strip().splitlines()[-2:]
        runs[label] = (report, json.loads(modules))  # the report as JSON text: NaN figures compare equal
    loaded = runs["on"][1]
    assert not [m for m in loaded if m.split(".")[0] in ("numba", "llvmlite")]
    assert any(m.startswith("_quality_aot_") for m in loaded)
    assert "numba" in runs["off"][1] and runs["on"][0] == runs["off"][0]
