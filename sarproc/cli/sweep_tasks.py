"""Sweeps: scenes x stage knobs expanded into tasks, run serially or on Dask, gathered into one table.

A sweep YAML names the scenes, the focusing chain and the knobs to vary::

    scenes:                          # name: scene YAML (relative to this file); its stage sections are the base
      stripmap: ../bp_stripmap.yaml
      alone: {file: ../bp_stripmap.yaml, targets: [A], set: {radar.prf: 500 Hz}}   # a variant of a scene file
    focus: backproject               # or a chain: [preprocess, coarse-focus, fine-focus]
    set: {backproject.margin_cells: 8}            # dotted key: value, applied to every task
    grid:                                         # dotted key: [values], cartesian product
      backproject.upsample: [1, 4, 16]
    cases:                                        # listed settings, each combined with every grid point
      - {backproject.interpolation: nearest}
      - {backproject.interpolation: linear}
    output: ../../results/sweep-bp               # default for -o (relative to this file)
    evaluate: true                                # false: no evaluate step (a chain whose product is no image)
    repeats: 3                                    # time the focus chain this many times (default 1)
    refusals: false                               # true: a step refusing its input is a row, not a failure

A scene given as a mapping is a variant of its ``file``: ``targets`` keeps only the named targets (a
target simulated and focused alone), ``set`` applies dotted keys to this scene only (after the sweep's
``set``, before the grid and cases).

Each task is one scene YAML with the knobs applied (written to ``tasks/<id>/config.yaml``): the raw
product is simulated from it (shared by every task whose scene sections resolve the same), each
focusing command of the chain runs with ``--config config.yaml``, then ``evaluate``. The stages are
the CLI's own commands, invoked in-process, so a sweep's products are exactly those of the shell
pipeline. Each output gets a ``<file>.done.json`` record with the key of its resolved inputs (sarproc
version, command, config, the key of its input product) and its run time; an output whose record
holds the same key is not recomputed. A killed sweep thus resumes where it stopped.

With ``repeats: N`` the focus chain of every task runs N times, interleaved: round-robin over the
tasks (every task's first run, then every task's second, ...), so a slow spell of a shared machine
hits all settings alike. The repeats write to ``tasks/<id>/repeat/`` (removed after), are checked to
give the first run's products bit for bit (``repeats_identical``) and leave their time in
``tasks/<id>/repeat-<k>.done.json``. The row's ``focus_s`` is the best of the N times, with
``focus_median_s`` and ``focus_spread_s`` (max - min); quality is the first run's. Each command of the chain
keeps its own times too (``focus_step_times``, in table.json): a chain's step timed over the repeats alone.

Dask is optional: ``run_serial`` needs nothing beyond sarproc; ``run_dask`` needs ``dask.distributed``
(``pip install 'sarproc[distributed]'``).
"""

from __future__ import annotations

import contextlib
import copy
import dataclasses
import hashlib
import io
import itertools
import json
import os
import re
import sys
import threading
import time
import uuid
from pathlib import Path
from typing import TYPE_CHECKING

from sarproc import __version__
from sarproc.cli.schema import SECTION_MODELS
from sarproc.product.config import STAGE_SECTIONS, build, load_yaml, param
from sarproc.product.errors import InputError, ProcessingError
from sarproc.quality.blas import one_blas_thread, single_blas

if TYPE_CHECKING:
    from collections.abc import Callable, Iterable, Iterator, Sequence
    from typing import TextIO

    from dask.distributed import Client

TIME_COLUMNS = ("simulate_s", "focus_s", "focus_median_s", "focus_spread_s", "evaluate_s")
# every key of a row that holds a measured time (focus_step_s: each focus command's seconds, first run;
# focus_step_times: each command's seconds over the first run and its repeats)
TIMING_KEYS = TIME_COLUMNS + ("focus_times", "focus_step_s", "focus_step_times")
QUALITY_COLUMNS = ("irw_dev", "pslr_db", "islr_db", "position_cells", "false_target_db")


