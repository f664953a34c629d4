"""sarproc.product.special: scipy.special's Fresnel integrals without importing scipy.special (issue 20 item 5).

The ufunc loaded from scipy's extension file gives scipy.special.fresnel's values bit for bit, and importing it
and calling it import no scipy subpackage (``import scipy.special`` costs a process 0.2-0.4 s of CPU,
docs/performance.md, "evaluate against the stage that made the image", session 33).
"""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from sarproc.product import special


def test_fresnel_equals_scipys_bit_for_bit():
    scipy_special = pytest.importorskip("scipy.special")
    rng = np.random.default_rng(5)
    # the arguments _fresnel_box passes ((a +- b) / sqrt(b)): small and large, both signs, the series'
    # and the asymptotic expansion's ranges and their boundary, zeros, and huge values
    x = np.concatenate(
        [
            rng.normal(0.0, 3.0, 20000),
            rng.normal(0.0, 300.0, 20000),
            np.linspace(-40.0, 40.0, 80001),
            [0.0, -0.0, 2.5, -2.5, 1e-300, 1e300, -1e300, np.inf, -np.inf],
        ]
    )
    got, want = special.fresnel(x), scipy_special.fresnel(x)
    for g, w in zip(got, want):
        assert g.dtype == w.dtype == np.float64
        assert np.array_equal(g.view(np.uint64), w.view(np.uint64))


def test_fresnel_imports_no_scipy_subpackage():
    code = (
        "import json, sys\nimport numpy as np\nfrom sarproc.product.special import fresnel\n"
        "s, c = fresnel(np.linspace(-3, 3, 7))\nassert np.isfinite(s).all() and np.isfinite(c).all()\n"
        "print(json.dumps(sorted(sys.modules)))"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    loaded = json.loads(done.stdout.strip().splitlines()[-1])
    assert not [m for m in loaded if m.startswith("scipy.") and not m.startswith(("scipy._", "scipy.version"))]
    assert "scipy.special" not in loaded
