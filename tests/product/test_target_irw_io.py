"""Per-target theoretical IRW (targets fields irw_<axis>): round trip, older files, bad values."""

import h5py
import numpy as np
import pytest

from sarproc.product.errors import InputError
from sarproc.product.io import read_product, write_product
from sarproc.product.model import TARGET_DTYPE, TARGET_IRW_FIELDS

from test_io import image_product


def test_target_irw_roundtrips_and_defaults_to_not_recorded(tmp_path):
    p = image_product()
    assert np.all(p.targets["irw_azimuth"] == 0)           # make_targets: 0, not recorded
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
    with h5py.File(tmp_path / "old.h5", "r+") as f:      # the table as written before the fields existed
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