@dataclasses.dataclass(frozen=True)
class SweepParams:
    scenes: dict = param(doc="name: scene YAML path (relative to the sweep file), or {file:, targets:, set:}")
    focus: tuple[str, ...] = param(default=("backproject",), doc="focusing command, or a chain of them")
    set: dict = param(default={}, doc="dotted key: value applied to every task")
    grid: dict = param(default={}, doc="dotted key: list of values; the tasks span their cartesian product")
    cases: tuple[dict, ...] = param(default=(), doc="listed settings (dotted key: value), each crossed with the grid")
    output: str | None = param(default=None, doc="output directory (relative to the sweep file)")
    evaluate: bool = param(default=True, doc="run evaluate on each task's last product (false: quality n/a)")
    repeats: int = param(default=1, doc="timed runs of each task's focus chain, interleaved over the tasks")
    refusals: bool = param(
        default=False,
        doc=(
            "a focusing or evaluate step that refuses its input (InputError, the CLI's exit 2) ends its task as a "
            "row with the message in 'refused' instead of failing the sweep (hard cases whose refusal is the result)"
        ),
    )

    def validate(self) -> None:
        from sarproc.cli.main import COMMANDS

        if not self.scenes:
            raise InputError("scenes: at least one scene is needed")
        for name in self.focus:
            if name not in COMMANDS or name in ("simulate", "evaluate", "sweep"):
                raise InputError(f"focus: {name!r} is not a focusing command of sarproc")
        for key, values in self.grid.items():
            if not isinstance(values, list) or not values:
                raise InputError(f"grid.{key}: expected a non-empty list of values")
        if isinstance(self.repeats, bool) or not isinstance(self.repeats, int) or self.repeats < 1:
            raise InputError(f"repeats: expected an integer >= 1, got {self.repeats!r}")
        for i, case in enumerate(self.cases):
            if not case:
                raise InputError(f"cases[{i}]: an empty case")
        for name, entry in self.scenes.items():
            if isinstance(entry, dict):
                unknown = set(entry) - {"file", "targets", "set"}
                if unknown or not isinstance(entry.get("file"), str):
                    raise InputError(
                        f"scenes.{name}: expected a scene YAML path or a mapping with 'file' "
                        f"(and optional 'targets', 'set'), got keys {sorted(entry)}"
                    )
                targets = entry.get("targets")
                if targets is not None and (not isinstance(targets, list) or not targets):
                    raise InputError(f"scenes.{name}.targets: expected a non-empty list of target names")
                if not isinstance(entry.get("set", {}), dict):
                    raise InputError(f"scenes.{name}.set: expected a mapping of dotted keys")
            elif not isinstance(entry, str):
                raise InputError(f"scenes.{name}: expected a scene YAML path, got {entry!r}")


@dataclasses.dataclass(frozen=True)
class SimJob:
    """One raw product, shared by every task whose scene resolves the same."""

    key: str
    scene_yaml: Path
    raw: Path
    config: dict


@dataclasses.dataclass(frozen=True)
class Task:
    task_id: str
    scene: str
    setting: dict  # dotted key -> value (grid point and case)
    config: dict  # the scene mapping with every knob applied
    directory: Path
    focus: tuple[str, ...]
    sim_key: str
    evaluate: bool = True
    repeats: int = 1
    refusals: bool = False


@dataclasses.dataclass(frozen=True)
class Plan:
    source: Path
    output: Path
    knobs: tuple[str, ...]
    sims: tuple[SimJob, ...]
    tasks: tuple[Task, ...]


def digest(obj: object) -> str:
    """sha256 of a JSON-serialisable object (sorted keys, so dict order does not matter)."""
    text = json.dumps(obj, sort_keys=True, default=str, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


def set_dotted(mapping: dict, key: str, value: object, where: str) -> None:
    """mapping['a']['b'] = value for key 'a.b' (intermediate mappings created)."""
    parts = key.split(".")
    node = mapping
    for part in parts[:-1]:
        child = node.setdefault(part, {})
        if not isinstance(child, dict):
            raise InputError(f"{where}: {key!r}: {part!r} is not a mapping in the scene")
        node = child
    node[parts[-1]] = copy.deepcopy(value)


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9.=_+-]+", "_", text).strip("_") or "x"


def _task_id(scene: str, setting: dict) -> str:
    parts = [scene] + [f"{k.rsplit('.', 1)[-1]}={v}" for k, v in setting.items()]
    slug = _slug("__".join(parts))
    # directory names stay well under file-system limits; the hash keeps long ones distinct
    return slug if len(slug) <= 100 else f"{slug[:80]}__{digest(setting)[:12]}"


