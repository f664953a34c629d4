"""sarproc schema [config|scene|expect|sweep|SECTION]: JSON Schema of the YAML files, for editors.

Every schema comes from the parameter declarations (:mod:`sarproc.product.schema`). Building it
imports every stage (numba kernels and all, over a second), so the result is kept in
``config_schema.json`` beside this module: ``sarproc schema`` and each command's ``--help`` read
that file, and ``tests/cli/test_docs.py`` fails when it differs from the declarations. After
changing a parameter, regenerate it: ``make schema`` (``python -m sarproc.cli.schema``).
"""

from __future__ import annotations

import functools
import json
from pathlib import Path
from typing import Any

import click

SCHEMA_FILE = Path(__file__).with_name("config_schema.json")

# Every --config section and the parameter model it builds ("module:Class"); the commands that
# read each section are in sarproc.cli.main.COMMANDS (a stage's command is its section with "-").
SECTION_MODELS = {
    "backproject": "sarproc.focus.backprojection:BackprojectParams",
    "preprocess": "sarproc.focus.squint_deramp.preprocess:PreprocessParams",
    "coarse_focus": "sarproc.focus.squint_deramp.coarse_focus:CoarseFocusParams",
    "fine_focus": "sarproc.focus.squint_deramp.fine_focus:FineFocusParams",
    "pfa2": "sarproc.focus.pfa.chain:Pfa2Params",
    "reconstruct": "sarproc.focus.multichannel.reconstruct:ReconstructParams",
    "array3d": "sarproc.focus.array3d.linear_array:Array3DParams",
    "evaluate": "sarproc.quality.metrics:EvaluateParams",
    "geolocation": "sarproc.formats.geolocation:GeolocationParams",
}
SCENE_MODEL = "sarproc.simulation.scene:SceneParams"
EXPECT_MODEL = "sarproc.quality.metrics:Expectations"
SWEEP_MODEL = "sarproc.cli.sweep_tasks:SweepParams"
# The sections a config file may hold without a model of their own (read by no stage today).
FREE_SECTIONS = ("sweep",)
TOPICS = ("config", "scene", "expect", "sweep")


def model_of(target: str) -> type:
    """The parameter model named "module:Class" (imports its module)."""
    import importlib

    module, name = target.split(":")
    return getattr(importlib.import_module(module), name)


def _effects_schema() -> dict:
    """``effects:``: each registered effect by name, with its parameters (``{}`` or empty for none)."""
    import importlib

    from sarproc.product.schema import model_schema
    from sarproc.simulation.effects import EFFECTS

    props = {}
    for key in sorted(EFFECTS):
        cls: Any = EFFECTS[key]
        schema = model_schema(cls.Params)
        doc = (importlib.import_module(cls.__module__).__doc__ or "").strip().split("\n")[0]
        props[key] = {"anyOf": [schema, {"type": "null"}], "description": doc.rstrip(".")}
    return {
        "type": "object",
        "properties": props,
        "additionalProperties": False,
        "description": "effect name -> its parameters; only these are simulated",
        "default": {},
    }


def build_schemas() -> dict:
    """Every schema from the declarations (imports every stage: slow; for ``make schema`` and the tests)."""
    from sarproc.product.schema import model_schema
    from sarproc.quality.metrics import AxisBounds, Expectations, TargetBounds

    scene_cls = model_of(SCENE_MODEL)
    scene = model_schema(scene_cls, {(scene_cls, "effects"): _effects_schema()})
    axis = model_schema(AxisBounds)
    target = model_schema(TargetBounds, {(TargetBounds, "axes"): _per_name(axis, "per-axis overrides: {axis: bounds}")})
    expect = model_schema(
        model_of(EXPECT_MODEL),
        {
            (Expectations, "axes"): _per_name(axis, "per-axis overrides: {axis: bounds}"),
            (Expectations, "targets"): _per_name(target, "per-target overrides: {name: bounds, axes: {...}}"),
        },
    )
    sweep = model_schema(model_of(SWEEP_MODEL))
    focus = sweep["properties"]["focus"]  # one command may be written without the list
    sweep["properties"]["focus"] = {
        "anyOf": [{"type": "string"}, {k: v for k, v in focus.items() if k in ("type", "items")}],
        **{k: v for k, v in focus.items() if k not in ("type", "items")},
    }
    sections = {name: model_schema(model_of(target)) for name, target in SECTION_MODELS.items()}
    return {"scene": scene, "sections": sections, "expect": expect, "sweep": sweep}


