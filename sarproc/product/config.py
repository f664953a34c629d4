"""Typed parameter models built from YAML mappings, with units, bounds and unknown-key checks.

A parameter model is a frozen dataclass whose fields are declared with :func:`param`.
:func:`build` turns a mapping (from YAML) into such a dataclass, converting quantities to SI,
checking bounds and choices, recursing into nested models and lists of models, and naming the
file and the dotted key path in every error. :func:`as_dict` gives the resolved values back
(SI floats) for the product history.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import sys
import typing
from pathlib import Path
from typing import TYPE_CHECKING

from sarproc.product.errors import InputError
from sarproc.product.units import parse_quantity

if TYPE_CHECKING:
    from collections.abc import Collection, Iterable, Mapping
    from typing import Any


MISSING = dataclasses.MISSING
T = typing.TypeVar("T")

# Top-level sections one YAML file may hold besides a scene's: each processing stage reads its
# own (STAGE_SECTIONS), other commands theirs (OTHER_SECTIONS). Any other key is refused, so a
# misspelt section cannot be ignored silently. A new stage adds its section here.
STAGE_SECTIONS = (
    "backproject",
    "preprocess",
    "coarse_focus",
    "fine_focus",
    "pfa2",
    "reconstruct",
    "array3d",
    "evaluate",
)
OTHER_SECTIONS = ("geolocation", "sweep")


def param(
    unit: str | None = None,
    default: Any = MISSING,
    *,
    gt: float | None = None,
    ge: float | None = None,
    lt: float | None = None,
    le: float | None = None,
    choices: tuple | None = None,
    doc: str = "",
) -> typing.Any:
    """Declare a parameter: ``unit`` is a quantity kind of :mod:`sarproc.product.units` (or None)."""
    meta = {"unit": unit, "gt": gt, "ge": ge, "lt": lt, "le": le, "choices": choices, "doc": doc}
    if isinstance(default, (list, dict)):
        return dataclasses.field(default_factory=lambda d=default: type(d)(d), metadata=meta)  # type: ignore[misc]
    return dataclasses.field(default=default, metadata=meta)


@functools.cache
def _strict_loader() -> type:
    """SafeLoader subclass that refuses a key given twice in one mapping (plain YAML keeps the last).

    Built on first use: ``import yaml`` (~25 ms, mostly compiling its regular expressions) is paid only by
    commands that read a YAML file, not by every stage's start (docs/performance.md, eighth round)."""
    import yaml

    def construct_mapping(loader: yaml.SafeLoader, node: yaml.MappingNode, deep: bool = False) -> dict:
        loader.flatten_mapping(node)
        seen: dict = {}
        for key_node, _ in node.value:
            key = loader.construct_object(key_node, deep=True)
            try:
                hash(key)
            except TypeError:
                raise InputError(f"line {key_node.start_mark.line + 1}: a mapping key must be a plain name") from None
            if key in seen:
                raise yaml.constructor.ConstructorError(
                    None,
                    None,
                    f"key {key!r} is given twice (first on line {seen[key] + 1}); keep one",
                    key_node.start_mark,
                )
            seen[key] = key_node.start_mark.line
        return loader.construct_mapping(node, deep=deep)

    class StrictLoader(yaml.SafeLoader):
        pass

    StrictLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, construct_mapping)
    # Dates stay strings ('2024-05-01T10:00:00Z'): parameters that are times parse them with their zone.
    StrictLoader.yaml_implicit_resolvers = {
        first: [(tag, rx) for tag, rx in resolvers if tag != "tag:yaml.org,2002:timestamp"]
        for first, resolvers in yaml.SafeLoader.yaml_implicit_resolvers.items()
    }
    return StrictLoader


_STDIN: dict[int, bytes] = {}


def read_stdin() -> bytes:
    """Standard input, read once per stream: a scene and a config both named ``-`` are the same text."""
    stream = sys.stdin.buffer
    if id(stream) not in _STDIN:
        _STDIN.clear()
        _STDIN[id(stream)] = stream.read()
    return _STDIN[id(stream)]


