import dataclasses
import math

import pytest
from hypothesis import given, strategies as st

from sarproc.product.config import as_dict, build, param
from sarproc.product.errors import InputError
from sarproc.product.units import parse_quantity


@pytest.mark.parametrize(
    "text,kind,si",
    [
        ("10 GHz", "frequency", 10e9),
        ("300 km", "length", 3e5),
        ("30 deg", "angle", math.radians(30)),
        ("0.5 rad", "angle", 0.5),
        ("10 us", "time", 1e-5),
        ("7 km/s", "velocity", 7000.0),
        ("1.5e3 Hz", "frequency", 1500.0),
        ("20 dB", "decibel", 20.0),
        ("-3 m", "length", -3.0),
    ],
)
def test_quantities_convert_to_si(text, kind, si):
    assert parse_quantity(text, kind, "k") == pytest.approx(si, rel=1e-15)


def test_bare_number_is_si_except_for_angles():
    assert parse_quantity(60e6, "frequency", "k") == 60e6
    with pytest.raises(InputError, match="radar.squint: an angle needs a unit"):
        parse_quantity(30, "angle", "radar.squint")


def test_unit_of_the_wrong_kind_is_named():
    with pytest.raises(InputError, match=r"radar.bandwidth: unit 'm' is not a frequency unit \('m' is a length\)"):
        parse_quantity("10 m", "frequency", "radar.bandwidth")


@pytest.mark.parametrize("bad", ["ten GHz", "GHz", "nan Hz", [1], None])
def test_unreadable_values_are_refused(bad):
    with pytest.raises(InputError, match="k"):
        parse_quantity(bad, "frequency", "k")


@given(
    st.floats(min_value=-1e6, max_value=1e6, allow_nan=False), st.sampled_from([("km", 1e3), ("m", 1.0), ("mm", 1e-3)])
)
def test_length_prefixes_scale_exactly(x, unit):
    sym, factor = unit
    assert parse_quantity(f"{x!r} {sym}", "length", "k") == pytest.approx(x * factor, rel=1e-12, abs=1e-300)


@dataclasses.dataclass(frozen=True)
class Inner:
    width: float = param("length", gt=0)


@dataclasses.dataclass(frozen=True)
class Outer:
    frequency: float = param("frequency", gt=0)
    name: str = param(default="x", choices=("x", "y"))
    inner: Inner = param(default=Inner(1.0))
    items: tuple[Inner, ...] = param(default=())


def test_build_converts_nested_models():
    obj = build(Outer, {"frequency": "1 GHz", "inner": {"width": "2 km"}, "items": [{"width": "1 m"}]})
    assert obj.frequency == 1e9 and obj.inner.width == 2000.0 and obj.items[0].width == 1.0
    assert as_dict(obj) == {"frequency": 1e9, "name": "x", "inner": {"width": 2000.0}, "items": [{"width": 1.0}]}


@pytest.mark.parametrize(
    "mapping,message",
    [
        ({"frequency": "1 GHz", "colour": 1}, r"f.yaml: unknown key\(s\) 'colour'"),
        ({}, "f.yaml: frequency: required key is missing"),
        ({"frequency": "-1 GHz"}, r"f.yaml: frequency: '-1 GHz' is out of range: must be > 0 Hz$"),
        ({"frequency": "1 GHz", "name": "z"}, "f.yaml: name: 'z' is not one of"),
        (
            {"frequency": "1 GHz", "inner": {"width": "0 m"}},
            "f.yaml: inner.width: '0 m' is out of range: must be > 0 m$",
        ),
        ({"frequency": "1 GHz", "items": [{"width": "1 m"}, {"wide": 1}]}, r"f.yaml: items\[1\]: unknown key"),
    ],
)
def test_build_errors_name_file_and_key(mapping, message):
    with pytest.raises(InputError, match=message):
        build(Outer, mapping, source="f.yaml")


def test_a_yaml_boolean_where_text_is_expected_says_to_quote_it():
    """Session 42 trial: a target named OFF (unquoted) was refused as "expected a string, got False", with no
    word that YAML had read it as a boolean."""
    import yaml

    from sarproc.simulation.scene import scene_from_mapping

    scene = {
        "radar": {
            "carrier_frequency": "10 GHz",
            "bandwidth": "20 MHz",
            "pulse_duration": "5 us",
            "range_sampling_rate": "24 MHz",
            "prf": "800 Hz",
        },
        "platform": {"velocity": "7 km/s"},
        "geometry": {"reference_range": "300 km"},
        "acquisition": {"mode": "spotlight", "aperture_time": "0.1 s"},
        "targets": yaml.safe_load("points: [{name: OFF}]"),
    }
    with pytest.raises(InputError, match=r'name: expected a string, got False; YAML reads .* quote it \("OFF"\)'):
        scene_from_mapping(scene, source="scene.yaml")
