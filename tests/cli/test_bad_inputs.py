"""Batch-job behaviour on bad input (issue 12): every case exits 2 (or 1 for processing failures)
with a one-line message naming the file and the YAML key or HDF5 item, no traceback, no file
left behind, inputs untouched. Fault cases (signals, file-size limit, concurrent writers) run
real subprocesses.

The cases are data (``CASES``: id -> builder); ``PYTHONPATH=tests python tests/cli/test_bad_inputs.py`` runs the same
list outside pytest and prints the counts quoted in the issue's closing note.
"""

from __future__ import annotations

import hashlib
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest
import yaml
from click.testing import CliRunner
from conftest import BASE_SCENE, merge

from sarproc.cli.main import cli

SCENE = merge(
    BASE_SCENE,
    {
        "geometry": {"squint": "10 deg"},
        "acquisition": {"aperture_time": "0.2 s"},
        "targets": {"points": [{"name": "A"}, {"name": "B", "range": "10 m", "azimuth": "4 m"}]},
    },
)
BP = {"azimuth_extent": "20 m", "range_extent": "24 m"}

ARRAY_SCENE = {
    "radar": {
        "carrier_frequency": "37.5 GHz",
        "bandwidth": "375 MHz",
        "pulse_duration": "0.2 us",
        "range_sampling_rate": "450 MHz",
        "prf": "400 Hz",
    },
    "platform": {"velocity": "50 m/s", "altitude": "500 m"},
    "geometry": {"reference_range": "500 m"},
    "acquisition": {"mode": "stripmap", "n_pulses": 33, "range_margin": "3 m"},
    "targets": {
        "frame": "elevation",
        "origin": "absolute",
        "points": [{"name": "A", "azimuth": "0 m", "range": "490 m", "elevation": "0 deg"}],
    },
    "effects": {
        "antenna": {"pattern": "rect", "azimuth_beamwidth": "0.57 deg", "elevation_beamwidth": "6 deg"},
        "cross_track_array": {"n_receivers": 4, "spacing": "0.0764 m"},
    },
}


def invoke(args):
    return CliRunner().invoke(cli, [str(a) for a in args], catch_exceptions=True)


def dump(path: Path, mapping) -> Path:
    path.write_text(yaml.safe_dump(mapping, sort_keys=False))
    return path


def with_change(base: dict, section: str, key: str | None, value):
    out = {k: (dict(v) if isinstance(v, dict) else v) for k, v in base.items()}
    if key is None:
        out[section] = value
    else:
        out[section] = {**out.get(section, {}), key: value}
    return out


# ------------------------------------------------------------------------------------------------
# Products built once per session (copied into each case's folder)


@pytest.fixture(scope="session")
def products(tmp_path_factory):
    return build_products(tmp_path_factory.mktemp("products"))


def build_products(d: Path) -> Path:
    """raw.h5, image.h5, pre.h5, raw_array.h5 (and their scene/config files) in ``d``."""
    dump(d / "scene.yaml", SCENE)
    dump(d / "bp.yaml", {"backproject": BP})
    steps = [
        ("simulate", d / "scene.yaml", "-o", d / "raw.h5"),
        ("backproject", d / "raw.h5", "--config", d / "bp.yaml", "-o", d / "image.h5"),
        ("preprocess", d / "raw.h5", "-o", d / "pre.h5"),
        (
            "coarse-focus",
            d / "pre.h5",
            "--config",
            dump(d / "coarse.yaml", {"coarse_focus": {"scene_margin": "10 m"}}),
            "-o",
            d / "coarse.h5",
        ),
        ("simulate", dump(d / "array.yaml", ARRAY_SCENE), "-o", d / "raw_array.h5"),
    ]
    for args in steps:
        res = invoke(args)
        assert res.exit_code == 0, (args, res.output)
    return d


# ------------------------------------------------------------------------------------------------
# Cases: builder(tmp, products) -> (args, exit code, [strings the message must contain])

CASES: dict[str, object] = {}


def case(name):
    def deco(fn):
        assert name not in CASES, name
        CASES[name] = fn
        return fn

    return deco


def scene_case(name, mapping, *must, text=None, code=2):
    """simulate on a scene file holding ``mapping`` (or raw ``text``); the message names the file."""

    def build(tmp, products):
        path = tmp / "scene.yaml"
        if text is not None:
            path.write_bytes(text if isinstance(text, bytes) else text.encode())
        else:
            dump(path, mapping)
        return ["simulate", path, "-o", tmp / "raw.h5"], code, ["scene.yaml", *must]

    case(name)(build)


# --- scene files as files
scene_case("scene-binary", None, "not a UTF-8 text file", text=b"\x89HDF\r\n\x1a\n\xff\xfe\x00\x01")
scene_case("scene-nul-bytes", None, "NUL", text="radar: {}\x00\n")
scene_case("scene-top-level-list", None, "expected a mapping", text="- 1\n- 2\n")
scene_case("scene-top-level-scalar", None, "expected a mapping", text="hello\n")
scene_case("scene-syntax", None, "not valid YAML", "line 2", text="radar: {prf: 400 Hz\n")
scene_case("scene-tab-indent", None, "not valid YAML", "line 2", text="radar:\n\tprf: 400 Hz\n")
scene_case("scene-empty", None, "radar", text="")
scene_case(
    "scene-duplicate-section", None, "'radar' is given twice", text=yaml.safe_dump(SCENE) + "radar: {prf: 500 Hz}\n"
)
scene_case(
    "scene-duplicate-key",
    None,
    "'prf' is given twice",
    text=yaml.safe_dump(SCENE).replace("prf: 400 Hz", "prf: 400 Hz\n  prf: 500 Hz"),
)
scene_case("scene-numeric-key", with_change(SCENE, "radar", 1, "x"), "radar", "key 1 is not a name")
scene_case(
    "scene-bool-key",
    None,
    "radar: key True is not a name",
    text=yaml.safe_dump(SCENE).replace("radar:", "radar:\n  yes: 1", 1),
)
scene_case("scene-unknown-key", with_change(SCENE, "radar", "foo", 1), "radar", "unknown key(s) 'foo'")
scene_case(
    "scene-misspelt-key", with_change(SCENE, "radar", "bandwith", "1 MHz"), "'bandwith'", "did you mean 'bandwidth'"
)
scene_case("scene-misspelt-section", {**SCENE, "radr": {}}, "unknown key(s) 'radr'", "did you mean 'radar'")
scene_case("scene-section-scalar", {**SCENE, "radar": 5}, "radar", "expected a mapping")
scene_case("scene-section-list", {**SCENE, "platform": [1, 2]}, "platform", "expected a mapping")
scene_case("scene-missing-radar", {k: v for k, v in SCENE.items() if k != "radar"}, "radar", "required")
scene_case("scene-missing-geometry", {k: v for k, v in SCENE.items() if k != "geometry"}, "geometry", "required")

