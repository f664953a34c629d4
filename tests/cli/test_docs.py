"""Docs from one source: the parameter declarations give the JSON Schema (sarproc schema) and every
command's --help key list; README names every subcommand and every scene key."""

from __future__ import annotations

import copy
import dataclasses
import glob
import json
import re
import subprocess
import sys
from pathlib import Path

import jsonschema
import pytest
from click.testing import CliRunner

from helpers import declared_keys, scene_keys
from sarproc.cli.main import COMMANDS, cli
from sarproc.cli.options import SectionCommand, check_sections
from sarproc.cli.schema import (
    FREE_SECTIONS,
    SECTION_MODELS,
    SWEEP_MODEL,
    build_schemas,
    model_of,
    section_rows,
    stored_schemas,
    topic_schema,
)
from sarproc.product.config import build, load_yaml
from sarproc.product.errors import InputError

ROOT = Path(__file__).resolve().parents[2]


def command_help(name: str) -> str:
    result = CliRunner().invoke(cli, [name, "--help"], terminal_width=200)
    assert result.exit_code == 0, result.output
    return result.output


def section_commands() -> dict[str, tuple[str, ...]]:
    """command name -> the sections its --help lists."""
    return {
        name: cmd.sections
        for name in COMMANDS
        if isinstance(cmd := cli.get_command(None, name), SectionCommand)  # type: ignore[arg-type]
    }


def keys_of(section: str) -> list[str]:
    if section == "scene":
        return scene_keys()
    if section == "sweep":
        return declared_keys(model_of(SWEEP_MODEL))
    if section == "expect":
        from sarproc.quality.metrics import AxisBounds, Expectations, TargetBounds

        return (
            declared_keys(Expectations)
            + declared_keys(AxisBounds, "axes.NAME.")
            + declared_keys(TargetBounds, "targets.NAME.")
            + declared_keys(AxisBounds, "targets.NAME.axes.NAME.")
        )
    return declared_keys(model_of(SECTION_MODELS[section]))


def test_stored_schema_is_the_declarations() -> None:
    fresh = json.loads(json.dumps(build_schemas()))
    stored = stored_schemas()
    stale = [k for k in fresh if fresh[k] != stored.get(k)]
    stale += [f"sections.{k}" for k in fresh["sections"] if fresh["sections"][k] != stored["sections"].get(k)]
    assert not stale, (
        f"sarproc/cli/config_schema.json differs from the parameter declarations in {stale}: run `make schema`"
    )


def test_every_config_command_lists_its_section() -> None:
    """A command taking --config reads one section; its --help must list that section's keys."""
    listed = section_commands()
    for name in COMMANDS:
        cmd = cli.get_command(None, name)  # type: ignore[arg-type]
        if any(p.name == "config_path" for p in cmd.params):
            assert name in listed, f"{name} takes --config but its --help lists no keys"
    from sarproc.product.config import OTHER_SECTIONS, STAGE_SECTIONS

    assert set(STAGE_SECTIONS + OTHER_SECTIONS) - set(FREE_SECTIONS) == set(SECTION_MODELS)
    documented = {s for sections in listed.values() for s in sections}
    assert set(SECTION_MODELS) <= documented, set(SECTION_MODELS) - documented
    assert {"scene", "sweep", "expect"} <= documented


@pytest.mark.parametrize("name", sorted(section_commands()))
def test_help_lists_every_declared_key(name: str) -> None:
    text = command_help(name)
    rows = dict(row for s in section_commands()[name] for row in section_rows(s))
    for section in section_commands()[name]:
        keys = keys_of(section)
        assert keys
        for key in keys:
            assert re.search(rf"(?m)^\s+{re.escape(key)}(\s|$)", text), f"{name} --help: key {key} missing"
            assert key in rows
    # units and defaults come with the keys: e.g. a quantity shows its SI unit, a default its value
    if name == "backproject":
        assert rows["azimuth_spacing"].startswith("[m] ") and "default 16 for the exact engines" in rows["upsample"]
        assert "one of compiled, reference, ffbp" in rows["engine"] and ">= 1, <= 64" in rows["upsample"]
    if name == "simulate":
        assert rows["radar.carrier_frequency"].startswith("[Hz] ") and rows["radar.carrier_frequency"].endswith(
            "(required)"
        )
        assert rows["geometry.squint"].startswith("[deg|rad] ") and "(default 0 deg)" in rows["geometry.squint"]
        assert "(default 0 m)" in rows["platform.altitude"] and ">= 0 m" in rows["platform.altitude"]