def load_yaml(path: str | Path) -> dict:
    """Read a YAML mapping (UTF-8, no key given twice); errors name the file and the line. ``-``: standard input."""
    path = Path(path)
    if str(path) != "-":
        if not path.exists():
            raise InputError(f"{path}: file not found")
        if path.is_dir():
            raise InputError(f"{path}: is a directory; expected a YAML file")
    try:
        text = (read_stdin() if str(path) == "-" else path.read_bytes()).decode("utf-8")
    except UnicodeDecodeError as exc:
        raise InputError(f"{path}: not a UTF-8 text file (byte {exc.start}); expected YAML") from None
    except OSError as exc:
        raise InputError(f"{path}: cannot read: {exc.strerror}") from None
    if "\x00" in text:
        raise InputError(f"{path}: contains NUL bytes (a binary file?); expected YAML")
    import yaml

    try:
        data = yaml.load(text, Loader=_strict_loader())  # a SafeLoader subclass
    except yaml.YAMLError as exc:
        raise InputError(f"{path}: not valid YAML: {' '.join(str(exc).split())}") from None
    except InputError as exc:
        raise InputError(f"{path}: {exc}") from None
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise InputError(f"{path}: expected a mapping at the top level, got {type(data).__name__}")
    _check_keys(data, path, "")
    return data


def _check_keys(data: object, path: str | Path, where: str) -> None:
    """Every mapping key must be a string (``1:`` or ``true:`` is a typo, not a parameter)."""
    if isinstance(data, dict):
        for k, v in data.items():
            if not isinstance(k, str):
                at = f"{where}: " if where else ""
                raise InputError(f"{path}: {at}key {k!r} is not a name; keys are words like 'prf'")
            _check_keys(v, path, f"{where}.{k}" if where else k)
    elif isinstance(data, list):
        for i, v in enumerate(data):
            _check_keys(v, path, f"{where}[{i}]")


def _is_model(tp: object) -> bool:
    return isinstance(tp, type) and dataclasses.is_dataclass(tp)


def _convert(value: object, tp: Any, meta: Mapping[str, Any], where: str) -> Any:
    origin = typing.get_origin(tp)
    args = typing.get_args(tp)
    if origin is typing.Union or (origin is not None and str(origin) == "<class 'types.UnionType'>"):
        non_none = [a for a in args if a is not type(None)]
        if value is None and len(non_none) < len(args):
            return None
        tp = non_none[0]
        origin, args = typing.get_origin(tp), typing.get_args(tp)
    if _is_model(tp):
        if not isinstance(value, dict):
            raise InputError(f"{where}: expected a mapping, got {type(value).__name__}")
        return _build(tp, value, where)
    if origin in (list, tuple):
        item_tp = args[0] if args else typing.Any
        if not isinstance(value, (list, tuple)):
            raise InputError(f"{where}: expected a list, got {type(value).__name__}")
        items = [_convert(v, item_tp, meta, f"{where}[{i}]") for i, v in enumerate(value)]
        return tuple(items)
    if origin is dict or tp is dict:
        if not isinstance(value, dict):
            raise InputError(f"{where}: expected a mapping, got {type(value).__name__}")
        return dict(value)
    if tp is float:
        unit = meta.get("unit") or "dimensionless"
        out = parse_quantity(value, unit, where)
        _check_bounds(out, meta, where, value)
        return out
    if tp is int:
        if isinstance(value, bool) or not isinstance(value, int):
            if isinstance(value, float) and value.is_integer():
                value = int(value)
            else:
                raise InputError(f"{where}: expected an integer, got {value!r}")
        _check_bounds(value, meta, where, value)
        return int(value)
    if tp is bool:
        if not isinstance(value, bool):
            raise InputError(f"{where}: expected true or false, got {value!r}")
        return value
    if tp is str:
        if not isinstance(value, str):
            hint = ""
            if isinstance(value, bool):  # YAML 1.1: unquoted yes/no/on/off/y/n are booleans
                hint = '; YAML reads an unquoted yes, no, on or off as true or false: quote it ("OFF")'
            elif isinstance(value, int | float):
                hint = "; quote it to keep it as text"
            raise InputError(f"{where}: expected a string, got {value!r}{hint}")
        choices = meta.get("choices")
        if choices and value not in choices:
            raise InputError(f"{where}: {value!r} is not one of {list(choices)}")
        return value
    return value