# --- every quantity with bad values
QUANTITIES = [
    ("radar", "carrier_frequency", "10 m"),
    ("radar", "bandwidth", "5 s"),
    ("radar", "pulse_duration", "3 Hz"),
    ("radar", "range_sampling_rate", "1 m/s"),
    ("radar", "prf", "2 m"),
    ("platform", "velocity", "3 Hz"),
    ("platform", "altitude", "1 s"),
    ("geometry", "reference_range", "1 GHz"),
    ("geometry", "squint", "1 m"),
]
BAD_VALUES = {
    "wrong-unit": None,
    "negative": "-1",
    "not-a-number": "abc",
    "boolean": True,
    "list": [1, 2],
    "mapping": {"a": 1},
    "infinite": "1e999",
    "nan": ".nan",
}
for section, key, wrong_unit in QUANTITIES:
    unit = SCENE[section][key].split()[-1]
    for label, value in BAD_VALUES.items():
        if label == "wrong-unit":
            value = wrong_unit
        elif label == "negative":
            value = f"-1 {unit}"
            if key in ("squint",):
                value = "-95 deg"
        elif label == "infinite":
            value = f"1e999 {unit}"
        elif label == "nan":
            value = float("nan")
        scene_case(f"scene-{key}-{label}", with_change(SCENE, section, key, value), f"{section}.{key}")

# --- cross-field and semantic checks of scenes
scene_case(
    "scene-fs-below-bandwidth",
    with_change(SCENE, "radar", "range_sampling_rate", "50 MHz"),
    "radar.range_sampling_rate",
    "below the bandwidth",
)
scene_case(
    "scene-bandwidth-above-carrier",
    merge(SCENE, {"radar": {"bandwidth": "12 GHz", "range_sampling_rate": "15 GHz"}}),
    "radar.bandwidth",
    "smaller than carrier_frequency",
)
scene_case("scene-chirp-direction", with_change(SCENE, "radar", "chirp", "sideways"), "radar.chirp")
scene_case(
    "scene-two-aperture-keys", with_change(SCENE, "acquisition", "n_pulses", 100), "acquisition", "exactly one of"
)
scene_case("scene-no-aperture-key", {**SCENE, "acquisition": {"mode": "spotlight"}}, "acquisition", "exactly one of")
scene_case("scene-mode-unknown", with_change(SCENE, "acquisition", "mode", "circular"), "acquisition.mode")
scene_case(
    "scene-stripmap-without-antenna",
    with_change(SCENE, "acquisition", "mode", "stripmap"),
    "acquisition.mode",
    "effects.antenna",
)
scene_case("scene-n-pulses-zero", {**SCENE, "acquisition": {"n_pulses": 0}}, "acquisition.n_pulses")
scene_case("scene-n-pulses-float", {**SCENE, "acquisition": {"n_pulses": 10.5}}, "acquisition.n_pulses")
scene_case(
    "scene-window-reversed",
    with_change(SCENE, "acquisition", "range_window", {"start": "2.1 km", "end": "1.9 km"}),
    "acquisition.range_window",
)
scene_case(
    "scene-window-missing-end",
    with_change(SCENE, "acquisition", "range_window", {"start": "2 km"}),
    "acquisition.range_window.end",
)
scene_case("scene-too-many-pulses", {**SCENE, "acquisition": {"n_pulses": 300000}}, "acquisition", "pulses")
scene_case(
    "scene-range-below-altitude",
    with_change(SCENE, "platform", "altitude", "3 km"),
    "geometry.reference_range",
    "platform.altitude",
)
scene_case("scene-unknown-frame", with_change(SCENE, "targets", "frame", "polar"), "targets.frame")
scene_case(
    "scene-target-names-repeat",
    with_change(SCENE, "targets", "points", [{"name": "A"}, {"name": "A"}]),
    "targets",
    "unique",
)
scene_case(
    "scene-target-without-name", with_change(SCENE, "targets", "points", [{"range": "1 m"}]), "targets.points[0].name"
)
scene_case(
    "scene-target-bad-range",
    with_change(SCENE, "targets", "points", [{"name": "A", "range": "1 Hz"}]),
    "targets.points[0].range",
)
scene_case(
    "scene-target-phase-bare",
    with_change(SCENE, "targets", "points", [{"name": "A", "phase": 1.5}]),
    "targets.points[0].phase",
    "needs a unit",
)
scene_case(
    "scene-target-negative-amplitude",
    with_change(SCENE, "targets", "points", [{"name": "A", "amplitude": -1}]),
    "targets.points[0].amplitude",
)
scene_case(
    "scene-target-velocity-2d",
    with_change(SCENE, "targets", "points", [{"name": "A", "velocity": ["1 m/s", "0 m/s"]}]),
    "targets.points[0]",
    "velocity",
)
scene_case(
    "scene-velocity-without-motion-effect",
    with_change(SCENE, "targets", "points", [{"name": "A", "velocity": ["1 m/s", "0 m/s", "0 m/s"]}]),
    "targets",
    "target_motion",
)
scene_case("scene-points-not-list", with_change(SCENE, "targets", "points", "A"), "targets.points")
scene_case(
    "scene-grid-zero",
    with_change(
        SCENE,
        "targets",
        "grid",
        {"azimuth_count": 0, "range_count": 1, "azimuth_spacing": "1 m", "range_spacing": "1 m"},
    ),
    "targets.grid.azimuth_count",
)
scene_case("scene-unknown-effect", {**SCENE, "effects": {"rain": {}}}, "effects", "rain")
scene_case("scene-effect-bad-param", {**SCENE, "effects": {"noise": {"snr": "loud"}}}, "effects", "noise")
scene_case("scene-block-pulses-zero", {**SCENE, "simulation": {"block_pulses": 0}}, "simulation.block_pulses")
scene_case("scene-seed-negative", {**SCENE, "simulation": {"seed": -1}}, "simulation.seed")
scene_case(
    "scene-reference-time-no-zone", {**SCENE, "reference": {"time": "2024-05-01T10:00:00"}}, "reference", "time zone"
)
scene_case("scene-reference-time-garbage", {**SCENE, "reference": {"time": "yesterday"}}, "reference", "ISO 8601")
scene_case(
    "scene-reference-latitude-only", {**SCENE, "reference": {"latitude": "45 deg"}}, "reference", "latitude/longitude"
)
scene_case(
    "scene-reference-latitude-range",
    {**SCENE, "reference": {"latitude": "95 deg", "longitude": "0 deg"}},
    "reference.latitude",
)
scene_case(
    "scene-reference-longitude-bare",
    {**SCENE, "reference": {"latitude": "45 deg", "longitude": 10}},
    "reference.longitude",
    "needs a unit",
)
scene_case("scene-reference-height-alone", {**SCENE, "reference": {"height": "10 m"}}, "reference", "height")
# sizes refused by the plan before any work (the message names the output and what does not fit)
scene_case(
    "scene-output-too-large",
    {**SCENE, "acquisition": {"n_pulses": 199000, "range_window": {"start": "2 km", "end": "78 km"}}},
    "raw.h5",
    "needs",
    "acquisition.range_window",
)
scene_case(
    "scene-pulse-two-seconds",
    with_change(SCENE, "radar", "pulse_duration", "2 s"),
    "raw.h5",
    "needs",
    "radar.pulse_duration 2 s",
)


