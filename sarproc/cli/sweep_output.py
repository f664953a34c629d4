"""Reading a finished sweep's output directory (``sarproc sweep``): its rows, task folders and raw products.

A sweep writes ``DIR/table.json`` (one row per task: its scene, setting, times and worst quality),
``DIR/tasks/<task>/`` (the task's config.yaml, its products and report.json) and ``DIR/raw/`` (one raw
product per distinct simulation, ``<scene>-<key>.h5`` beside the scene YAML it was simulated from, shared
by every task whose scene simulates the same). Scripts that tabulate a sweep read it through these.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from sarproc.product.config import load_yaml
from sarproc.product.errors import InputError


def sweep_rows(directory: Path) -> list[dict[str, Any]]:
    """Rows of a sweep's table.json, each with its task folder under ``"dir"``; a sweep with failed tasks is
    refused (its table is incomplete)."""
    directory = Path(directory)
    path = directory / "table.json"
    if not path.exists():
        raise InputError(f"{path}: no sweep table (run `sarproc sweep ... -o {directory}` first)")
    doc = json.loads(path.read_text())
    if doc["failures"]:
        raise InputError(f"{path}: the sweep has failed tasks {doc['failures']}; rerun it to retry them")
    return [{**row, "dir": directory / "tasks" / row["task"]} for row in doc["rows"]]


def pick_row(rows: list[dict[str, Any]], **match: Any) -> dict[str, Any]:
    """The one row whose columns equal ``match`` (e.g. ``scene="vr20-image"``)."""
    found = [r for r in rows if all(r.get(k) == v for k, v in match.items())]
    if len(found) != 1:
        raise InputError(f"expected one sweep row with {match}, found {len(found)}")
    return found[0]


def _scene_part(config: dict[str, Any]) -> dict[str, Any]:
    """The sections of a task config that the simulation reads (every stage's section left out)."""
    from sarproc.cli.sweep_tasks import STAGE_PARAMS

    stages = {section for section, _ in STAGE_PARAMS.values()}
    return {k: v for k, v in config.items() if k not in stages}


def same_simulation(task_a: Path, task_b: Path) -> bool:
    """Whether two task folders (of one sweep or of two) simulate the same scene: their configs' sections other
    than the stages' are equal (so are their raw products: the simulation is deterministic)."""
    return _scene_part(load_yaml(Path(task_a) / "config.yaml")) == _scene_part(load_yaml(Path(task_b) / "config.yaml"))


def raw_product_of(directory: Path, scene: str) -> Path:
    """The raw product a sweep simulated for ``scene``: the one whose scene YAML holds the simulation sections
    of the scene's first task (raw products are shared between scenes that simulate the same and named after
    the first of them)."""
    directory = Path(directory)
    tasks = [r for r in sweep_rows(directory) if r["scene"] == scene]
    if not tasks:
        raise InputError(f"{directory}: no task of scene {scene!r}")
    want = _scene_part(load_yaml(tasks[0]["dir"] / "config.yaml"))
    for path in sorted((directory / "raw").glob("*.yaml")):
        if _scene_part(load_yaml(path)) == want:
            return path.with_suffix(".h5")
    raise InputError(f"{directory}: no raw product for scene {scene!r}")
