"""JSON Schema of parameter models (:mod:`sarproc.product.config`), and their key lists for ``--help``.

One source: the ``param(...)`` declarations of a model (type, unit kind, bounds, choices, default,
doc) become a JSON Schema (draft 2020-12) that editors use to check and complete the YAML files,
and the same schema, rendered by :func:`key_rows`, is what each command's ``--help`` lists. A
quantity accepts a bare number (SI; refused for a nonzero angle, as the loader does) or a string
with a unit of its kind; the schema carries the SI unit as ``x-unit`` and the kind as ``x-kind``.
Cross-field rules (``validate()`` methods) are not expressible here; the loader still checks them.
"""

from __future__ import annotations

import dataclasses
import math
import re
import types
import typing
from typing import Any

from sarproc.product.config import MISSING, SI_SYMBOL
from sarproc.product.units import unit_symbols

DRAFT = "https://json-schema.org/draft/2020-12/schema"
_NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
# readable defaults: the prefixes a value in SI is shown with (1.5e9 Hz -> "1.5 GHz")
_PREFIXES = ((1e9, "G"), (1e6, "M"), (1e3, "k"), (1.0, ""), (1e-3, "m"), (1e-6, "u"), (1e-9, "n"))


def _is_model(tp: Any) -> bool:
    return isinstance(tp, type) and dataclasses.is_dataclass(tp)


def quantity_text(value: float, kind: str | None) -> str | float:
    """An SI value as the YAML a user would write: '1.5 GHz', '30 deg'; a plain number without a unit."""
    if kind is None or kind == "dimensionless" or kind not in SI_SYMBOL:
        return value
    if kind == "angle":
        return f"{math.degrees(value):.10g} deg"
    symbol = SI_SYMBOL[kind]
    if kind in ("frequency", "length", "time") and value != 0:
        for factor, prefix in _PREFIXES:
            if abs(value) >= factor * 0.9999999:
                return f"{value / factor:.10g} {prefix}{symbol}"
        return f"{value / 1e-9:.10g} n{symbol}"
    return f"{value:.10g} {symbol}"


def _bounds(meta: dict) -> dict:
    out = {}
    for key, word in (("gt", "exclusiveMinimum"), ("ge", "minimum"), ("lt", "exclusiveMaximum"), ("le", "maximum")):
        if meta.get(key) is not None:
            out[word] = meta[key]
    return out


def _quantity(kind: str | None, meta: dict) -> dict:
    """Number (SI) or string with a unit of ``kind``; bounds apply to the SI number."""
    kind = kind or "dimensionless"
    symbols = sorted((s for s in unit_symbols(kind) if s), key=len, reverse=True)
    unit = "(?:" + "|".join(re.escape(s) for s in symbols) + ")" if symbols else ""
    if kind == "dimensionless":
        text = {"type": "string", "pattern": rf"^\s*{_NUMBER}\s*$"}
    else:
        text = {"type": "string", "pattern": rf"^\s*{_NUMBER}\s*{unit}\s*$"}
    number = {"type": "number", **_bounds(meta)}
    if kind == "angle":  # a bare number is refused (degrees or radians?), except 0
        number = {"const": 0, **_bounds(meta)}
    out: dict = {"anyOf": [number, text]}
    if kind != "dimensionless":
        out["x-kind"] = kind
        out["x-unit"] = SI_SYMBOL.get(kind, "")
    return out


def type_schema(tp: Any, meta: dict, dict_values: dict | None = None) -> dict:
    """JSON Schema of one annotated type with the field's metadata (unit, bounds, choices)."""
    origin, args = typing.get_origin(tp), typing.get_args(tp)
    if origin is typing.Union or origin is types.UnionType:
        inner = [a for a in args if a is not type(None)]
        out = type_schema(inner[0], meta, dict_values)
        if len(inner) < len(args):
            out = {"anyOf": [out, {"type": "null"}], **{k: v for k, v in out.items() if k.startswith("x-")}}
        return out
    if _is_model(tp):
        return model_schema(tp, dict_values)
    if origin in (list, tuple):
        item = args[0] if args else Any
        items = type_schema(item, meta, dict_values) if item is not Any else {}
        return {"type": "array", "items": items, **{k: v for k, v in items.items() if k.startswith("x-")}}
    if tp is float:
        return _quantity(meta.get("unit"), meta)
    if tp is int:
        return {"type": "integer", **_bounds(meta)}
    if tp is bool:
        return {"type": "boolean"}
    if tp is str:
        return {"type": "string", **({"enum": list(meta["choices"])} if meta.get("choices") else {})}
    if origin is dict or tp is dict:
        return {"type": "object"}
    return {}


