"""Per-target theoretical IRW (targets fields irw_<axis>): round trip, older files, bad values."""

import h5py
import numpy as np
import pytest
from test_io import image_product

from sarproc.product.errors import InputError
from sarproc.product.io import read_product, write_product
from sarproc.product.model import TARGET_DTYPE, TARGET_IRW_FIELDS


def test_target_irw_roundtrips_and_defaults_to_not_recorded(tmp_path):
    p = image_product()
    assert np.all(p.targets["irw_azimuth"] == 0)  # make_targets: 0, not recorded
    p.targets["irw_azimuth"] = [0.95, 1.1]
    p.targets["irw_range"][1] = 0.7
    write_product(tmp_path / "x.h5", p)
    q = read_product(tmp_path / "x.h5")
    np.testing.assert_array_equal(q.targets["irw_azimuth"], [0.95, 1.1])
    np.testing.assert_array_equal(q.targets["irw_range"], [0.0, 0.7])
    assert np.all(q.targets["irw_elevation"] == 0)


def test_file_without_target_irw_fields_reads_as_not_recorded(tmp_path):
    p = image_product()
    write_product(tmp_path / "old.h5", p)
    old = np.dtype([(n, TARGET_DTYPE[n]) for n in TARGET_DTYPE.names if n not in TARGET_IRW_FIELDS])
    with h5py.File(tmp_path / "old.h5", "r+") as f:  # the table as written before the fields existed
        t = f["targets"][()]
        rows = np.zeros(len(t), old)
        for n in old.names:
            rows[n] = t[n]
        del f["targets"]
        f.create_dataset("targets", data=rows)
    q = read_product(tmp_path / "old.h5")
    assert q.targets.dtype == TARGET_DTYPE
    for n in TARGET_IRW_FIELDS:
        assert np.all(q.targets[n] == 0)
    np.testing.assert_array_equal(q.targets["range"], p.targets["range"])


@pytest.mark.parametrize("value", [-1.0, np.nan, np.inf])
def test_bad_target_irw_is_refused(tmp_path, value):
    p = image_product()
    p.targets["irw_range"][0] = value
    write_product(tmp_path / "x.h5", p)
    with pytest.raises(InputError, match="irw_range"):
        read_product(tmp_path / "x.h5")


def test_target_theory_fields_roundtrip_and_bad_levels_are_refused(tmp_path):
    p = image_product()
    p.targets["null_azimuth"] = [0.7, 0.8]
    p.targets["pslr_range"] = [-42.7, -13.3]
    p.targets["islr_range"] = [-36.8, 0.5]  # an ISLR above 0 dB is a real (side-lobe-lit) theory
    write_product(tmp_path / "x.h5", p)
    q = read_product(tmp_path / "x.h5")
    for f in ("null_azimuth", "pslr_range", "islr_range"):
        np.testing.assert_array_equal(q.targets[f], p.targets[f])
    p.targets["pslr_range"][0] = 1.0  # a side lobe above the peak is no PSLR
    write_product(tmp_path / "y.h5", p)
    with pytest.raises(InputError, match="pslr_range"):
        read_product(tmp_path / "y.h5")
