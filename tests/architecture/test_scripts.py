"""Scripts stand alone and tests never run them (issue 21): a script imports sarproc and libraries, no other
script; a test reaches the package, never scripts/ (by import, by path or with runpy).

Every file is parsed, not imported, so nothing here runs a script.
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
SCRIPTS = ROOT / "scripts"


def script_imports(source: str, scripts: set[str]) -> list[tuple[int, str]]:
    """(line, module) of every import in ``source`` of a module named like a script (or of a scripts package)."""
    found = []
    for node in ast.walk(ast.parse(source)):
        names: list[str] = []
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
            names = [node.module]
        found += [(node.lineno, n) for n in names if n.split(".")[0] in scripts | {"scripts"}]
    return found


# runpy, importlib, sys.path and subprocess calls: the ways to run or load a file by its path
LOADERS = {"run_path", "run_module", "spec_from_file_location", "import_module", "insert", "append", "run", "Popen"}
LOADERS |= {"call", "check_call", "check_output"}


def loads_a_script(source: str) -> list[int]:
    """Lines of a loader call (:data:`LOADERS`) with a string naming scripts/ or a file under it."""
    lines = []
    for node in ast.walk(ast.parse(source)):
        func = node.func if isinstance(node, ast.Call) else None
        name = func.attr if isinstance(func, ast.Attribute) else func.id if isinstance(func, ast.Name) else None
        if name in LOADERS:
            strings = [s.value for s in ast.walk(node) if isinstance(s, ast.Constant) and isinstance(s.value, str)]
            if any(s == "scripts" or s.startswith("scripts/") or "/scripts/" in s for s in strings):
                lines.append(node.lineno)
    return lines


def script_names() -> set[str]:
    return {p.stem for p in SCRIPTS.glob("*.py")}


def test_no_script_imports_another() -> None:
    names = script_names()
    assert len(names) > 10
    bad = [
        f"{p.name}:{line} imports {module}"
        for p in sorted(SCRIPTS.glob("*.py"))
        for line, module in script_imports(p.read_text(), names)
    ]
    assert bad == []


def test_no_test_loads_a_script() -> None:
    names = script_names()
    bad = []
    for p in sorted((ROOT / "tests").rglob("*.py")):
        source = p.read_text()
        bad += [f"{p.relative_to(ROOT)}:{line} imports {m}" for line, m in script_imports(source, names)]
        bad += [f"{p.relative_to(ROOT)}:{line} calls into scripts/" for line in loads_a_script(source)]
    assert bad == []


def test_the_checks_see_what_they_forbid() -> None:
    names = {"bench", "timed"}
    assert script_imports("import bench\nfrom timed import main\nimport numpy", names) == [(1, "bench"), (2, "timed")]
    assert script_imports("from scripts.bench import x\nfrom . import timed", names) == [(1, "scripts.bench")]
    assert loads_a_script("import runpy\nrunpy.run_path('scripts/bench.py')") == [2]
    assert loads_a_script("spec_from_file_location('b', ROOT / 'scripts' / 'bench.py')") == [1]
    assert loads_a_script("subprocess.run([sys.executable, 'scripts/bench.py'])") == [1]
    assert loads_a_script("open('docs/scripts.md')\nprint('scripts/ only tabulate')") == []