# --- stage configs (--config): file problems, sections, keys
def config_case(name, text_or_mapping, *must, stage="backproject", product="raw.h5", extra=()):
    def build(tmp, products):
        src = tmp / product
        shutil.copy(products / product, src)
        cfg = tmp / "cfg.yaml"
        if isinstance(text_or_mapping, (str, bytes)):
            cfg.write_bytes(text_or_mapping if isinstance(text_or_mapping, bytes) else text_or_mapping.encode())
        else:
            dump(cfg, text_or_mapping)
        return [stage, src, "--config", cfg, "-o", tmp / "out.h5", *extra], 2, ["cfg.yaml", *must]

    case(name)(build)


config_case("config-binary", b"\x89HDF\r\n\x1a\n\x00\x00\xff", "not a UTF-8")
config_case("config-duplicate-key", "backproject:\n  upsample: 4\n  upsample: 8\n", "'upsample' is given twice")
config_case("config-duplicate-section", "backproject: {}\nbackproject: {}\n", "'backproject' is given twice")
config_case("config-misspelt-section", {"backprojct": {"upsample": 4}}, "'backprojct'", "did you mean 'backproject'")
config_case("config-misspelt-section-fine", {"finefocus": {"flow": 1}}, "'finefocus'", "did you mean 'fine_focus'")
config_case("config-unknown-section", {"backproject": BP, "colour": "red"}, "'colour'")
config_case("config-section-scalar", {"backproject": 5}, "backproject", "expected a mapping")
config_case("config-section-list", {"backproject": [1, 2]}, "backproject", "expected a mapping")
config_case("config-numeric-keys", "backproject:\n  1: a\n  foo: b\n", "backproject: key 1 is not a name")
config_case("config-unknown-key", {"backproject": {"upsampel": 4}}, "backproject", "'upsampel'", "did you mean")
config_case("config-top-level-list", "- backproject\n", "expected a mapping")
config_case("config-syntax", "backproject: [\n", "not valid YAML", "line 2")
for key, value in [
    ("upsample", 0),
    ("upsample", 100),
    ("upsample", "eight"),
    ("upsample", 2.5),
    ("interpolation", "cubicx"),
    ("engine", "gpu"),
    ("azimuth_extent", "-5 m"),
    ("azimuth_extent", "5 Hz"),
    ("range_spacing", "0 m"),
    ("oversample", 0.5),
    ("max_pixels", "lots"),
    ("margin_cells", -1),
    ("kernel_length", 1),
    ("range_window", "kaiser9"),
    ("azimuth_window", True),
    ("azimuth_center", "1 s"),
]:
    config_case(f"config-backproject-{key}-{value}", {"backproject": {key: value}}, f"backproject.{key}")
config_case(
    "config-backproject-grid-too-large",
    {"backproject": {"azimuth_extent": "10 km", "range_extent": "10 km"}},
    "backproject.max_pixels",
)
# checked before the plan estimate, which reads the taps (was an internal ValueError, exit 1)
config_case(
    "config-backproject-ffbp-odd-taps", {"backproject": {"engine": "ffbp", "ffbp_taps": 5}}, "backproject.ffbp_taps"
)
config_case("config-backproject-frame-unknown", {"backproject": {"frame": "polar"}}, "frame")
config_case("config-preprocess-method", {"preprocess": {"method": "bogus"}}, "preprocess.method", stage="preprocess")
config_case(
    "config-preprocess-block", {"preprocess": {"block_pulses": 0}}, "preprocess.block_pulses", stage="preprocess"
)
config_case("config-preprocess-misspelt", {"preproces": {}}, "did you mean 'preprocess'", stage="preprocess")
config_case(
    "config-coarse-on-alias",
    {"coarse_focus": {"on_alias": "maybe"}},
    "coarse_focus.on_alias",
    stage="coarse-focus",
    product="pre.h5",
)
config_case(
    "config-coarse-samples",
    {"coarse_focus": {"azimuth_samples": 1}},
    "coarse_focus.azimuth_samples",
    stage="coarse-focus",
    product="pre.h5",
)
config_case(
    "config-coarse-precision",
    {"coarse_focus": {"precision": "float16"}},
    "coarse_focus.precision",
    stage="coarse-focus",
    product="pre.h5",
)
config_case(
    "config-array3d-precision",
    {"array3d": {"precision": "float16"}},
    "array3d.precision",
    stage="array3d",
    product="raw_array.h5",
)
config_case(
    "config-array3d-span",
    {"array3d": {"elevation_span": "5 m"}},
    "array3d.elevation_span",
    stage="array3d",
    product="raw_array.h5",
)
config_case(
    "config-evaluate-upsample",
    {"evaluate": {"upsample": 0}},
    "evaluate.upsample",
    stage="evaluate",
    product="image.h5",
    extra=(),
)
config_case(
    "config-evaluate-unknown", {"evaluate": {"guard": 3}}, "evaluate", "'guard'", stage="evaluate", product="image.h5"
)


@case("config-missing-file")
def _(tmp, products):
    shutil.copy(products / "raw.h5", tmp / "raw.h5")
    return (
        ["backproject", tmp / "raw.h5", "--config", tmp / "nope.yaml", "-o", tmp / "o.h5"],
        2,
        ["nope.yaml", "not found"],
    )


@case("config-is-directory")
def _(tmp, products):
    shutil.copy(products / "raw.h5", tmp / "raw.h5")
    (tmp / "cfgdir").mkdir()
    return ["backproject", tmp / "raw.h5", "--config", tmp / "cfgdir", "-o", tmp / "o.h5"], 2, ["cfgdir"]


@case("config-is-hdf5-product")
def _(tmp, products):
    shutil.copy(products / "raw.h5", tmp / "raw.h5")
    return ["backproject", tmp / "raw.h5", "--config", tmp / "raw.h5", "-o", tmp / "o.h5"], 2, ["raw.h5", "UTF-8"]


# --- HDF5 inputs: file problems and every part of the layout
def product_case(name, edit, *must, stage="backproject", product="raw.h5"):
    """Copy ``product``, apply ``edit(h5py.File)`` (or ``edit(path)`` for byte-level damage), run ``stage``."""

    def build(tmp, products):
        src = tmp / product
        shutil.copy(products / product, src)
        if getattr(edit, "bytes_level", False):
            edit(src)
        else:
            with h5py.File(src, "a") as f:
                edit(f)
        args = [stage, src] + (["-o", tmp / "out.h5"] if stage != "evaluate" else ["-o", tmp / "out.json"])
        return args, 2, [product, *must]

    case(name)(build)


def bytes_level(fn):
    fn.bytes_level = True
    return fn


def set_attr(obj, key, value):
    def edit(f):
        f[obj].attrs[key] = value

    return edit


def del_attr(obj, key):
    def edit(f):
        del f[obj].attrs[key]

    return edit


def replace_dataset(name, make):
    """Replace dataset ``name`` by ``make(old_array)``, re-attaching the old dimension scales when shapes allow."""

    def edit(f):
        old = f[name][()]
        scales = [d[0] if len(d) else None for d in f[name].dims] if name in ("signal", "image") else []
        attrs = {k: v for k, v in f[name].attrs.items() if k not in ("DIMENSION_LIST",)}
        del f[name]
        new = f.create_dataset(name, data=make(old))
        for k, v in attrs.items():
            if k not in ("REFERENCE_LIST", "CLASS", "NAME"):
                new.attrs[k] = v
        for i, sc in enumerate(scales[: new.ndim]):
            if sc is not None:
                new.dims[i].attach_scale(sc)

    return edit


