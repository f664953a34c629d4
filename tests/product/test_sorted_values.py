"""sarproc.product.sorted_values: np.median's and np.unique's results bit for bit, without importing numpy.ma."""

import json
import subprocess
import sys

import numpy as np
import pytest

from sarproc.product.sorted_values import median, unique_integers


@pytest.mark.parametrize("dtype", [np.float64, np.float32, np.int64, np.int32])
def test_median_is_numpys_bit_for_bit(dtype):
    rng = np.random.default_rng(7)
    for n in [*range(1, 34), 255, 256, 1001, 4096]:
        for scale in (1e-7, 1.0, 3e5):
            x = (rng.standard_normal(n) * scale).astype(dtype)
            assert np.float64(median(x)).tobytes() == np.float64(np.median(x)).tobytes(), (n, scale)
    x = rng.standard_normal((7, 9))  # any shape: all its values, as np.median without an axis
    assert median(x) == float(np.median(x))
    assert median([3.0, 1.0, 2.0, 10.0]) == float(np.median([3.0, 1.0, 2.0, 10.0])) == 2.5


def test_median_of_values_with_nan_is_nan_and_of_none_an_error():
    x = np.arange(10.0)
    x[3] = np.nan
    assert np.isnan(median(x)) and np.isnan(np.median(x))
    with pytest.raises(ValueError):
        median(np.zeros(0))


@pytest.mark.parametrize("dtype", [np.int64, np.int32, np.uint8, bool])
def test_unique_integers_are_numpys(dtype):
    rng = np.random.default_rng(8)
    for n in (0, 1, 2, 5, 64, 1000):
        x = rng.integers(0, 40, n).astype(dtype)
        got, want = unique_integers(x), np.unique(x)
        assert got.dtype == want.dtype and np.array_equal(got, want)
    assert np.array_equal(unique_integers([[3, 1], [3, 2]]), [1, 2, 3])
    with pytest.raises(TypeError):
        unique_integers([0.5, 1.0])


def test_median_and_unique_integers_do_not_import_numpy_ma():
    # np.median's NaN check and np.unique's mask check import numpy.ma (10-25 ms of a process's start;
    # docs/performance.md, fourteenth round)
    code = (
        "import json, sys\nimport numpy as np\nfrom sarproc.product.sorted_values import median, unique_integers\n"
        "median(np.arange(10.0)), unique_integers(np.arange(10))\nprint(json.dumps('numpy.ma' in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert json.loads(out.strip().splitlines()[-1]) is False