# command -> (its --config section, its parameter model): checked for every task before anything runs
STAGE_PARAMS = {
    section.replace("_", "-"): (section, target)
    for section, target in SECTION_MODELS.items()
    if section in STAGE_SECTIONS
}


def check_stage_sections(config: dict, commands: Iterable[str], where: str) -> None:
    """Build each stage's parameters from ``config`` (bad knobs fail here, naming the task and key)."""
    import importlib

    for command in commands:
        if command not in STAGE_PARAMS:
            continue  # checked when it runs
        section, target = STAGE_PARAMS[command]
        module, name = target.split(":")
        build(getattr(importlib.import_module(module), name), config.get(section) or {}, where, section)


def plan_sweep(path: str | Path, output: str | Path | None = None) -> Plan:
    """Expand a sweep YAML into simulation jobs and tasks; every scene is validated first."""
    from sarproc.simulation.scene import scene_from_mapping

    path = Path(path)
    raw = load_yaml(path)
    if isinstance(raw.get("focus"), str):
        raw["focus"] = [raw["focus"]]
    params = build(SweepParams, raw, source=str(path))
    base_dir = path.parent
    out = (
        Path(output)
        if output is not None
        else (Path(os.path.normpath(base_dir / params.output)) if params.output else None)
    )
    if out is None:
        raise InputError(f"{path}: no output directory: pass -o DIR or set 'output:' in the sweep file")
    grid_keys = list(params.grid)
    points = [dict(zip(grid_keys, combo)) for combo in itertools.product(*params.grid.values())]
    cases = [dict(c) for c in params.cases] or [{}]
    knobs = tuple(dict.fromkeys(grid_keys + [k for c in cases for k in c]))
    sims: dict[str, SimJob] = {}
    tasks: list[Task] = []
    for scene_name, entry in params.scenes.items():
        entry = entry if isinstance(entry, dict) else {"file": entry}
        scene_file = base_dir / str(entry["file"])
        base = load_yaml(scene_file)
        for key, value in params.set.items():
            set_dotted(base, key, value, f"{path}: set")
        for key, value in (entry.get("set") or {}).items():
            set_dotted(base, key, value, f"{path}: scenes.{scene_name}.set")
        if entry.get("targets") is not None:
            base = _keep_targets(base, entry["targets"], f"{path}: scenes.{scene_name}.targets")
        for case in cases:
            for point in points:
                setting = {**point, **case}
                config = copy.deepcopy(base)
                for key, value in setting.items():
                    set_dotted(config, key, value, f"{path}: grid/cases")
                where = f"{scene_file} with {setting}" if setting else str(scene_file)
                scene = scene_from_mapping(copy.deepcopy(config), source=where)
                check_stage_sections(config, (*params.focus, "evaluate"), where)
                sim_key = digest({"sarproc": __version__, "command": "simulate", "scene": scene.resolved()})
                if sim_key not in sims:
                    stem = f"{_slug(scene_name)}-{sim_key[:10]}"
                    sims[sim_key] = SimJob(sim_key, out / "raw" / f"{stem}.yaml", out / "raw" / f"{stem}.h5", config)
                task_id = _task_id(scene_name, setting)
                tasks.append(
                    Task(
                        task_id,
                        scene_name,
                        setting,
                        config,
                        out / "tasks" / task_id,
                        params.focus,
                        sim_key,
                        params.evaluate,
                        params.repeats,
                        params.refusals,
                    )
                )
    ids = [t.task_id for t in tasks]
    if len(set(ids)) != len(ids):  # knob names that differ only before their last dot, or repeated values
        tasks = [
            dataclasses.replace(t, task_id=f"{i:03d}-{t.task_id}", directory=out / "tasks" / f"{i:03d}-{t.task_id}")
            for i, t in enumerate(tasks)
        ]
    return Plan(path, out, knobs, tuple(sims.values()), tuple(tasks))