def test_help_imports_no_stage() -> None:
    """--help reads the stored schema: no stage module and no numerical library is imported for it."""
    runs = "".join(f"run_cli([{name!r}, '--help'])\n" for name in section_commands())
    code = (
        "import sys\nfrom sarproc.cli.main import run_cli\n" + runs + "print(sorted(m for m in sys.modules if "
        "m.split('.')[0] in ('numba', 'scipy', 'h5py', 'matplotlib', 'xarray') "
        "or m.startswith(('sarproc.focus', 'sarproc.simulation', 'sarproc.quality'))))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip().splitlines()[-1] == "[]"


def _topic(path: str) -> str:
    return "sweep" if "/sweeps/" in path else ("expect" if path.endswith("_expect.yaml") else "config")


CONFIGS = sorted(glob.glob(str(ROOT / "configs" / "*.yaml")) + glob.glob(str(ROOT / "configs" / "sweeps" / "*.yaml")))


def _loader_accepts(mapping: dict, topic: str) -> None:
    """What the commands do with a file of ``topic``; raises InputError as they would."""
    from sarproc.quality.metrics import expectations_from_mapping
    from sarproc.simulation.scene import SceneParams, scene_from_mapping

    if topic == "expect":
        expectations_from_mapping(mapping, "f")
        return
    if topic == "sweep":
        build(model_of(SWEEP_MODEL), mapping, "f")
        return
    check_sections(mapping, "f")
    for section, target in SECTION_MODELS.items():
        if section in mapping:
            build(model_of(target), mapping[section], "f", section)
    if any(f.name in mapping for f in dataclasses.fields(SceneParams)):
        scene_from_mapping(mapping, "f")


def test_every_config_validates() -> None:
    assert len(CONFIGS) > 40
    validators = {t: jsonschema.Draft202012Validator(topic_schema(t)) for t in ("config", "expect", "sweep")}
    for v in validators.values():
        jsonschema.Draft202012Validator.check_schema(v.schema)
    for path in CONFIGS:
        errors = [e.message for e in validators[_topic(path)].iter_errors(load_yaml(path))]
        assert not errors, (path, errors[:3])


def _set(mapping: dict, dotted: str, value: object) -> dict:
    out = copy.deepcopy(mapping)
    node = out
    parts = dotted.split(".")
    for part in parts[:-1]:
        node = node[int(part)] if part.isdigit() else node.setdefault(part, {})
    node[parts[-1]] = value
    return out


# (key, value) that the loader refuses: the schema must refuse them too
WRONG = [
    ("radar.prff", "500 Hz"),  # unknown key
    ("radar.carrier_frequency", "10 km"),  # unit of the wrong kind
    ("radar.prf", -5),  # out of range
    ("radar.chirp", "sideways"),  # not a choice
    ("geometry.squint", 30),  # an angle without a unit
    ("acquisition.range_margin", True),  # a boolean for a quantity
    ("targets.points.0.amplitude", "big"),  # not a number
    ("targets.points.0.colour", "red"),  # unknown key in a list item
    ("effects.antena", {}),  # unknown effect
    ("effects.noise", {"snr": "20 Hz"}),  # effect key, wrong unit
    ("backproject.upsample", "eight"),  # integer expected
    ("backproject.upsample", 0),  # below its bound
    ("backproject.engine", "fast"),  # not a choice
    ("backproject.grid", 1),  # unknown stage key
    ("evalute", {}),  # misspelt section
]


@pytest.mark.parametrize("key,value", WRONG, ids=[f"{k}={v}" for k, v in WRONG])
def test_wrong_key_or_type_fails_schema_and_loader(key: str, value: object) -> None:
    demo = load_yaml(ROOT / "configs" / "demo.yaml")
    _loader_accepts(demo, "config")
    bad = _set(demo, key, value)
    with pytest.raises(InputError):
        _loader_accepts(bad, "config")
    for topic in ("config", "scene"):
        assert list(jsonschema.Draft202012Validator(topic_schema(topic)).iter_errors(bad)), (topic, key, value)


def test_wrong_expect_and_sweep_fail() -> None:
    expect = load_yaml(ROOT / "configs" / "demo_expect.yaml")
    for bad in (_set(expect, "irw_ratio_maxx", 1.1), _set(expect, "axes", {"range": {"pslr": 1}})):
        assert list(jsonschema.Draft202012Validator(topic_schema("expect")).iter_errors(bad))
        with pytest.raises(InputError):
            _loader_accepts(bad, "expect")
    sweep = load_yaml(ROOT / "configs" / "sweeps" / "backprojection.yaml")
    bad = _set(sweep, "repeats", "three")
    assert list(jsonschema.Draft202012Validator(topic_schema("sweep")).iter_errors(bad))


def test_scene_schema_needs_the_whole_scene() -> None:
    demo = load_yaml(ROOT / "configs" / "demo.yaml")
    partial = {k: v for k, v in demo.items() if k != "radar"}
    for topic in ("config", "scene"):
        assert list(jsonschema.Draft202012Validator(topic_schema(topic)).iter_errors(partial))
    stage_only = {"backproject": demo["backproject"]}
    assert not list(jsonschema.Draft202012Validator(topic_schema("config")).iter_errors(stage_only))


def test_schema_command() -> None:
    runner = CliRunner()
    out = runner.invoke(cli, ["schema", "coarse-focus"])
    assert out.exit_code == 0, out.output
    schema = json.loads(out.output)
    assert schema["title"] == "sarproc coarse_focus: section" and "on_alias" in schema["properties"]
    default = json.loads(runner.invoke(cli, ["schema"]).output)
    assert set(SECTION_MODELS) <= set(default["properties"]) and "radar" in default["properties"]
    bad = runner.invoke(cli, ["schema", "backprojekt"])
    assert bad.exit_code == 2 and "'backprojekt' is not one of" in bad.output


def _properties(schema: dict, where: str = ""):
    """(dotted key, property schema) of every key at any depth of an object schema."""
    for name, sub in schema.get("properties", {}).items():
        yield f"{where}{name}", sub
        for branch in [sub, *sub.get("anyOf", []), sub.get("items", {}), sub.get("additionalProperties") or {}]:
            if isinstance(branch, dict) and "properties" in branch:
                yield from _properties(branch, f"{where}{name}.")


def test_every_schema_is_valid_and_its_defaults_validate() -> None:
    """Each topic is a valid draft 2020-12 schema, and every default it shows ('0 deg', '1 GHz', ...)
    is a value its own key accepts, which the loader reads back as the declared SI default."""
    from sarproc.product.units import parse_quantity

    topics = ("config", "scene", "expect", "sweep", *SECTION_MODELS)
    checked = 0
    for topic in topics:
        schema = topic_schema(topic)
        jsonschema.Draft202012Validator.check_schema(schema)
        for key, sub in _properties(schema):
            if "default" not in sub:
                continue
            own = {k: v for k, v in sub.items() if k != "default"}
            errors = list(jsonschema.Draft202012Validator(own).iter_errors(sub["default"]))
            assert not errors, (topic, key, sub["default"], errors[0].message)
            if isinstance(sub["default"], str) and sub.get("x-kind"):
                parse_quantity(sub["default"], sub["x-kind"], key)  # reads back
            checked += 1
    assert checked > 150


def test_readable_defaults_read_back_exactly() -> None:
    from sarproc.product.schema import quantity_text
    from sarproc.product.units import parse_quantity

    for kind, values in {
        "frequency": (1.5e9, 120e6, 400.0, 0.0),
        "length": (5e3, 0.1, 2.5e-3, 0.0),
        "time": (1e-6, 2.5e-9, 60.0),
        "angle": (0.5235987755982988, -1.5707963267948966, 0.0),
        "velocity": (7e3, -3.5),
        "decibel": (-30.0,),
    }.items():
        for v in values:
            text = quantity_text(v, kind)
            assert isinstance(text, str) and parse_quantity(text, kind) == pytest.approx(v, rel=1e-9, abs=1e-15), (
                kind,
                v,
                text,
            )