product_case("h5-truncated", bytes_level(lambda p: p.write_bytes(p.read_bytes()[:4096])), "HDF5")
product_case("h5-empty-file", bytes_level(lambda p: p.write_bytes(b"")), "not an HDF5 file")
product_case("h5-text-file", bytes_level(lambda p: p.write_text("radar: {}\n")), "not an HDF5 file")
product_case("h5-no-product-attr", del_attr("/", "product"), "'product'")
product_case("h5-product-unknown", set_attr("/", "product", "banana"), "'product'", "banana")
product_case("h5-product-wrong-stage", set_attr("/", "product", "coarse"), "product type is 'coarse'")
product_case("h5-format-2", set_attr("/", "sarproc_format", "2"), "sarproc_format '2'")
product_case("h5-no-format", del_attr("/", "sarproc_format"), "'sarproc_format'")
product_case("h5-history-not-list", set_attr("/", "history", '{"a": 1}'), "'history'")
product_case("h5-no-radar", lambda f: f.__delitem__("radar"), "radar")
for attr in (
    "carrier_frequency",
    "bandwidth",
    "pulse_duration",
    "chirp_rate",
    "range_sampling_rate",
    "prf",
    "velocity",
    "altitude",
    "squint",
    "reference_range",
    "scene_center",
):
    product_case(f"h5-radar-missing-{attr}", del_attr("radar", attr), "radar", f"'{attr}'")
for attr, value, why in [
    ("bandwidth", "150 MHz", "must be a number"),
    ("prf", -500.0, "positive"),
    ("carrier_frequency", np.nan, "finite"),
    ("velocity", np.inf, "finite"),
    ("scene_center", np.array([1.0, 2.0]), "3 numbers"),
    ("mode", "circular", "mode"),
    ("mode", 3, "must be a string"),
    ("n_channels", 1.5, "integer"),
    ("n_channels", 0, "n_channels"),
    ("squint", 2.0, "squint"),
    ("altitude", -5.0, "altitude"),
    ("range_sampling_rate", 1e6, "below the bandwidth"),
    ("prf", np.array([1.0, 2.0]), "single"),
    ("reference_utc", "noon", "ISO 8601"),
    ("reference_latitude", 2.0, "reference_"),
]:
    product_case(
        f"h5-radar-{attr}-{why.split()[0]}-{np.asarray(value).dtype.kind}",
        set_attr("radar", attr, value),
        "radar",
        f"'{attr}'" if not attr.startswith("reference_") else "reference_",
        why,
    )
product_case("h5-no-signal", lambda f: f.__delitem__("signal"), "'signal'")
product_case("h5-signal-int16", replace_dataset("signal", lambda a: a.real.astype(np.int16)), "'signal'", "complex")
product_case("h5-signal-float64", replace_dataset("signal", lambda a: a.real.astype(np.float64)), "'signal'", "complex")
product_case("h5-signal-rows-vs-azimuth-time", replace_dataset("signal", lambda a: a[:-7]), "'signal'", "azimuth_time")
product_case(
    "h5-signal-no-scales",
    lambda f: [f["signal"].dims[i].detach_scale(f[d]) for i, d in enumerate(("azimuth_time", "range_time"))],
    "'signal'",
    "dimension scale",
)
product_case("h5-signal-3d-for-raw", replace_dataset("signal", lambda a: a[None]), "'signal'", "dims")
product_case("h5-signal-nan", lambda f: f["signal"].__setitem__((1, 2), np.nan), "'signal'", "NaN")
product_case(
    "h5-azimuth-time-decreasing",
    lambda f: f["azimuth_time"].__setitem__(slice(None), f["azimuth_time"][()][::-1]),
    "azimuth_time",
    "increase",
)
product_case("h5-range-time-nan", lambda f: f["range_time"].__setitem__(3, np.nan), "range_time", "NaN")
product_case(
    "h5-aux-platform-rows", replace_dataset("aux/platform_position", lambda a: a[:-5]), "aux/platform_position", "rows"
)
product_case(
    "h5-aux-platform-2-columns",
    replace_dataset("aux/platform_position", lambda a: a[:, :2]),
    "aux/platform_position",
    "shape",
)
product_case(
    "h5-aux-platform-nan",
    lambda f: f["aux/platform_position"].__setitem__((0, 0), np.nan),
    "aux/platform_position",
    "NaN",
)
product_case(
    "h5-aux-platform-text",
    replace_dataset("aux/platform_position", lambda a: np.array([b"x"] * len(a))),
    "aux/platform_position",
    "numeric",
)
product_case("h5-aux-tx-offset-2", replace_dataset("aux/tx_offset", lambda a: a[:2]), "aux/tx_offset")
product_case(
    "h5-aux-rx-offset-receivers", replace_dataset("aux/rx_offset", lambda a: np.zeros((2, 3))), "aux/rx_offset"
)
product_case(
    "h5-aux-gate-length",
    lambda f: f["aux"].create_dataset("range_gate_offset", data=np.zeros(5)),
    "aux/range_gate_offset",
    "rows",
)
product_case("h5-no-targets", lambda f: f.__delitem__("targets"), "'targets'")
product_case(
    "h5-targets-missing-field",
    replace_dataset("targets", lambda a: a[["name", "x", "y", "z"]].copy()),
    "'targets'",
    "field",
)
product_case(
    "h5-targets-nan",
    lambda f: f["targets"].__setitem__(
        0, tuple(np.nan if n == "x" else v for n, v in zip(f["targets"].dtype.names, f["targets"][0]))
    ),
    "'targets'",
    "NaN",
)
product_case(
    "h5-preprocess-on-image", lambda f: None, "product type is 'image'", stage="preprocess", product="image.h5"
)
product_case("h5-array3d-on-raw", lambda f: None, "product type is 'raw'", stage="array3d")
product_case("h5-evaluate-on-raw", lambda f: None, "product type is 'raw'", stage="evaluate")
product_case(
    "h5-image-real",
    replace_dataset("image", lambda a: np.abs(a)),
    "'image'",
    "complex",
    stage="evaluate",
    product="image.h5",
)
product_case("h5-image-no-frame", del_attr("image", "frame"), "'frame'", stage="evaluate", product="image.h5")
product_case(
    "h5-image-frame-garbage", set_attr("image", "frame", "polar"), "'frame'", stage="evaluate", product="image.h5"
)
product_case(
    "h5-image-irw-length",
    set_attr("image", "theoretical_irw", np.array([1.0])),
    "theoretical_irw",
    stage="evaluate",
    product="image.h5",
)
product_case(
    "h5-image-irw-negative",
    set_attr("image", "theoretical_irw", np.array([1.0, -1.0])),
    "theoretical_irw",
    stage="evaluate",
    product="image.h5",
)
product_case(
    "h5-coarse-lacks-sampling-rate",
    del_attr("signal", "azimuth_sampling_rate"),
    "'azimuth_sampling_rate'",
    stage="fine-focus",
    product="coarse.h5",
)
product_case(
    "h5-coarse-sampling-rate-text",
    set_attr("signal", "azimuth_sampling_rate", "fast"),
    "'azimuth_sampling_rate'",
    stage="fine-focus",
    product="coarse.h5",
)
config_case("config-fine-flow", {"fine_focus": {"flow": 3}}, "fine_focus.flow", stage="fine-focus", product="coarse.h5")
config_case(
    "config-fine-kernel",
    {"fine_focus": {"stolt_kernel": "magic"}},
    "fine_focus.stolt_kernel",
    stage="fine-focus",
    product="coarse.h5",
)
config_case(
    "config-fine-max-samples",
    {"fine_focus": {"max_samples": 1000}},
    "fine_focus.max_samples",
    stage="fine-focus",
    product="coarse.h5",
)
product_case(
    "h5-array-channels-vs-radar",
    set_attr("radar", "n_channels", 7),
    "n_channels",
    stage="array3d",
    product="raw_array.h5",
)
product_case(
    "h5-array-rx-offsets",
    replace_dataset("aux/rx_offset", lambda a: a[:2]),
    "aux/rx_offset",
    stage="array3d",
    product="raw_array.h5",
)