def _keep_targets(mapping: dict, names: Sequence[str], where: str) -> dict:
    """The scene with only the named point targets (in the order given; a targets.grid is left out)."""
    points = (mapping.get("targets") or {}).get("points") or []
    by_name = {str(p.get("name")): p for p in points if isinstance(p, dict)}
    missing = [str(n) for n in names if str(n) not in by_name]
    if missing:
        raise InputError(f"{where}: no target named {missing} in the scene (it has {sorted(by_name)})")
    out = copy.deepcopy(mapping)
    out["targets"]["points"] = [copy.deepcopy(by_name[str(n)]) for n in names]
    out["targets"].pop("grid", None)  # its targets are not among the named ones
    return out


# --- running one step ------------------------------------------------------------------------------

_local = threading.local()
_install_lock = threading.Lock()
_installed: list = [0, None]  # active captures, the stream replaced


class _ThreadRoutedStdout(io.TextIOBase):
    """sys.stdout stand-in: text written by a thread that captures goes to its buffer, the rest through.

    Steps run in worker threads (a Dask worker with several threads); swapping sys.stdout per step
    (contextlib.redirect_stdout) would mix their outputs and restore the wrong stream.
    """

    def __init__(self, fallback: TextIO) -> None:
        self._fallback = fallback

    @property
    def encoding(self) -> str:  # type: ignore[override]  # the wrapped stream's, read-only
        return getattr(self._fallback, "encoding", "utf-8")

    def writable(self) -> bool:
        return True

    def write(self, text: str) -> int:
        buf = getattr(_local, "buffer", None)
        return (buf if buf is not None else self._fallback).write(text)

    def flush(self) -> None:
        buf = getattr(_local, "buffer", None)
        if buf is None:
            self._fallback.flush()


@contextlib.contextmanager
def captured_stdout() -> Iterator[io.StringIO]:
    """Collect what this thread prints (click.echo) into a StringIO."""
    with _install_lock:
        if _installed[0] == 0:
            _installed[1] = sys.stdout
            sys.stdout = _ThreadRoutedStdout(sys.stdout)
        _installed[0] += 1
    _local.buffer = buf = io.StringIO()
    try:
        yield buf
    finally:
        _local.buffer = None
        with _install_lock:
            _installed[0] -= 1
            if _installed[0] == 0 and isinstance(sys.stdout, _ThreadRoutedStdout):
                sys.stdout = _installed[1]


def invoke(command: str, args: Sequence[str | Path]) -> str:
    """Run ``sarproc COMMAND ARGS`` in this process; returns what it printed."""
    from sarproc.cli.main import cli

    cmd = cli.get_command(None, command)
    if cmd is None:
        raise InputError(f"sarproc {command}: command not available")
    with captured_stdout() as buf:
        cmd.main(args=[str(a) for a in args], prog_name=f"sarproc {command}", standalone_mode=False)
    return buf.getvalue()


def _record_path(output: Path) -> Path:
    return output.with_name(output.name + ".done.json")


def run_step(command: str, args: Sequence[str | Path], output: Path, key: str) -> dict:
    """Run one stage unless ``output`` exists with a record of the same key; returns the record."""
    from sarproc.product.io import atomic_path

    record_path = _record_path(output)
    if output.exists() and record_path.exists():
        try:
            record = json.loads(record_path.read_text())
        except (OSError, json.JSONDecodeError):
            record = {}
        if record.get("key") == key:
            return {**record, "skipped": True}
    output.parent.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    try:
        printed = invoke(command, args)
    except Exception as exc:  # the step's own error, named with its command
        raise ProcessingError(f"sarproc {command} {' '.join(map(str, args))}: {exc}") from exc
    record = {
        "key": key,
        "command": f"sarproc {command}",
        "seconds": time.perf_counter() - start,
        "summary": printed.strip().splitlines()[-1] if printed.strip() else "",
    }
    with atomic_path(record_path) as tmp:
        tmp.write_text(json.dumps(record, indent=1) + "\n")
    return {**record, "skipped": False}


def _write_yaml_if_changed(path: Path, mapping: dict) -> None:
    import yaml

    from sarproc.product.io import atomic_path

    text = yaml.safe_dump(mapping, sort_keys=False)
    if path.exists() and path.read_text() == text:
        return
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        tmp.write_text(text)