def _default(f: dataclasses.Field, kind: str | None) -> Any:
    """The field's default as a valid YAML value (quantities with their unit), or MISSING."""
    if f.default is not MISSING:
        value = f.default
    elif f.default_factory is not MISSING:
        value = f.default_factory()
    else:
        return MISSING
    if _is_model(type(value)):
        return MISSING  # a nested model's defaults are listed key by key
    if isinstance(value, float):
        return quantity_text(value, kind)
    if isinstance(value, tuple):
        return [quantity_text(v, kind) if isinstance(v, float) else v for v in value]
    return value


def model_schema(cls: type, dict_values: dict | None = None) -> dict:
    """JSON Schema of parameter model ``cls``: an object of its declared keys, no others.

    ``dict_values``: {(model, field name): that field's schema} for fields typed ``dict`` whose
    values are themselves models (effects by name, per-target bounds); other dicts are free mappings.
    """
    hints = typing.get_type_hints(cls)
    props: dict = {}
    required = []
    for f in dataclasses.fields(cls):
        if not f.init:
            continue
        meta = dict(f.metadata)
        if dict_values and (cls, f.name) in dict_values:
            schema = dict(dict_values[(cls, f.name)])
        else:
            schema = type_schema(hints[f.name], meta, dict_values)
        doc = meta.get("doc") or ""
        if doc:
            schema["description"] = doc
        default = _default(f, meta.get("unit"))
        if default is not MISSING:
            schema["default"] = default
        elif f.default is MISSING and f.default_factory is MISSING:
            required.append(f.name)
        props[f.name] = schema
    out: dict = {"type": "object", "properties": props, "additionalProperties": False}
    if required:
        out["required"] = required
    if cls.__doc__ and not cls.__doc__.startswith(cls.__name__ + "("):  # not dataclass's generated signature
        out["description"] = " ".join(cls.__doc__.strip().split("\n\n")[0].split())
    return out


def _object_of(schema: dict) -> dict | None:
    """The object schema inside ``schema`` (optional or list of models), else None."""
    if schema.get("type") == "object" and "properties" in schema:
        return schema
    for branch in schema.get("anyOf", []):
        found = _object_of(branch)
        if found is not None:
            return found
    if schema.get("type") == "array":
        return _object_of(schema.get("items", {}))
    return None


def _is_list(schema: dict) -> bool:
    return schema.get("type") == "array" or any(_is_list(b) for b in schema.get("anyOf", []))


def _rule(schema: dict, kind: str | None = None) -> str:
    """Choices and bounds of one key in words: "one of a, b", "> 0 Hz" (looked for through anyOf)."""
    kind = schema.get("x-kind", kind)
    if "enum" in schema:
        return "one of " + ", ".join(map(str, schema["enum"]))
    words = {"exclusiveMinimum": ">", "minimum": ">=", "exclusiveMaximum": "<", "maximum": "<="}
    found = [f"{sym} {_yaml_text(quantity_text(schema[k], kind))}" for k, sym in words.items() if k in schema]
    if found:
        return ", ".join(found)
    for branch in schema.get("anyOf", []):
        rule = _rule(branch, kind)
        if rule:
            return rule
    return ""


def key_rows(schema: dict, prefix: str = "") -> list[tuple[str, str]]:
    """(dotted key, "[unit] doc; rule (default ...)") for every key of an object schema, nested ones
    as ``outer.inner`` and list items as ``outer[].inner``; the rows ``--help`` prints."""
    rows = []
    required = set(schema.get("required", ()))
    for name, sub in schema.get("properties", {}).items():
        key = prefix + name
        unit = "[deg|rad] " if sub.get("x-kind") == "angle" else (f"[{sub['x-unit']}] " if sub.get("x-unit") else "")
        said = "; ".join(p for p in (sub.get("description", ""), _rule(sub)) if p)
        if "default" in sub:
            default = sub["default"]
            tail = f"(default {default if isinstance(default, str) else _yaml_text(default)})"
        else:
            tail = "(required)" if name in required else ""
        rows.append((key, unit + " ".join(p for p in (said, tail) if p)))
        inner = _object_of(sub)
        if inner is not None:
            rows.extend(key_rows(inner, key + ("[]." if _is_list(sub) else ".")))
        extra = sub.get("additionalProperties")
        per_name = _object_of(extra) if isinstance(extra, dict) else None
        if per_name is not None:  # {name: model}: the model's keys under NAME
            rows.extend(key_rows(per_name, key + ".NAME."))
    return rows


def _yaml_text(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, list):
        return "[" + ", ".join(_yaml_text(v) for v in value) + "]"
    if value is None:
        return "none"
    if isinstance(value, dict):
        return "{}" if not value else str(value)
    return f"{value:g}" if isinstance(value, float) else str(value)
