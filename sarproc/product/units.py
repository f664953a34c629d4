"""Quantities with units in YAML ("10 GHz", "30 deg", "7 km/s") converted to SI floats.

Each parameter declares a *kind* (frequency, length, angle, ...). A string must carry a unit
of that kind; a bare number is taken as SI for every kind except ``angle``, where it is
refused because degrees-versus-radians is the classic silent bug.
"""

from __future__ import annotations

import math
import re

from sarproc.product.errors import InputError

_PREFIX = {"T": 1e12, "G": 1e9, "M": 1e6, "k": 1e3, "": 1.0, "m": 1e-3, "u": 1e-6, "µ": 1e-6, "n": 1e-9, "p": 1e-12}

# kind -> {unit symbol: factor to SI}; prefixes are expanded below for the base symbols.
_BASE = {
    "frequency": ("Hz", 1.0),
    "length": ("m", 1.0),
    "time": ("s", 1.0),
}
_EXTRA = {
    "angle": {"rad": 1.0, "mrad": 1e-3, "urad": 1e-6, "deg": math.pi / 180.0, "°": math.pi / 180.0},
    "velocity": {"m/s": 1.0, "km/s": 1e3, "km/h": 1.0 / 3.6},
    "chirp_rate": {"Hz/s": 1.0, "kHz/s": 1e3, "MHz/s": 1e6, "MHz/us": 1e12, "GHz/s": 1e9, "Hz/us": 1e6},
    "decibel": {"dB": 1.0},
    "dimensionless": {"": 1.0},
    "time": {"min": 60.0},
}
KINDS = ("frequency", "length", "time", "angle", "velocity", "chirp_rate", "decibel", "dimensionless")


def _units_of(kind: str) -> dict[str, float]:
    table: dict[str, float] = {}
    if kind in _BASE:
        sym, f = _BASE[kind]
        for p, pf in _PREFIX.items():
            table[p + sym] = pf * f
    table.update(_EXTRA.get(kind, {}))
    return table


_TABLES = {k: _units_of(k) for k in KINDS}
_NUM = re.compile(r"^\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(.*?)\s*$")


def parse_quantity(value: object, kind: str, where: str = "value") -> float:
    """Return ``value`` as an SI float of ``kind``; ``where`` names the key for the error."""
    if kind not in _TABLES:
        raise ValueError(f"unknown quantity kind {kind!r}")
    if isinstance(value, bool):
        raise InputError(f"{where}: expected a {kind}, got a boolean {value!r}")
    if isinstance(value, (int, float)):
        if kind == "angle" and value != 0:
            raise InputError(
                f"{where}: an angle needs a unit (write '{value} deg' or '{value} rad'); bare numbers are refused"
            )
        out = float(value)
    elif isinstance(value, str):
        m = _NUM.match(value)
        if not m:
            raise InputError(f"{where}: cannot read {value!r} as a {kind} (expected e.g. {example(kind)!r})")
        number, unit = float(m.group(1)), m.group(2)
        table = _TABLES[kind]
        if unit not in table:
            other = [k for k in KINDS if unit in _TABLES[k]]
            hint = f" ({unit!r} is a {other[0]})" if other else ""
            raise InputError(
                f"{where}: unit {unit!r} is not a {kind} unit{hint}; "
                f"expected one of {sorted(u for u in table if u)[:8]}"
            )
        if kind == "angle" and unit == "" and number != 0:
            raise InputError(f"{where}: an angle needs a unit ('deg' or 'rad')")
        out = number * table[unit]
    else:
        raise InputError(f"{where}: expected a {kind} like {example(kind)!r}, got {type(value).__name__}")
    if not math.isfinite(out):
        raise InputError(f"{where}: {value!r} is not finite")
    return out


def example(kind: str) -> str:
    return {
        "frequency": "10 GHz",
        "length": "300 km",
        "time": "10 us",
        "angle": "30 deg",
        "velocity": "7 km/s",
        "chirp_rate": "5 MHz/us",
        "decibel": "20 dB",
        "dimensionless": "1.5",
    }[kind]


def unit_symbols(kind: str) -> tuple[str, ...]:
    """Every unit symbol a quantity of ``kind`` may carry ('' for a bare number), e.g. for a schema."""
    return tuple(_TABLES[kind])