@single_blas  # a worker's BLAS like the serial run's: one thread, the same rounding
def run_simulation(job: SimJob) -> dict:
    """Simulate one raw product (or find it done); returns its record."""
    _write_yaml_if_changed(job.scene_yaml, job.config)
    rec = run_step("simulate", [job.scene_yaml, "-o", job.raw, "--overwrite", "--no-progress"], job.raw, job.key)
    return {**rec, "path": str(job.raw)}


def _without(mapping: dict, section: str) -> dict:
    return {k: v for k, v in mapping.items() if k != section}


@single_blas  # a worker's BLAS like the serial run's: one thread, the same rounding
def run_task(task: Task, sim: dict) -> dict:
    """Focus chain and evaluate of one task (each step skipped when done); returns its table row. With
    ``task.refusals``, a step refusing its input (InputError) gives a row with the message in ``refused``
    (the command in ``refused_by``), no times beyond the simulation's and no quality."""
    try:
        return _run_task(task, sim)
    except ProcessingError as exc:
        cause = exc.__cause__
        if not (task.refusals and isinstance(cause, InputError)):
            raise
        return {
            "task": task.task_id,
            "scene": task.scene,
            **task.setting,
            "simulate_s": sim["seconds"],
            "focus_s": None,
            "evaluate_s": None,
            **dict.fromkeys(QUALITY_COLUMNS),
            "refused": str(cause),
            "refused_by": str(exc).split(" ", 2)[1],  # "sarproc COMMAND args: message"
            "skipped": False,
        }


def _run_task(task: Task, sim: dict) -> dict:
    config_path = task.directory / "config.yaml"
    _write_yaml_if_changed(config_path, task.config)
    source, key = Path(sim["path"]), sim["key"]
    focus_s, skipped, step_s = 0.0, [sim["skipped"]], {}
    for command, key in zip(task.focus, focus_keys(task, sim["key"])):
        out = task.directory / f"{command}.h5"
        rec = run_step(command, [source, "--config", config_path, "-o", out, "--overwrite", "--no-progress"], out, key)
        focus_s += rec["seconds"]
        step_s[command] = rec["seconds"]
        skipped.append(rec["skipped"])
        source = out
    if not task.evaluate:
        return {
            "task": task.task_id,
            "scene": task.scene,
            **task.setting,
            "simulate_s": sim["seconds"],
            "focus_s": focus_s,
            "focus_step_s": step_s,
            "evaluate_s": None,
            **dict.fromkeys(QUALITY_COLUMNS),
            "skipped": all(skipped),
        }
    report = task.directory / "report.json"
    key = digest({"sarproc": __version__, "command": "evaluate", "input": key, "config": task.config.get("evaluate")})
    rec = run_step("evaluate", [source, "--config", config_path, "-o", report, "--overwrite"], report, key)
    skipped.append(rec["skipped"])
    quality = summarise_report(json.loads(report.read_text()))
    return {
        "task": task.task_id,
        "scene": task.scene,
        **task.setting,
        "simulate_s": sim["seconds"],
        "focus_s": focus_s,
        "focus_step_s": step_s,
        "evaluate_s": rec["seconds"],
        **quality,
        "skipped": all(skipped),
    }


def focus_keys(task: Task, sim_key: str) -> list[str]:
    """The record key of each command of the task's focus chain (each chained on the one before)."""
    keys, key = [], sim_key
    for command in task.focus:
        # evaluate's own knobs do not change the image: leave them out of the focusing keys
        key = digest(
            {"sarproc": __version__, "command": command, "input": key, "config": _without(task.config, "evaluate")}
        )
        keys.append(key)
    return keys


def _same_data(a: Path, b: Path) -> bool:
    import numpy as np

    from sarproc.product.io import read_product

    pa, pb = read_product(a, check_finite=False), read_product(b, check_finite=False)
    return pa.data.shape == pb.data.shape and bool(np.array_equal(pa.data, pb.data, equal_nan=True))