SI_SYMBOL = {
    "frequency": "Hz",
    "length": "m",
    "time": "s",
    "angle": "rad",
    "velocity": "m/s",
    "chirp_rate": "Hz/s",
    "decibel": "dB",
}


def _check_bounds(x: float, meta: Mapping[str, Any], where: str, raw: object) -> None:
    if isinstance(x, float) and math.isnan(x):
        raise InputError(f"{where}: NaN is not allowed")
    tests = (
        ("gt", lambda a, b: a > b, ">"),
        ("ge", lambda a, b: a >= b, ">="),
        ("lt", lambda a, b: a < b, "<"),
        ("le", lambda a, b: a <= b, "<="),
    )
    for key, ok, sym in tests:
        bound = meta.get(key)
        if bound is not None and not ok(x, bound):
            si = SI_SYMBOL.get(meta.get("unit") or "", "")
            raise InputError(f"{where}: {raw!r} is out of range: must be {sym} {bound:g}{' ' + si if si else ''}")
    choices = meta.get("choices")
    if choices and x not in choices:
        raise InputError(f"{where}: {raw!r} is not one of {list(choices)}")


def _build(cls: Any, mapping: dict, where: str) -> Any:
    hints = typing.get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls) if f.init}
    unknown = sorted((k for k in mapping if k not in fields), key=str)
    if unknown:
        raise InputError(
            f"{where + ': ' if where else ''}unknown key(s) {', '.join(map(repr, unknown))}"
            f"{did_you_mean(unknown, fields)}; allowed: {', '.join(sorted(fields))}"
        )
    kwargs = {}
    for name, f in fields.items():
        key = f"{where}.{name}" if where else name
        if name in mapping:
            kwargs[name] = _convert(mapping[name], hints[name], f.metadata, key)
        elif f.default is MISSING and f.default_factory is MISSING:
            raise InputError(
                f"{key}: required key is missing" + (f" ({f.metadata['doc']})" if f.metadata.get("doc") else "")
            )
    try:
        obj = cls(**kwargs)
        check = getattr(obj, "validate", None)
        if check is not None:
            check()
    except InputError as exc:
        msg = str(exc)
        head = msg.split(":", 1)[0]
        if where and head in fields:  # "frame: ..." from validate() -> "targets.frame: ..."
            msg = f"{where}.{msg}"
        elif where and not msg.startswith(where):
            msg = f"{where}: {msg}"
        raise InputError(msg) from None
    return obj


def did_you_mean(unknown: Iterable[str], known: Collection[str]) -> str:
    """' (did you mean 'x'?)' for the first unknown name close to a known one, else ''."""
    import difflib

    for name in unknown:
        close = difflib.get_close_matches(str(name), list(known), n=1, cutoff=0.6)
        if close:
            return f" (did you mean {close[0]!r}?)"
    return ""


def build(cls: type[T], mapping: object, source: str = "", section: str = "") -> T:
    """Build parameter model ``cls`` from ``mapping``; errors read ``source: section.key: why``.

    A model may define ``validate(self)`` raising :class:`InputError` for cross-field checks.
    """
    mapping = {} if mapping is None else mapping
    if not isinstance(mapping, dict):
        prefix = f"{source}: " if source else ""
        raise InputError(
            f"{prefix}{section or 'parameters'}: expected a mapping of keys, got {type(mapping).__name__} {mapping!r}"
        )
    try:
        return _build(cls, mapping, section)
    except InputError as exc:
        prefix = f"{source}: " if source else ""
        raise InputError(prefix + str(exc)) from None


def as_dict(obj: object) -> dict:
    """Resolved parameters as plain Python values (SI floats), for history and YAML dumps."""

    def conv(v: object) -> Any:
        if dataclasses.is_dataclass(v):
            return {f.name: conv(getattr(v, f.name)) for f in dataclasses.fields(v)}
        if isinstance(v, (list, tuple)):
            return [conv(x) for x in v]
        if isinstance(v, dict):
            return {k: conv(x) for k, x in v.items()}
        if hasattr(v, "item") and callable(v.item):
            return v.item()
        return v

    return conv(obj)
