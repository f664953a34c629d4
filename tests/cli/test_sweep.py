"""sarproc sweep: a grid of tasks on a local Dask cluster gives the serial run's table; killed, it resumes."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time

import pytest
import yaml
from conftest import BASE_SCENE, merge

from sarproc.cli.sweep_output import pick_row, raw_product_of, sweep_rows
from sarproc.cli.sweep_tasks import QUALITY_COLUMNS, TIMING_KEYS, plan_sweep, run_dask, run_serial, write_results
from sarproc.product.errors import InputError

distributed = pytest.importorskip("dask.distributed", reason="sweeps on Dask need sarproc[distributed]")


@pytest.fixture(scope="module")
def sweep_file(tmp_path_factory):
    """Two tiny one-target scenes x 3 upsampling x 2 interpolations = 12 tasks, 2 raw products."""
    tmp_path = tmp_path_factory.mktemp("sweep")
    for name, point in (("one", {"name": "A"}), ("two", {"name": "B", "azimuth": "8 m", "range": "6 m"})):
        mapping = merge(
            BASE_SCENE, {"targets": {"frame": "squint", "points": [point]}, "backproject": {"margin_cells": 8}}
        )
        (tmp_path / f"{name}.yaml").write_text(yaml.safe_dump(mapping))
    sweep = {
        "scenes": {"one": "one.yaml", "two": "two.yaml"},
        "focus": "backproject",
        "grid": {"backproject.upsample": [1, 4, 16]},
        "cases": [{"backproject.interpolation": "nearest"}, {"backproject.interpolation": "linear"}],
        "output": "out",
    }
    path = tmp_path / "sweep.yaml"
    path.write_text(yaml.safe_dump(sweep))
    return path


@pytest.fixture(scope="module")
def serial(sweep_file):
    """The reference: every task in this process, one after the other."""
    outcome = run_serial(plan_sweep(sweep_file, sweep_file.parent / "serial"))
    assert not outcome.failures and len(outcome.rows) == 12
    return outcome


def quality(rows):
    """The table without its measured times (and the run-specific skip flag)."""
    return [{k: v for k, v in r.items() if k not in TIMING_KEYS + ("skipped",)} for r in rows]


def test_plan_shares_raw_products_and_validates(sweep_file):
    plan = plan_sweep(sweep_file)
    assert len(plan.tasks) == 12 and len(plan.sims) == 2
    assert plan.knobs == ("backproject.upsample", "backproject.interpolation")
    assert len({t.directory for t in plan.tasks}) == 12
    bad = sweep_file.parent / "bad.yaml"
    bad.write_text(yaml.safe_dump({"scenes": {"one": "one.yaml"}, "grid": {"radar.prf": "400 Hz"}, "output": "x"}))
    with pytest.raises(InputError, match="grid.radar.prf: expected a non-empty list"):
        plan_sweep(bad)
    bad.write_text(yaml.safe_dump({"scenes": {"one": "one.yaml"}, "grid": {"radar.prf": ["-1 Hz"]}, "output": "x"}))
    with pytest.raises(InputError, match="radar.prf"):
        plan_sweep(bad)
    # a stage knob out of range is refused at planning, before any task runs
    bad.write_text(
        yaml.safe_dump({"scenes": {"one": "one.yaml"}, "grid": {"backproject.upsample": [4, 0]}, "output": "x"})
    )
    with pytest.raises(InputError, match=r"'backproject.upsample': 0}: backproject.upsample: 0 is out of range"):
        plan_sweep(bad)


def test_local_cluster_gives_the_serial_table(sweep_file, serial, tmp_path):
    plan = plan_sweep(sweep_file, tmp_path / "dask")
    with distributed.Client(
        distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False, dashboard_address=":0")
    ) as client:
        assert len(client.scheduler_info()["workers"]) == 2
        on_dask = run_dask(plan, client)
    assert not on_dask.failures
    assert quality(on_dask.rows) == quality(serial.rows)
    # the knobs matter: nearest-neighbour without upsampling is visibly worse than upsample 16, linear
    worst = {(r["scene"], r["backproject.upsample"], r["backproject.interpolation"]): r for r in serial.rows}
    assert worst[("two", 1, "nearest")]["irw_dev"] > 0.1 > 0.03 > worst[("two", 16, "linear")]["irw_dev"]
    assert all(r["skipped"] is False for r in on_dask.rows)
    paths = write_results(plan, on_dask, "test")
    doc = json.loads(paths["json"].read_text())
    assert len(doc["rows"]) == 12 and paths["plot"].stat().st_size > 0
    assert all(c in paths["md"].read_text() for c in QUALITY_COLUMNS)


def test_sweep_output_is_read_back_by_scene_and_setting(sweep_file, serial, tmp_path):
    """What scripts tabulate a sweep with: its rows with their folders, one row by its setting, a scene's raw."""
    plan = plan_sweep(sweep_file, sweep_file.parent / "serial")
    write_results(plan, serial, "serial")
    rows = sweep_rows(plan.output)
    assert [r["task"] for r in rows] == [t.task_id for t in plan.tasks]
    row = pick_row(rows, scene="two", **{"backproject.upsample": 4, "backproject.interpolation": "linear"})
    assert (row["dir"] / "backproject.h5").exists() and (row["dir"] / "report.json").exists()
    raws = {job.key: job.raw for job in plan.sims}
    assert {t.scene: raw_product_of(plan.output, t.scene) for t in plan.tasks} == {
        t.scene: raws[t.sim_key] for t in plan.tasks
    }
    with pytest.raises(InputError, match="expected one sweep row"):
        pick_row(rows, scene="two")
    with pytest.raises(InputError, match="no task of scene 'three'"):
        raw_product_of(plan.output, "three")
    (tmp_path / "table.json").write_text(json.dumps({"rows": [], "failures": [{"task": "x", "error": "boom"}]}))
    with pytest.raises(InputError, match="failed tasks"):
        sweep_rows(tmp_path)