@single_blas  # a worker's BLAS like the serial run's: one thread, the same rounding
def run_repeat(task: Task, sim: dict, k: int) -> dict:
    """Repeat ``k`` (1, 2, ...) of the task's focus chain, timed, into ``tasks/<id>/repeat/``; each product
    compared with the first run's (bit for bit) and removed. Returns {"seconds", "identical"}; skipped
    (its record read back) when ``repeat-<k>.done.json`` holds the same key."""
    from sarproc.product.io import atomic_path

    keys = focus_keys(task, sim["key"])
    key = digest({"repeat": k, "focus": keys[-1]})
    record_path = task.directory / f"repeat-{k}.done.json"
    if record_path.exists():
        try:
            record = json.loads(record_path.read_text())
        except (OSError, json.JSONDecodeError):
            record = {}
        if record.get("key") == key:
            return record
    config_path = task.directory / "config.yaml"
    workdir = task.directory / "repeat"
    workdir.mkdir(parents=True, exist_ok=True)
    source, seconds, identical, made, steps = Path(sim["path"]), 0.0, True, [], {}
    try:
        for command in task.focus:
            out = workdir / f"{command}.h5"
            start = time.perf_counter()
            try:
                invoke(command, [source, "--config", config_path, "-o", out, "--overwrite", "--no-progress"])
            except Exception as exc:  # the step's own error, named with its command
                raise ProcessingError(f"repeat {k} of sarproc {command} ({task.task_id}): {exc}") from exc
            steps[command] = time.perf_counter() - start
            seconds += steps[command]
            made.append(out)
            identical = identical and _same_data(out, task.directory / f"{command}.h5")
            source = out
    finally:
        for path in made:
            path.unlink(missing_ok=True)
        with contextlib.suppress(OSError):
            workdir.rmdir()
    record = {"key": key, "repeat": k, "seconds": seconds, "step_seconds": steps, "identical": identical}
    with atomic_path(record_path) as tmp:
        tmp.write_text(json.dumps(record, indent=1) + "\n")
    return record


def with_repeats(row: dict, repeats: list) -> dict:
    """The row with its focus time summarised over the first run and its repeats (best, median, spread)."""
    from sarproc.quality.tradeoff import timing_stats

    if row.get("refused") is not None:  # a refused task: no focus time
        return {**row, "focus_median_s": None, "focus_spread_s": None, "focus_times": [], "repeats_identical": None}
    times = [row["focus_s"]] + [r["seconds"] for r in repeats]
    stats = timing_stats(times)
    out = {
        **row,
        "focus_s": stats["best"],
        "focus_median_s": stats["median"],
        "focus_spread_s": stats["spread"],
        "focus_times": times,
        "repeats_identical": all(r["identical"] for r in repeats) if repeats else None,
    }
    first = row.get("focus_step_s")
    if first and all(set(r.get("step_seconds") or {}) == set(first) for r in repeats):  # older records: none
        out["focus_step_times"] = {c: [first[c]] + [r["step_seconds"][c] for r in repeats] for c in first}
    return out


def summarise_report(report: dict) -> dict:
    """Worst quality over targets and axes of an evaluate report (None where nothing was measured)."""
    from sarproc.quality.summary import worst_quality_json

    worst = worst_quality_json(report).as_dict()
    return {c: worst[c] for c in QUALITY_COLUMNS}


# --- runners ---------------------------------------------------------------------------------------


@dataclasses.dataclass
class Outcome:
    rows: list
    failures: list  # (task id or raw path, message)
    seconds: float


def _order(plan: Plan, rows: list) -> list:
    index = {t.task_id: i for i, t in enumerate(plan.tasks)}
    return sorted(rows, key=lambda r: index[r["task"]])


def run_serial(plan: Plan, on_row: Callable[[dict], object] | None = None) -> Outcome:
    """Every task in this process, one after the other (no Dask needed)."""
    with one_blas_thread():
        return _run_serial(plan, on_row)


def _run_serial(plan: Plan, on_row: Callable[[dict], object] | None = None) -> Outcome:
    start = time.perf_counter()
    sims, rows, failures = {}, [], []
    for job in plan.sims:
        try:
            sims[job.key] = run_simulation(job)
        except (InputError, ProcessingError) as exc:
            failures.append((str(job.raw), str(exc)))
    for task in plan.tasks:
        if task.sim_key not in sims:
            failures.append((task.task_id, "its raw product could not be simulated"))
            continue
        try:
            row = run_task(task, sims[task.sim_key])
        except (InputError, ProcessingError) as exc:
            failures.append((task.task_id, str(exc)))
            continue
        rows.append(row)
        if on_row:
            on_row(row)
    rows = _repeat_rounds(plan, rows, failures, sims, _serial_round)
    return Outcome(_order(plan, rows), failures, time.perf_counter() - start)


