"""The longest functions of the package (issue 21: functions that do one thing).

    python scripts/longest_functions.py [--top 10] [--root sarproc]

Parses every module (no imports run) and prints a markdown table of the ``--top`` longest
functions and methods: lines from ``def`` to the last line of the body, docstring included.
"""

from __future__ import annotations

import argparse
import ast
from pathlib import Path


def function_lengths(root: Path) -> list[tuple[int, str]]:
    """(lines, "path:line name") of every function and method under ``root``."""
    found = []
    for path in sorted(root.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                lines = (node.end_lineno or node.lineno) - node.lineno + 1  # always set by ast.parse
                found.append((lines, f"{path}:{node.lineno} {node.name}"))
    return sorted(found, key=lambda item: (-item[0], item[1]))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--top", type=int, default=10)
    parser.add_argument("--root", type=Path, default=Path("sarproc"))
    args = parser.parse_args()
    print("| lines | function |\n|---:|---|")
    for lines, where in function_lengths(args.root)[: args.top]:
        print(f"| {lines} | `{where}` |")


if __name__ == "__main__":
    main()