def _per_name(value_schema: dict, description: str) -> dict:
    return {"type": "object", "additionalProperties": value_schema, "description": description, "default": {}}


@functools.cache
def stored_schemas() -> dict:
    """The schemas of ``config_schema.json`` (cheap: no stage is imported)."""
    return json.loads(SCHEMA_FILE.read_text(encoding="utf-8"))


def topic_schema(topic: str, schemas: dict | None = None) -> dict:
    """The standalone JSON Schema of one topic: a config file (scene and stage sections, each
    optional, a scene complete once any of its sections is given), a scene file, an --expect file,
    a sweep file, or one section (``backproject``, ``coarse_focus`` or ``coarse-focus`` ...)."""
    schemas = stored_schemas() if schemas is None else schemas
    section = topic.replace("-", "_")
    head = {"$schema": "https://json-schema.org/draft/2020-12/schema"}
    if topic in ("config", "scene"):
        scene = schemas["scene"]
        extra = {name: {**s, "description": f"parameters of {name}"} for name, s in schemas["sections"].items()}
        extra.update({name: {"type": ["object", "null"]} for name in FREE_SECTIONS})
        out = {
            **head,
            "title": "sarproc scene file" if topic == "scene" else "sarproc config file (scene and stage sections)",
            "type": "object",
            "properties": {**scene["properties"], **extra},
            "additionalProperties": False,
        }
        if topic == "scene":
            out["required"] = scene["required"]
        else:  # stage-only files are fine; a scene section asks for the whole scene
            out["dependentRequired"] = dict.fromkeys(scene["properties"], scene["required"])
        return out
    if topic in ("expect", "sweep"):
        title = "sarproc evaluate --expect file" if topic == "expect" else "sarproc sweep file"
        return {**head, "title": title, **schemas[topic]}
    if section in schemas["sections"]:
        return {**head, "title": f"sarproc {section}: section", **schemas["sections"][section]}
    known = ", ".join(TOPICS + tuple(schemas["sections"]))
    from sarproc.product.errors import InputError

    raise InputError(f"schema: {topic!r} is not one of {known}")


def section_rows(section: str) -> list[tuple[str, str]]:
    """(key, description) of every key of a --config section, or of a scene, sweep or --expect file
    (``scene``, ``sweep``, ``expect``), from the stored schema."""
    from sarproc.product.schema import key_rows

    schemas = stored_schemas()
    return key_rows(schemas[section] if section in ("scene", "sweep", "expect") else schemas["sections"][section])


def write_schema_file(path: Path = SCHEMA_FILE) -> None:
    """Regenerate ``config_schema.json`` from the declarations."""
    text = json.dumps(build_schemas(), indent=1, ensure_ascii=False) + "\n"
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(text, encoding="utf-8")
    tmp.replace(path)


@click.command()
@click.argument("topic", default="config", metavar="[config|scene|expect|sweep|SECTION]")
def schema(topic: str) -> None:
    """Print the JSON Schema (draft 2020-12) of sarproc's YAML files, for editors.

    config (default): a --config or scene file with any stage sections; scene: a scene file;
    expect: an evaluate --expect file; sweep: a sweep file; SECTION: one stage's section
    (backproject, pfa2, coarse_focus, evaluate, geolocation ...). For example, with the YAML
    language server: sarproc schema > sarproc.schema.json, then put
    '# yaml-language-server: $schema=sarproc.schema.json' on a YAML file's first line.
    """
    click.echo(json.dumps(topic_schema(topic), indent=2, ensure_ascii=False))


if __name__ == "__main__":  # make schema
    write_schema_file()
    print(f"wrote {SCHEMA_FILE}")