def _serial_round(calls: Iterable[tuple[str, tuple]]) -> Iterator[tuple[str, object]]:
    """Run (name, args of run_repeat) pairs in order; yields (name, result or exception)."""
    for name, args in calls:
        try:
            yield name, run_repeat(*args)
        except (InputError, ProcessingError) as exc:
            yield name, exc


def _repeat_rounds(
    plan: Plan, rows: list, failures: list, sims: dict, run_round: Callable[[list], Iterable[tuple[str, object]]]
) -> list:
    """Rounds 1..repeats-1 of every finished task's focus chain, one round after the other (round-robin
    over the tasks); the rows with their timing summaries. A task whose repeat fails is a failure."""
    n = max((t.repeats for t in plan.tasks), default=1)
    if n <= 1:
        return [with_repeats(r, []) for r in rows]
    by_id = {t.task_id: t for t in plan.tasks}
    refused = {r["task"] for r in rows if r.get("refused") is not None}  # nothing to repeat
    done: dict[str, list] = {r["task"]: [] for r in rows if r["task"] not in refused}
    for k in range(1, n):
        calls = [(tid, (by_id[tid], sims[by_id[tid].sim_key], k)) for tid in done]
        for tid, result in run_round(calls):
            if isinstance(result, Exception):
                failures.append((tid, str(result)))
                done.pop(tid, None)
            else:
                done[tid].append(result)
    return [with_repeats(r, done.get(r["task"], [])) for r in rows if r["task"] in done or r["task"] in refused]


def local_client(workers: int, threads_per_worker: int = 1, processes: bool = True) -> Client:
    """A distributed Client on a new LocalCluster (its HTTP server on a free port: several may run at once)."""
    from dask.distributed import Client, LocalCluster

    cluster = LocalCluster(
        n_workers=workers, threads_per_worker=threads_per_worker, processes=processes, dashboard_address=":0"
    )
    return Client(cluster)


def run_dask(plan: Plan, client: Client, on_row: Callable[[dict], object] | None = None) -> Outcome:
    """Submit the simulations and the tasks (each depending on its raw product) to a Dask client."""
    with one_blas_thread():  # this process's BLAS, for threads of a local cluster
        return _run_dask(plan, client, on_row)


def _run_dask(plan: Plan, client: Client, on_row: Callable[[dict], object] | None = None) -> Outcome:
    from dask.distributed import as_completed

    start = time.perf_counter()
    run = uuid.uuid4().hex[:12]  # keys unique to this run: a long-lived scheduler may see the sweep again
    sim_futures = {
        job.key: client.submit(run_simulation, job, key=f"simulate-{job.key[:16]}-{run}", pure=False)
        for job in plan.sims
    }
    task_futures = {
        client.submit(run_task, task, sim_futures[task.sim_key], key=f"task-{task.task_id}-{run}", pure=False): task
        for task in plan.tasks
    }
    rows, failures = [], []
    for future in as_completed(task_futures):
        task = task_futures[future]
        if future.status == "error":
            failures.append((task.task_id, str(future.exception())))
            continue
        row = future.result()
        rows.append(row)
        if on_row:
            on_row(row)

    def dask_round(calls: Iterable[tuple[str, tuple]]) -> Iterator[tuple[str, object]]:
        # the whole round is submitted at once; the next round waits for this one (interleaving)
        futures = {
            client.submit(run_repeat, *args, key=f"repeat-{name}-{args[2]}-{run}", pure=False): name
            for name, args in calls
        }
        for future in as_completed(futures):
            yield futures[future], (future.exception() if future.status == "error" else future.result())

    rows = _repeat_rounds(plan, rows, failures, sim_futures, dask_round)
    return Outcome(_order(plan, rows), failures, time.perf_counter() - start)


# --- table and plot --------------------------------------------------------------------------------


def _cell(v: object) -> str:
    if v is None:
        return "n/a"
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)


def sweep_table(plan: Plan, rows: list) -> str:
    """The sweep's rows as Markdown: scene, knobs, times, worst quality."""
    from sarproc.cli.markdown import markdown_table

    columns = ["scene", *plan.knobs, *TIME_COLUMNS, *QUALITY_COLUMNS]
    if any(row.get("refused") is not None for row in rows):
        columns.append("refused")
    # a knob a task does not set keeps its default: blank
    cells = [[_cell(row.get(c)) if c in row or c not in plan.knobs else "" for c in columns] for row in rows]
    return markdown_table(columns, cells)