def test_killed_sweep_resumes_and_skips_finished_tasks(sweep_file, serial, tmp_path):
    out = tmp_path / "killed"
    proc = subprocess.Popen(
        [sys.executable, "-m", "sarproc", "sweep", str(sweep_file), "-o", str(out), "--scheduler", "serial"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    deadline = time.monotonic() + 60
    while len(list(out.glob("tasks/*/report.json.done.json"))) < 3 and time.monotonic() < deadline:
        if proc.poll() is not None:
            break
        time.sleep(0.02)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    finished = {p.parent.name for p in out.glob("tasks/*/report.json.done.json")}
    assert 3 <= len(finished) < 12, f"not killed halfway: {len(finished)} done, exit status {proc.returncode}"
    records = {p: p.read_text() for p in out.glob("tasks/*/*.done.json")}
    resumed = run_serial(plan_sweep(sweep_file, out))
    assert not resumed.failures and len(resumed.rows) == 12
    assert {r["task"] for r in resumed.rows if r["skipped"]} >= finished
    assert all(p.read_text() == text for p, text in records.items()), "a finished step was recomputed"
    assert quality(resumed.rows) == quality(serial.rows)
    again = run_serial(plan_sweep(sweep_file, out))
    assert all(r["skipped"] for r in again.rows)


def test_sweep_cli_serial_and_list(sweep_file, tmp_path):
    from click.testing import CliRunner

    from sarproc.cli.main import cli

    res = CliRunner().invoke(cli, ["sweep", str(sweep_file), "--list"])
    assert res.exit_code == 0 and "12 tasks, 2 raw products" in res.output
    import dask

    with dask.config.set({"distributed.comm.timeouts.connect": "1s"}):
        res = CliRunner().invoke(
            cli, ["sweep", str(sweep_file), "--scheduler", "tcp://127.0.0.1:1", "-o", str(tmp_path / "x")]
        )
    assert res.exit_code == 2 and "cannot reach Dask scheduler" in res.output


def test_scene_variants_and_a_sweep_without_evaluate(tmp_path):
    """A scene entry {file, targets, set} is a variant of its file for that scene only; evaluate: false
    leaves the evaluate step out (quality n/a) but still runs the chain."""
    points = [{"name": "A"}, {"name": "B", "azimuth": "8 m", "range": "6 m"}]
    mapping = merge(BASE_SCENE, {"targets": {"frame": "squint", "points": points}, "backproject": {"margin_cells": 8}})
    (tmp_path / "two.yaml").write_text(yaml.safe_dump(mapping))
    sweep = {
        "scenes": {
            "both": "two.yaml",
            "b": {"file": "two.yaml", "targets": ["B"], "set": {"backproject.margin_cells": 4}},
        },
        "focus": "backproject",
        "cases": [{"backproject.upsample": 4}],
        "output": "out",
        "evaluate": False,
    }
    path = tmp_path / "sweep.yaml"
    path.write_text(yaml.safe_dump(sweep))
    plan = plan_sweep(path)
    both, b = sorted(plan.tasks, key=lambda t: t.scene != "both")
    assert both.config["targets"]["points"] == points and both.config["backproject"]["margin_cells"] == 8
    assert b.config["targets"]["points"] == points[1:] and b.config["backproject"]["margin_cells"] == 4
    assert {k: v for k, v in b.config.items() if k not in ("targets", "backproject")} == {
        k: v for k, v in both.config.items() if k not in ("targets", "backproject")
    }
    assert len(plan.sims) == 2 and not b.evaluate
    outcome = run_serial(plan)
    assert not outcome.failures and len(outcome.rows) == 2
    for task, row in zip(plan.tasks, outcome.rows):
        assert (task.directory / "backproject.h5").exists() and not (task.directory / "report.json").exists()
        assert row["evaluate_s"] is None and all(row[c] is None for c in QUALITY_COLUMNS)
    for entry, match in (
        ({"file": "two.yaml", "targets": ["Z"]}, r"no target named \['Z'\]"),
        ({"file": "two.yaml", "target": ["A"]}, "expected a scene YAML path or a mapping"),
        ({"file": "two.yaml", "targets": []}, "non-empty list of target names"),
    ):
        path.write_text(yaml.safe_dump({**sweep, "scenes": {"bad": entry}}))
        with pytest.raises(InputError, match=match):
            plan_sweep(path)


def test_scene_variant_targets_drop_the_scene_grid(tmp_path):
    """targets: [names] keeps only the named targets: a scene's targets.grid used to stay in the variant."""
    points = [{"name": "A"}, {"name": "B", "azimuth": "8 m", "range": "6 m"}]
    grid = {"azimuth_count": 2, "range_count": 2, "azimuth_spacing": "5 m", "range_spacing": "5 m"}
    mapping = merge(BASE_SCENE, {"targets": {"frame": "squint", "points": points, "grid": grid}})
    (tmp_path / "grid.yaml").write_text(yaml.safe_dump(mapping))
    path = tmp_path / "sweep.yaml"
    path.write_text(
        yaml.safe_dump(
            {
                "scenes": {"b": {"file": "grid.yaml", "targets": ["B"]}},
                "focus": "backproject",
                "cases": [{"backproject.upsample": 4}],
                "output": "out",
            }
        )
    )
    (task,) = plan_sweep(path).tasks
    assert task.config["targets"]["points"] == points[1:]
    assert task.config["targets"].get("grid") is None


def test_repeats_time_the_focus_interleaved_and_check_determinism(tmp_path):
    """repeats: 3 runs each task's focus chain 3 times, round-robin over the tasks (every task's first
    run before any second run), records best/median/spread, finds the repeats bit-identical and
    removes their products; rerun, nothing is recomputed."""
    mapping = merge(
        BASE_SCENE, {"targets": {"frame": "squint", "points": [{"name": "A"}]}, "backproject": {"margin_cells": 8}}
    )
    (tmp_path / "one.yaml").write_text(yaml.safe_dump(mapping))
    path = tmp_path / "sweep.yaml"
    path.write_text(
        yaml.safe_dump(
            {
                "scenes": {"one": "one.yaml"},
                "focus": "backproject",
                "output": "out",
                "grid": {"backproject.upsample": [1, 4]},
                "repeats": 3,
            }
        )
    )
    plan = plan_sweep(path)
    outcome = run_serial(plan)
    assert not outcome.failures and len(outcome.rows) == 2
    for task, row in zip(plan.tasks, outcome.rows):
        times = row["focus_times"]
        assert len(times) == 3 and row["repeats_identical"] is True
        assert row["focus_s"] == min(times) and row["focus_spread_s"] == max(times) - min(times)
        assert min(times) <= row["focus_median_s"] <= max(times)
        # each command of the chain keeps its own times over the same runs (a one-command chain: the chain's)
        assert row["focus_step_times"] == {"backproject": times}
        assert not (task.directory / "repeat").exists()
    first_runs = [(t.directory / "backproject.h5").stat().st_mtime_ns for t in plan.tasks]
    rounds = [[(t.directory / f"repeat-{k}.done.json").stat().st_mtime_ns for t in plan.tasks] for k in (1, 2)]
    assert max(first_runs) <= min(rounds[0]) and max(rounds[0]) <= min(rounds[1])
    paths = write_results(plan, outcome, "serial")
    text = paths["md"].read_text()
    assert "best of 3 runs" in text and "identical to the first run's, bit for bit" in text
    assert "focus_spread_s" in text and paths["plot"].stat().st_size > 10_000
    again = run_serial(plan_sweep(path))
    assert all(r["skipped"] for r in again.rows)
    assert [r["focus_times"] for r in again.rows] == [r["focus_times"] for r in outcome.rows]
    path.write_text(yaml.safe_dump({"scenes": {"one": "one.yaml"}, "output": "out", "repeats": 0}))
    with pytest.raises(InputError, match="repeats: expected an integer >= 1"):
        plan_sweep(path)


def test_refusals_make_rows_and_failures_without_them(tmp_path):
    """refusals: true turns a step's InputError (here evaluate.fold_elevation on a 2D image) into a row with
    the message, kept out of the repeats and the plot; without it the same task is a failure."""
    mapping = merge(
        BASE_SCENE, {"targets": {"frame": "squint", "points": [{"name": "A"}]}, "backproject": {"margin_cells": 8}}
    )
    (tmp_path / "one.yaml").write_text(yaml.safe_dump(mapping))
    sweep = {
        "scenes": {"ok": "one.yaml", "bad": {"file": "one.yaml", "set": {"evaluate.fold_elevation": True}}},
        "focus": "backproject",
        "output": "out",
        "repeats": 2,
        "refusals": True,
    }
    path = tmp_path / "sweep.yaml"
    path.write_text(yaml.safe_dump(sweep, sort_keys=False))
    plan = plan_sweep(path)
    outcome = run_serial(plan)
    assert not outcome.failures and [r["scene"] for r in outcome.rows] == ["ok", "bad"]
    ok, bad = outcome.rows
    assert ok.get("refused") is None and len(ok["focus_times"]) == 2 and ok["irw_dev"] is not None
    assert bad["refused_by"] == "evaluate" and "evaluate.fold_elevation needs a 3D cube" in bad["refused"]
    assert bad["focus_s"] is None and bad["focus_times"] == [] and all(bad[c] is None for c in QUALITY_COLUMNS)
    assert not (plan.tasks[1].directory / "repeat-1.done.json").exists()
    paths = write_results(plan, outcome, "serial")
    assert "| refused |" in paths["md"].read_text() and paths["plot"].exists()
    assert json.loads(paths["json"].read_text())["rows"][1]["refused_by"] == "evaluate"
    path.write_text(yaml.safe_dump({**sweep, "refusals": False}, sort_keys=False))
    strict = run_serial(plan_sweep(path, tmp_path / "strict"))
    assert [r["scene"] for r in strict.rows] == ["ok"]
    assert len(strict.failures) == 1 and "fold_elevation" in strict.failures[0][1]