@case("h5-missing-file")
def _(tmp, products):
    return ["backproject", tmp / "nope.h5", "-o", tmp / "o.h5"], 2, ["nope.h5", "not found"]


@case("h5-directory")
def _(tmp, products):
    (tmp / "dir.h5").mkdir()
    return ["backproject", tmp / "dir.h5", "-o", tmp / "o.h5"], 2, ["dir.h5", "directory"]


@case("h5-scene-given-to-backproject")
def _(tmp, products):
    dump(tmp / "scene.yaml", SCENE)
    return ["backproject", tmp / "scene.yaml", "-o", tmp / "o.h5"], 2, ["scene.yaml", "not an HDF5 file"]


@case("scene-is-directory")
def _(tmp, products):
    (tmp / "scene.yaml").mkdir()
    return ["simulate", tmp / "scene.yaml", "-o", tmp / "o.h5"], 2, ["scene.yaml", "directory"]


@case("scene-missing")
def _(tmp, products):
    return ["simulate", tmp / "scene.yaml", "-o", tmp / "o.h5"], 2, ["scene.yaml", "not found"]


@case("scene-is-hdf5")
def _(tmp, products):
    shutil.copy(products / "raw.h5", tmp / "raw.h5")
    return ["simulate", tmp / "raw.h5", "-o", tmp / "o.h5"], 2, ["raw.h5", "UTF-8"]


# --- outputs
def output_case(name, stage, make_output, *must, extra=(), setup=None):
    def build(tmp, products):
        if stage == "simulate":
            src = dump(tmp / "scene.yaml", SCENE)
        else:
            src = tmp / ("image.h5" if stage == "evaluate" else "raw.h5")
            shutil.copy(products / src.name, src)
        out = make_output(tmp)
        if setup is not None:
            setup(tmp)
        return [stage, src, "-o", out, *extra], 2, list(must)

    case(name)(build)


def existing(name):
    def make(tmp):
        (tmp / name).write_text("keep me")
        return tmp / name

    return make


for stage in ("simulate", "backproject", "preprocess", "evaluate"):
    name = "out.json" if stage == "evaluate" else "out.h5"
    output_case(f"out-exists-{stage}", stage, existing(name), name, "exists", "--overwrite")
    output_case(f"out-is-directory-{stage}", stage, lambda tmp, n=name: (tmp / n).mkdir() or tmp / n, name, "directory")
    output_case(f"out-dir-missing-{stage}", stage, lambda tmp, n=name: tmp / "nowhere" / n, "nowhere", "does not exist")
    output_case(
        f"out-parent-is-file-{stage}",
        stage,
        lambda tmp, n=name: (tmp / "afile").write_text("x") and tmp / "afile" / n,
        "afile",
        "not a directory",
    )
output_case(
    "out-is-input-backproject", "backproject", lambda tmp: tmp / "raw.h5", "raw.h5", "input", extra=("--overwrite",)
)
output_case(
    "out-is-input-simulate", "simulate", lambda tmp: tmp / "scene.yaml", "scene.yaml", "input", extra=("--overwrite",)
)
output_case(
    "out-is-input-evaluate", "evaluate", lambda tmp: tmp / "image.h5", "image.h5", "input", extra=("--overwrite",)
)
output_case(
    "out-read-only-fs", "backproject", lambda tmp: Path("/proc/sarproc_out.h5"), "sarproc_out.h5", "cannot create files"
)
output_case(
    "evaluate-plot-is-file",
    "evaluate",
    lambda tmp: tmp / "r.json",
    "plots",
    "is a file",
    extra=("--plot", "PLOTS"),
    setup=lambda tmp: (tmp / "plots").write_text("x"),
)


@case("array3d-channel-output-alone")
def _(tmp, products):
    shutil.copy(products / "raw_array.h5", tmp / "raw_array.h5")
    return ["array3d", tmp / "raw_array.h5", "-o", tmp / "c.h5", "--channel-image", "1"], 2, ["--channel-output"]


@case("array3d-channel-output-same")
def _(tmp, products):
    shutil.copy(products / "raw_array.h5", tmp / "raw_array.h5")
    return (
        ["array3d", tmp / "raw_array.h5", "-o", tmp / "c.h5", "--channel-image", "1", "--channel-output", tmp / "c.h5"],
        2,
        ["c.h5", "same file"],
    )


@case("array3d-channel-image-range")
def _(tmp, products):
    shutil.copy(products / "raw_array.h5", tmp / "raw_array.h5")
    return (
        ["array3d", tmp / "raw_array.h5", "-o", tmp / "c.h5", "--channel-image", "9", "--channel-output", tmp / "i.h5"],
        2,
        ["raw_array.h5", "--channel-image 9"],
    )


# --- formats, imports and the generic-estimate stages: the same order (config, input, output, plan)
for key, value in [
    ("latitude", "100 deg"),
    ("longitude", 4),
    ("time", "yesterday"),
    ("heading", "10 m"),
    ("latitud", "10 deg"),
]:
    for stage, product in (("export-sicd", "image.h5"), ("export-cphd", "raw.h5")):
        config_case(
            f"config-{stage}-geolocation-{key}",
            {"geolocation": {key: value}},
            "geolocation",
            f"'{key}'" if key == "latitud" else f"geolocation.{key}",
            stage=stage,
            product=product,
        )


@case("config-export-sicd-before-output-exists")
def _(tmp, products):
    shutil.copy(products / "image.h5", tmp / "image.h5")
    (tmp / "out.nitf").write_text("keep me")
    cfg = dump(tmp / "cfg.yaml", {"geolocation": {"latitude": "100 deg"}})
    return (
        ["export-sicd", tmp / "image.h5", "--config", cfg, "-o", tmp / "out.nitf"],
        2,
        ["cfg.yaml", "geolocation.latitude"],
    )


config_case("config-pfa2-unknown-key", {"pfa2": {"methd": "two_step"}}, "pfa2", "'methd'", stage="pfa2")
config_case("config-pfa2-bad-value", {"pfa2": {"method": "three_step"}}, "pfa2.method", stage="pfa2")
config_case(
    "config-reconstruct-unknown-key",
    {"reconstruct": {"methd": "modified"}},
    "reconstruct",
    "'methd'",
    stage="reconstruct",
)


def format_case(name, stage, make_input, *must, out="out.h5"):
    """``stage`` on the input ``make_input(tmp, products)`` builds; the output already exists (validation first)."""

    def build(tmp, products):
        src = make_input(tmp, products)
        (tmp / out).write_text("keep me")
        return [stage, src, "-o", tmp / out], 2, list(must)

    case(name)(build)


