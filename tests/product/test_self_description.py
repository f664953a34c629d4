"""Products describe themselves (issue 12): units on every dataset and radar attribute, named aux
dims (no phony_dim in xarray), axis units off the values' ``units``, the optional absolute
reference (UTC time, geodetic point) carried losslessly from the scene YAML to the product."""

from __future__ import annotations

import json
import math

import h5py
import numpy as np
import pytest

from sarproc.product.errors import InputError
from sarproc.product.io import read_product, write_product
from sarproc.product.metadata import RADAR_UNITS, RadarMetadata, parse_utc
from sarproc.simulation.scene import scene_from_mapping
from sarproc.simulation.simulate import simulate

REFERENCE = {
    "time": "2024-05-01T12:30:00.25+02:00",
    "latitude": "48.137 deg",
    "longitude": "-11.575 deg",
    "height": "520 m",
}


@pytest.fixture
def raw(scene_mapping):
    scene = scene_from_mapping(
        scene_mapping(acquisition={"mode": "spotlight", "aperture_time": "0.1 s"}, reference=REFERENCE)
    )
    return simulate(scene)


def test_reference_reaches_the_radar_metadata_in_si(raw):
    r = raw.radar
    assert r.reference_utc == "2024-05-01T10:30:00.250000Z"
    assert r.reference_latitude == pytest.approx(math.radians(48.137), abs=1e-15)
    assert r.reference_longitude == pytest.approx(math.radians(-11.575), abs=1e-15)
    assert r.reference_height == 520.0


def test_metadata_roundtrip_is_lossless_with_and_without_reference(raw, tmp_path):
    for radar in (
        raw.radar,
        raw.radar.replace(reference_utc=None, reference_latitude=None, reference_longitude=None, reference_height=None),
    ):
        write_product(
            tmp_path / "p.h5", raw.derive(raw.kind, raw.data, raw.dims, raw.coords, radar=radar), overwrite=True
        )
        assert read_product(tmp_path / "p.h5").radar == radar


def test_every_dataset_and_radar_attribute_has_a_unit(raw, tmp_path):
    write_product(tmp_path / "p.h5", raw)
    with h5py.File(tmp_path / "p.h5") as f:
        seen = []
        f.visititems(lambda name, obj: seen.append((name, obj)) if isinstance(obj, h5py.Dataset) else None)
        for name, d in seen:
            if d.dtype.names:  # the compound targets table: one unit per field
                units = json.loads(d.attrs["field_units"])
                assert set(units) == set(d.dtype.names), name
            else:
                assert "units" in d.attrs, name
        radar_units = json.loads(f["radar"].attrs["units"])
        assert set(radar_units) == set(f["radar"].attrs) - {"units"}
        assert radar_units["prf"] == "Hz" and radar_units["reference_latitude"] == "rad"
        assert f["aux/platform_position"].attrs["units"] == "m"
        assert f["signal"].attrs["units"] == "1"
    assert set(RADAR_UNITS) == {f.name for f in __import__("dataclasses").fields(RadarMetadata)}


def test_xarray_sees_named_dims_everywhere(raw, tmp_path):
    xr = pytest.importorskip("xarray")
    write_product(tmp_path / "p.h5", raw)
    with xr.open_dataset(tmp_path / "p.h5", engine="h5netcdf") as ds:
        assert not [d for d in ds.dims if str(d).startswith("phony_dim")]
        assert ds["azimuth_time"].attrs["units"] == "s" and ds["signal"].attrs["units"] == "1"
    with xr.open_dataset(tmp_path / "p.h5", engine="h5netcdf", group="aux") as aux:
        assert not [d for d in aux.dims if str(d).startswith("phony_dim")]
        assert aux["platform_position"].dims == ("pulse", "xyz")
        assert aux["rx_offset"].dims == ("receiver", "xyz")
        assert aux.sizes["pulse"] == raw.data.shape[0]


def test_aux_scales_are_not_read_back_as_aux_arrays(raw, tmp_path):
    write_product(tmp_path / "p.h5", raw)
    back = read_product(tmp_path / "p.h5")
    assert set(back.aux) == set(raw.aux)
    for k in raw.aux:
        np.testing.assert_array_equal(back.aux[k], raw.aux[k])


@pytest.mark.parametrize(
    "text,canonical",
    [
        ("2024-05-01T10:00:00Z", "2024-05-01T10:00:00.000000Z"),
        ("2024-05-01T12:00:00+02:00", "2024-05-01T10:00:00.000000Z"),
        ("2024-12-31T23:59:59.999999-01:00", "2025-01-01T00:59:59.999999Z"),
    ],
)
def test_utc_canonical_form(text, canonical):
    assert parse_utc(text) == canonical


@pytest.mark.parametrize("text", ["2024-05-01T10:00:00", "noon", "2024-13-01T00:00:00Z"])
def test_utc_needs_a_zone_and_a_date(text):
    with pytest.raises(InputError):
        parse_utc(text)
