"""Imports run one way: cli -> formats / focus / simulation -> quality / dsp -> product.

Every module of the package is parsed (no import side effects) and each of its imports,
including those inside functions, is checked against the layer ranks below. A layer may
import itself and any layer of lower rank, never a sibling of the same rank or one above.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[2] / "sarproc"

# Rank of each top-level sub-package; equal ranks are siblings and may not import each other.
# formats (CPHD, SICD, Gotcha, geolocation) sits above product and dsp: only cli imports it.
LAYER_RANK = {"product": 0, "dsp": 1, "quality": 1, "focus": 2, "simulation": 2, "formats": 2, "cli": 3}


def module_name(path: Path, root: Path = PACKAGE) -> str:
    parts = list(path.relative_to(root.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def imported_modules(source: str, module: str, is_package: bool) -> list[tuple[int, str]]:
    """(line, absolute module name) of every import in ``source`` that names a sarproc module."""
    package = module if is_package else module.rpartition(".")[0]
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            found.append((node.lineno, target))
            # "from sarproc.x import y" may import the sub-module y itself
            found += [(node.lineno, f"{target}.{alias.name}") for alias in node.names]
    return [(line, name) for line, name in found if name == "sarproc" or name.startswith("sarproc.")]


def layer_of(module: str) -> str | None:
    """The layer a module belongs to; None for the package root (version, entry point)."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 and parts[1] in LAYER_RANK else None


def violations(source: str, module: str, is_package: bool = False) -> list[str]:
    here = layer_of(module)
    out = []
    for line, target in imported_modules(source, module, is_package):
        there = layer_of(target)
        if here is None or there is None or there == here:
            continue
        if LAYER_RANK[there] >= LAYER_RANK[here]:
            out.append(f"{module}:{line} imports {target} ({here} may not import {there})")
    return out


def package_modules():
    return sorted(p for p in PACKAGE.rglob("*.py") if "__pycache__" not in p.parts)


def test_every_module_belongs_to_a_layer():
    """No module outside the layers except the package root's __init__ and __main__."""
    stray = [
        module_name(p)
        for p in package_modules()
        if layer_of(module_name(p)) is None and module_name(p) not in ("sarproc", "sarproc.__main__")
    ]
    assert stray == []


@pytest.mark.parametrize("path", package_modules(), ids=lambda p: module_name(p))
def test_imports_run_downward(path):
    assert violations(path.read_text(), module_name(path), path.name == "__init__.py") == []


@pytest.mark.parametrize(
    "layer, bad_import",
    [
        ("product", "from sarproc.dsp.interp import resample"),
        ("product", "import sarproc.cli.main"),
        ("dsp", "from sarproc.quality import metrics"),
        ("quality", "from ..dsp.phasor import unit_phasor"),
        ("focus", "from sarproc.simulation.simulate import simulate"),
        ("simulation", "from sarproc.focus.backprojection import backproject"),
        ("focus", "    from sarproc.cli.options import summary"),
        ("product", "from sarproc.formats.cphd import read_cphd"),
        ("dsp", "from sarproc.formats.geolocation import placement"),
        ("focus", "from sarproc.formats.gotcha import gotcha_product"),
        ("formats", "from sarproc.cli.stage import plan_outputs"),
    ],
)
def test_checker_catches_an_upward_or_sideways_import(layer, bad_import):
    """The rule bites: a deliberate upward or sibling import is reported (also when indented in a function)."""
    source = f"def f():\n{bad_import if bad_import.startswith(' ') else '    ' + bad_import}\n"
    assert violations(source, f"sarproc.{layer}.example") != []


@pytest.mark.parametrize(
    "layer, good_import",
    [
        ("cli", "from sarproc.focus.backprojection import backproject"),
        ("focus", "from sarproc.quality.metrics import evaluate_product"),
        ("focus", "from .stolt import stolt_resample"),
        ("simulation", "from sarproc.dsp.phasor import unit_phasor"),
        ("product", "from sarproc import __version__"),
        ("formats", "from sarproc.dsp.rangecomp import chirp_replica"),
        ("formats", "from sarproc.product.io import atomic_path"),
        ("cli", "from sarproc.formats.cphd import read_cphd"),
    ],
)
def test_checker_allows_downward_imports(layer, good_import):
    assert violations(good_import + "\n", f"sarproc.{layer}.squint_deramp.example") == []