def copied(product):
    return lambda tmp, products: shutil.copy(products / product, tmp / product) and tmp / product


def written(name, data: bytes):
    def make(tmp, products):
        (tmp / name).write_bytes(data)
        return tmp / name

    return make


def mat_file(name, variables):
    def make(tmp, products):
        import scipy.io

        scipy.io.savemat(tmp / name, variables)
        return tmp / name

    return make


format_case("export-sicd-of-raw", "export-sicd", copied("raw.h5"), "raw.h5", "'image'")
format_case("export-sicd-skewed-frame", "export-sicd", copied("image.h5"), "image.h5", "skewed axes")
format_case("export-cphd-of-image", "export-cphd", copied("image.h5"), "image.h5", "'raw'")
format_case("export-cphd-of-raw-array", "export-cphd", copied("raw_array.h5"), "raw_array.h5", "'raw'")
format_case(
    "import-cphd-text", "import-cphd", written("x.cphd", b"CPHD/1.1.0\nnot really\n"), "x.cphd", "cannot read as CPHD"
)
format_case("import-cphd-hdf5", "import-cphd", copied("raw.h5"), "raw.h5", "cannot read as CPHD")
format_case(
    "import-cphd-directory",
    "import-cphd",
    lambda tmp, products: (tmp / "d.cphd").mkdir() or tmp / "d.cphd",
    "d.cphd",
    "cannot read as CPHD",
)
format_case(
    "import-gotcha-not-mat",
    "import-gotcha",
    written("g.mat", b"not a mat file" * 20),
    "g.mat",
    "not a MATLAB .mat file",
)
format_case(
    "import-gotcha-no-data-variable",
    "import-gotcha",
    mat_file("g.mat", {"x": np.arange(3)}),
    "g.mat",
    "no variable 'data'",
)
format_case("import-gotcha-missing", "import-gotcha", lambda tmp, products: tmp / "none.mat", "none.mat", "not found")
format_case(
    "import-gotcha-empty-folder",
    "import-gotcha",
    lambda tmp, products: (tmp / "g").mkdir() or tmp / "g",
    "g",
    "no .mat files",
)
format_case(
    "import-gotcha-directory-named-mat",
    "import-gotcha",
    lambda tmp, products: (tmp / "h.mat").mkdir() or (tmp / "h.mat"),
    "h.mat",
    "no .mat files",
)


# --- usage and budgets
@case("usage-unknown-command")
def _(tmp, products):
    return ["simulat", "x.yaml"], 2, ["simulat"]


@case("usage-missing-output")
def _(tmp, products):
    dump(tmp / "scene.yaml", SCENE)
    return ["simulate", tmp / "scene.yaml"], 2, ["-o"]


@case("usage-max-memory-garbage")
def _(tmp, products):
    dump(tmp / "scene.yaml", SCENE)
    return ["simulate", tmp / "scene.yaml", "-o", tmp / "o.h5", "--max-memory", "lots"], 2, ["--max-memory", "lots"]


for stage, product in (
    ("simulate", None),
    ("backproject", "raw.h5"),
    ("preprocess", "raw.h5"),
    ("coarse-focus", "pre.h5"),
    ("array3d", "raw_array.h5"),
    ("evaluate", "image.h5"),
):

    @case(f"budget-max-memory-{stage}")
    def _(tmp, products, stage=stage, product=product):
        if product is None:
            src = dump(tmp / "scene.yaml", SCENE)
        else:
            src = tmp / product
            shutil.copy(products / product, src)
        out = tmp / ("o.json" if stage == "evaluate" else "o.h5")
        return [stage, src, "-o", out, "--max-memory", "1k"], 2, ["--max-memory", "needs"]


# ------------------------------------------------------------------------------------------------
# The check applied to every case


def snapshot(folder: Path) -> dict[str, str]:
    out = {}
    for p in sorted(folder.rglob("*")):
        if p.is_file():
            out[str(p.relative_to(folder))] = hashlib.sha256(p.read_bytes()).hexdigest()
        elif p.is_dir():
            out[str(p.relative_to(folder)) + "/"] = "dir"
    return out


def run_case(name, tmp: Path, products: Path) -> dict:
    """Run one case; returns what the report counts (and the assertions read)."""
    args, code, must = CASES[name](tmp, products)
    args = [tmp / "plots" if a == "PLOTS" else a for a in args]
    before = snapshot(tmp)
    res = invoke(args)
    after = snapshot(tmp)
    out = res.output
    crashed = res.exception is not None and not isinstance(res.exception, SystemExit)
    return {
        "name": name,
        "args": args,
        "code": res.exit_code,
        "want_code": code,
        "output": out,
        "must": must,
        "missing": [m for m in must if m not in out],
        "file_named": any(Path(a).name in out for a in args if isinstance(a, Path)),
        "traceback": "Traceback" in out or crashed,
        "silent_accept": res.exit_code == 0,
        "leftovers": sorted(set(after) - set(before)),
        "inputs_modified": sorted(k for k in before if k in after and before[k] != after[k])
        + sorted(set(before) - set(after)),
        "one_line": len([ln for ln in out.strip().splitlines() if ln.startswith("Error:")]) == 1,
    }


@pytest.mark.parametrize("name", sorted(CASES))
def test_bad_input(name, tmp_path, products):
    r = run_case(name, tmp_path, products)
    assert r["code"] == r["want_code"], (r["args"], r["output"])
    assert not r["traceback"], r["output"]
    assert not r["missing"], (r["missing"], r["output"])
    assert r["one_line"], r["output"]
    assert not r["leftovers"], r["leftovers"]
    assert not r["inputs_modified"], r["inputs_modified"]


def test_at_least_150_cases():
    assert len(CASES) >= 150


# ------------------------------------------------------------------------------------------------
# Behaviour that is not an error


def test_quiet_and_verbose_anywhere(tmp_path, products):
    scene = dump(tmp_path / "scene.yaml", SCENE)
    res = invoke(["simulate", scene, "-o", tmp_path / "a.h5", "-q"])
    assert res.exit_code == 0 and res.output == ""
    res = invoke(["simulate", scene, "-v", "-o", tmp_path / "b.h5"])
    assert res.exit_code == 0 and "simulate: plan: output ~" in res.output and "peak memory" in res.output
    res = invoke(["backproject", products / "raw.h5", "-o", tmp_path / "i.h5", "--config", products / "bp.yaml", "-vv"])
    assert res.exit_code == 0 and "backproject: plan:" in res.output
    assert "h5py" not in res.output  # h5py's conversion chatter stays out of -vv


def test_validation_comes_before_output_exists(tmp_path):
    """A Makefile rebuild reports the bad scene, not 'output exists'."""
    bad = dump(tmp_path / "scene.yaml", with_change(SCENE, "radar", "prf", "-1 Hz"))
    (tmp_path / "raw.h5").write_text("old")
    res = invoke(["simulate", bad, "-o", tmp_path / "raw.h5"])
    assert res.exit_code == 2 and "radar.prf" in res.output and "exists" not in res.output


