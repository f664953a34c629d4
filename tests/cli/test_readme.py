"""README cannot drift: it names every subcommand (from the click group) and every scene key (from
the scene and effect declarations)."""

from __future__ import annotations

import re
from pathlib import Path

from helpers import scene_keys
from sarproc.cli.main import cli

ROOT = Path(__file__).resolve().parents[2]


def _readme() -> str:
    return (ROOT / "README.md").read_text(encoding="utf-8")


def test_readme_lists_every_subcommand() -> None:
    text = _readme()
    for name in cli.list_commands(None):  # type: ignore[arg-type]
        assert re.search(rf"(?m)^sarproc {re.escape(name)}\s", text), f"README's command list lacks {name}"


def test_readme_lists_every_scene_key() -> None:
    """The Scenes table has a row per section (and per nested model: `targets.points[]`,
    `effects.antenna` ...) naming each of its keys in backquotes."""
    rows = {}
    for line in _readme().split("## Scenes", 1)[1].split("\n## ", 1)[0].splitlines():
        cells = line.split("|")
        if len(cells) > 3 and re.fullmatch(r"\s*`[^`]+`\s*", cells[1]):
            rows[cells[1].strip().strip("`")] = "|".join(cells[2:])
    for key in scene_keys():
        parent, _, name = key.rpartition(".")
        if not parent:
            assert name in rows, f"README's scene table has no row `{name}`"
        else:
            assert parent in rows, f"README's scene table has no row `{parent}` (for {key})"
            assert f"`{name}`" in rows[parent], f"README's row `{parent}` does not name `{name}`"