def write_results(plan: Plan, outcome: Outcome, runner: str) -> dict[str, Path]:
    """table.json, table.md and plot.png in the sweep's output directory."""
    from sarproc.product.io import atomic_path

    plan.output.mkdir(parents=True, exist_ok=True)
    doc = {
        "sweep": str(plan.source),
        "sarproc": __version__,
        "runner": runner,
        "wall_s": outcome.seconds,
        "knobs": list(plan.knobs),
        "rows": [{k: v for k, v in r.items() if k != "skipped"} for r in outcome.rows],
        "failures": [{"task": t, "error": e} for t, e in outcome.failures],
    }
    paths = {"json": plan.output / "table.json", "md": plan.output / "table.md", "plot": plan.output / "plot.png"}
    with atomic_path(paths["json"]) as tmp:
        tmp.write_text(json.dumps(doc, indent=1) + "\n")
    repeats = max((t.repeats for t in plan.tasks), default=1)
    identical = [r.get("repeats_identical") for r in outcome.rows]
    timing = (
        f"focus_s is the best of {repeats} runs of the focus chain, interleaved (round-robin over the "
        "tasks), focus_median_s their median and focus_spread_s max - min; a setting is faster than "
        "another only when its worst time is below the other's best. The repeats' products were "
        + (
            "identical to the first run's, bit for bit, in every task"
            if all(identical)
            else f"NOT identical to the first run's in {sum(1 for i in identical if i is False)} task(s)"
        )
        + "; quality is the first run's."
        if repeats > 1
        else "focus_s is one run (repeats: 1), so no spread is known."
    )
    head = (
        f"# Sweep {plan.source.name}\n\nTimes are each step's own wall time (s); {timing} Quality is the "
        "worst over targets and axes: |IRW/theory - 1|, PSLR and ISLR (dB), |position error| (cells), "
        "false-target level (dB).\n\n"
    )
    with atomic_path(paths["md"]) as tmp:
        tmp.write_text(head + sweep_table(plan, outcome.rows) + "\n")
    if any(r.get("refused") is None for r in outcome.rows):
        with atomic_path(paths["plot"]) as tmp:
            plot_sweep(tmp, plan, outcome.rows)
    return paths


def plot_sweep(path: Path, plan: Plan, rows: list) -> None:
    """Focus time against worst |IRW / theory - 1| per scene: repeated times as bars, the Pareto front as
    a line, numbered markers with a table of the settings (sarproc.quality.tradeoff_plot)."""
    import tempfile

    from sarproc.quality.tradeoff_plot import plot_tradeoff

    rows = [r for r in rows if r.get("refused") is None]  # a refused task has no time to plot
    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    pngs: list[Path] = []
    with tempfile.TemporaryDirectory() as tmp:
        for scene in scenes:
            sel = [r for r in rows if r["scene"] == scene]
            labels = [
                ", ".join(f"{k.rsplit('.', 1)[-1]}={_cell(r[k])}" for k in plan.knobs if k in r) or r["task"]
                for r in sel
            ]
            times = [r.get("focus_times") or [r["focus_s"]] for r in sel]
            png = Path(tmp) / f"{len(pngs)}.png"
            plot_tradeoff(
                png,
                labels,
                times,
                [r["irw_dev"] for r in sel],
                quality_label="worst |IRW / theory - 1|",
                title=f"sweep {plan.source.name}, scene {scene}",
                log_quality=True,
                floor=1e-4,
            )
            pngs.append(png)
        _stack_pngs(path, pngs)


def _stack_pngs(path: Path, pngs: list) -> None:
    """One PNG of the given PNGs one above the other (a panel per scene)."""
    import matplotlib.image as mpimg
    import numpy as np

    images = [mpimg.imread(p) for p in pngs]
    width = max(im.shape[1] for im in images)
    padded = [np.pad(im, ((0, 0), (0, width - im.shape[1]), (0, 0)), constant_values=1.0) for im in images]
    mpimg.imsave(path, np.concatenate(padded, axis=0), format="png")