def test_evaluate_overwrite(tmp_path, products):
    out = tmp_path / "r.json"
    assert invoke(["evaluate", products / "image.h5", "-o", out, "-q"]).exit_code == 0
    first = out.read_text()
    res = invoke(["evaluate", products / "image.h5", "-o", out])
    assert res.exit_code == 2 and "--overwrite" in res.output and out.read_text() == first
    assert invoke(["evaluate", products / "image.h5", "-o", out, "--overwrite", "-q"]).exit_code == 0


def test_processing_failure_is_one_line_exit_1(tmp_path, products, monkeypatch):
    import sarproc.focus.backprojection as bp

    def boom(*a, **k):
        raise ZeroDivisionError("division by zero")

    monkeypatch.setattr(bp, "backproject_rows", boom)  # fails while the image is being streamed out
    res = invoke(["backproject", products / "raw.h5", "-o", tmp_path / "i.h5"])
    assert res.exit_code == 1 and "internal error: ZeroDivisionError" in res.output and "-vv" in res.output
    assert "Traceback" not in res.output and not (tmp_path / "i.h5").exists()


# ------------------------------------------------------------------------------------------------
# Faults in real processes: signals, file-size limit, concurrent writers, stale temporaries

# Long enough that a signal 0.2 s after its temporary file appears lands while blocks are still being written:
# 1.5 s of compiled echoes and writes on an idle 2-core machine (8 s and 8 x 8 targets finished in 0.4 s once
# the kernels loaded lean and wrote complex64 behind the compute).
SLOW = {
    **SCENE,
    "acquisition": {
        "mode": "spotlight",
        "aperture_time": "48 s",
        "range_window": {"start": "1.9 km", "end": "2.1 km"},
    },
    "targets": {
        "frame": "squint",
        "grid": {"azimuth_count": 16, "range_count": 16, "azimuth_spacing": "2 m", "range_spacing": "2 m"},
    },
    "simulation": {"block_pulses": 32},
}


def sarproc(*args, limit_kb=None):
    pre = None
    if limit_kb is not None:
        import resource

        def pre():
            resource.setrlimit(resource.RLIMIT_FSIZE, (limit_kb * 1024, limit_kb * 1024))

    return subprocess.Popen(
        [sys.executable, "-m", "sarproc", *map(str, args)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=pre,
    )


def _size(path: Path) -> int:
    try:
        return path.stat().st_size
    except FileNotFoundError:
        return 0


def wait_for_temporary(folder: Path, proc, timeout=60.0):
    # The product's own temporary: the writability probe (product.io._probe_directory) makes an empty one with the
    # same suffix and removes it within milliseconds, which a kill after it would find gone.
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if any(_size(p) > 0 for p in folder.glob(".*.sarproc-tmp")):
            return True
        if proc.poll() is not None:
            return False
        time.sleep(0.02)
    return False


@pytest.mark.parametrize("sig", ["SIGTERM", "SIGINT", "SIGHUP"])
def test_signal_during_write_removes_temporary(tmp_path, sig):
    scene = dump(tmp_path / "scene.yaml", SLOW)
    before = snapshot(tmp_path)
    proc = sarproc("simulate", scene, "-o", tmp_path / "raw.h5", "--no-progress")
    assert wait_for_temporary(tmp_path, proc), proc.communicate()
    time.sleep(0.2)
    proc.send_signal(getattr(signal, sig))
    try:
        _, err = proc.communicate(timeout=60)
    except subprocess.TimeoutExpired:  # a hang is the failure; the process must not outlive the test
        proc.kill()
        _, err = proc.communicate()
        pytest.fail(f"simulate did not stop within 60 s of {sig}: {err[-2000:]}")
    assert proc.returncode == 128 + getattr(signal, sig), err
    assert f"interrupted by {sig}" in err and "Traceback" not in err
    assert snapshot(tmp_path) == before


def test_sigkill_leftover_is_cleaned_by_the_next_run(tmp_path):
    scene = dump(tmp_path / "scene.yaml", SLOW)
    proc = sarproc("simulate", scene, "-o", tmp_path / "raw.h5", "--no-progress")
    assert wait_for_temporary(tmp_path, proc)
    proc.kill()
    proc.communicate()
    assert list(tmp_path.glob(".*.sarproc-tmp"))
    dump(tmp_path / "small.yaml", SCENE)
    quick = sarproc("simulate", tmp_path / "small.yaml", "-o", tmp_path / "raw.h5", "-q")
    _, err = quick.communicate(timeout=60)
    assert quick.returncode == 0, err
    assert not list(tmp_path.glob(".*.sarproc-tmp"))


def test_file_size_limit(tmp_path):
    scene = dump(tmp_path / "scene.yaml", SLOW)
    before = snapshot(tmp_path)
    # far below the product: refused by the plan before any work
    proc = sarproc("simulate", scene, "-o", tmp_path / "raw.h5", limit_kb=64)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 2 and "raw.h5" in err and "ulimit -f" in err
    # above the estimate (the samples), below the real file (aux arrays, scales, metadata): the write fails
    from sarproc.simulation.budget import simulate_estimate
    from sarproc.simulation.scene import load_scene

    limit_kb = int(simulate_estimate(load_scene(scene)).output_bytes / 1024) + 8
    proc = sarproc("simulate", scene, "-o", tmp_path / "raw.h5", "--no-progress", limit_kb=limit_kb)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 1, (proc.returncode, err)
    assert "raw.h5: cannot write the product: File too large (EFBIG)" in err and "Traceback" not in err
    assert snapshot(tmp_path) == before


def test_evaluate_figures_on_a_full_disk(tmp_path, products):
    """The report fits under the file-size limit, a figure does not: exit 1 naming it, no folder left."""
    image = tmp_path / "image.h5"
    shutil.copy(products / "image.h5", image)
    probe = sarproc("evaluate", image, "-o", tmp_path / "probe.json", "-q")
    assert probe.wait(60) == 0
    probe.communicate()
    limit_kb = (tmp_path / "probe.json").stat().st_size // 1024 + 2
    (tmp_path / "probe.json").unlink()
    before = snapshot(tmp_path)
    proc = sarproc("evaluate", image, "-o", tmp_path / "r.json", "--plot", tmp_path / "plots", limit_kb=limit_kb)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 1, err
    assert "plots/quicklook.png: cannot write: File too large (EFBIG)" in err and "Traceback" not in err
    assert out == ""  # no table printed before the failure
    assert set(snapshot(tmp_path)) - set(before) == {"r.json"}  # the complete report only; no plots/, no temporaries


def test_a_file_size_limit_leaves_no_truncated_bytecode(tmp_path, products):
    """Python ignores SIGXFSZ and does not check its .pyc writes: a first import under ``ulimit -f`` left a
    truncated cache that broke every later run ("marshal data too short"). With a fresh cache prefix the
    figures' modules (quality.plotting, matplotlib) are first imported under the limit, as in a new install."""
    env = {**os.environ, "PYTHONPYCACHEPREFIX": str(tmp_path / "pycache")}
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    image = tmp_path / "image.h5"
    shutil.copy(products / "image.h5", image)

    def run(*args, limit_kb=None):
        def pre():
            if limit_kb is not None:
                import resource

                resource.setrlimit(resource.RLIMIT_FSIZE, (limit_kb * 1024, limit_kb * 1024))

        cmd = [sys.executable, "-m", "sarproc", *map(str, args)]
        proc = subprocess.run(cmd, capture_output=True, text=True, env=env, preexec_fn=pre, timeout=300)
        return proc.returncode, proc.stderr

    code, err = run("evaluate", image, "-o", tmp_path / "probe.json", "-q")
    assert code == 0, err
    limit_kb = (tmp_path / "probe.json").stat().st_size // 1024 + 2  # the report fits, its figures do not
    code, err = run("evaluate", image, "-o", tmp_path / "r.json", "--plot", tmp_path / "plots", limit_kb=limit_kb)
    assert code == 1 and "File too large" in err, err
    code, err = run("evaluate", image, "-o", tmp_path / "r2.json", "--plot", tmp_path / "plots")
    assert code == 0, err  # the modules first imported under the limit load again


def test_two_concurrent_writers_never_replace_each_other(tmp_path):
    a = dump(tmp_path / "a.yaml", SLOW)
    b = dump(tmp_path / "b.yaml", {**SLOW, "geometry": {"reference_range": "2 km", "squint": "5 deg"}})
    procs = [sarproc("simulate", s, "-o", tmp_path / "raw.h5", "--no-progress") for s in (a, b)]
    results = [(p.wait(120), p.communicate()[1]) for p in procs]
    codes = sorted(r[0] for r in results)
    assert codes == [0, 2], results
    loser = next(err for rc, err in results if rc == 2)
    winner = next(p for p, (rc, _) in zip(procs, results) if rc == 0)
    # seen at the start by the lock (naming the other run), or, had the first already finished, "exists"
    assert "raw.h5" in loser and (
        f"another sarproc run is writing this output (pid {winner.pid} " in loser or "output exists" in loser
    ), loser
    assert not list(tmp_path.glob(".*.sarproc-tmp"))


def test_formats_and_imports_print_their_plan(tmp_path, products):
    """export-sicd, export-cphd, import-cphd (and import-gotcha on the shared data) plan with -v."""
    d = tmp_path
    res = invoke(
        [
            "backproject",
            products / "raw.h5",
            "--config",
            dump(d / "los.yaml", {"backproject": {**BP, "frame": "los"}}),
            "-o",
            d / "los.h5",
            "-q",
        ]
    )
    assert res.exit_code == 0, res.output
    res = invoke(["-v", "export-sicd", d / "los.h5", "-o", d / "i.nitf"])
    assert res.exit_code == 0 and "export-sicd: plan: output ~" in res.output, res.output
    # export-cphd's plan comes before the (slant-plane scene's) consistency verdict
    res = invoke(["-v", "export-cphd", products / "raw.h5", "-o", d / "r.cphd"])
    assert "export-cphd: plan: output ~" in res.output, res.output
    if (d / "r.cphd").exists():  # written, then checked by sarkit
        res = invoke(["-v", "import-cphd", d / "r.cphd", "-o", d / "r.h5"])
        assert res.exit_code == 0 and "import-cphd: plan: output ~" in res.output, res.output
    gotcha = Path(__file__).resolve().parents[3] / "shared" / "data" / "gotcha"
    mats = sorted(gotcha.glob("*.mat"))[:1]
    if mats:
        res = invoke(["-v", "import-gotcha", mats[0], "-o", d / "g.h5"])
        assert res.exit_code == 0 and "import-gotcha: plan: output ~" in res.output, res.output


def test_export_failing_its_consistency_check_publishes_nothing(tmp_path, products):
    """The slant-plane scene's CPHD fails sarkit's check (incidence 90 deg): exit 1, the checker's
    verdict named, and no file at the output (the export is checked before it is published)."""
    res = invoke(["export-cphd", products / "raw.h5", "-o", tmp_path / "r.cphd"])
    assert res.exit_code == 1, res.output
    assert "consistency checks failed" in res.output
    assert not (tmp_path / "r.cphd").exists()
    assert not list(tmp_path.glob(".*.sarproc-tmp"))


# The report (PYTHONPATH=tests python tests/cli/test_bad_inputs.py). An expected string that is a YAML key
# path, an HDF5 item, an attribute or an option:
KEYLIKE = re.compile(
    r"[a-z_]\.[a-z_]|'[^']+'|--[a-z]|aux/|radar|targets|signal|image|azimuth_time|range_time|"
    r"theoretical_irw|n_channels|frame|reference|acquisition|effects|geometry|platform|backproject|line \d"
)


def names_key(must) -> bool:
    return any(KEYLIKE.search(m) for m in must if not re.search(r"\.(yaml|h5|json)$", m))


def report() -> int:
    """Run every case outside pytest and print the counts table, then the cases that fall short."""
    import collections
    import tempfile

    suite = sys.modules[__name__]
    start = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        (Path(tmp) / "products").mkdir()
        products = suite.build_products(Path(tmp) / "products")
        results = []
        for i, name in enumerate(sorted(suite.CASES)):
            case_dir = Path(tmp) / f"case{i}"
            case_dir.mkdir()
            results.append(suite.run_case(name, case_dir, products))
    wall = time.perf_counter() - start
    families = collections.Counter(r["name"].split("-")[0] for r in results)
    rows = [
        ("cases", len(results)),
        ("  by family", ", ".join(f"{k} {v}" for k, v in sorted(families.items()))),
        ("expected exit code", sum(r["code"] == r["want_code"] for r in results)),
        ("exit 2", sum(r["code"] == 2 for r in results)),
        ("exit 2 with every expected string in the message", sum(r["code"] == 2 and not r["missing"] for r in results)),
        (
            "exit 2 whose message names one of the files on the command line",
            sum(r["code"] == 2 and r["file_named"] for r in results),
        ),
        ("  those that do not (usage errors)", ", ".join(r["name"] for r in results if not r["file_named"])),
        (
            "exit 2 naming the key / HDF5 item / option as well (checked string)",
            sum(r["code"] == 2 and not r["missing"] and names_key(r["must"]) for r in results),
        ),
        (
            "  cases with no key to name (file-level: missing, directory, binary, syntax, output place)",
            ", ".join(r["name"] for r in results if not names_key(r["must"])),
        ),
        ("one-line message", sum(r["one_line"] for r in results)),
        ("tracebacks", sum(r["traceback"] for r in results)),
        ("silent accepts (exit 0)", sum(r["silent_accept"] for r in results)),
        ("leftover files", sum(bool(r["leftovers"]) for r in results)),
        ("inputs modified", sum(bool(r["inputs_modified"]) for r in results)),
        ("crashes (uncaught exception)", sum(r["traceback"] and r["code"] not in (1, 2) for r in results)),
        ("wall time, s", f"{wall:.1f}"),
    ]
    print("| count | value |\n|---|---|")
    for k, v in rows:
        print(f"| {k} | {v} |")
    bad = [
        r
        for r in results
        if r["code"] != r["want_code"]
        or r["missing"]
        or r["traceback"]
        or r["leftovers"]
        or r["inputs_modified"]
        or not r["one_line"]
    ]
    for r in bad:
        print(
            f"\nFALLS SHORT {r['name']}: exit {r['code']} (want {r['want_code']}), missing {r['missing']}, "
            f"leftovers {r['leftovers']}, modified {r['inputs_modified']}\n{r['output']}"
        )
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(report())
