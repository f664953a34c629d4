"""--dry-run prints the plan and writes nothing; each stage's plan is within 2x of what its run measures.

One stage per test, on the smallest shipped config that runs it (the inputs are made in this
process first). The run is a subprocess measured like /usr/bin/time: peak RSS (ru_maxrss) and wall
time, which is what a plan promises. Time on a shared 2-core machine is noisy and only ever
stretched by load, so a stage outside 2x is rerun (best of 3 kept), and the lower bound is also
checked against the run's CPU time (a loaded machine stretches the wall clock of a mostly
single-threaded run, not its CPU time): see ``within`` in sarproc/cli/plan_check.py;
scripts/plan_accuracy.py makes the same table for every shipped config (``make plan-accuracy``, docs/plans.md).
"""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from sarproc.cli.main import cli
from sarproc.cli.plan_check import all_chains, chain, run_stage, within

ROOT = Path(__file__).resolve().parents[2]
CONFIGS = ROOT / "configs"


def sarproc(*args):
    res = CliRunner().invoke(cli, [str(a) for a in args] + ["--overwrite"], catch_exceptions=False)
    assert res.exit_code == 0, res.output
    return res


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    """Every stage's input, made in this process: raw products of five small configs, exp1's
    preprocessed and coarse products, the demo image."""
    d = tmp_path_factory.mktemp("plans")
    for name in ("demo", "an2012_exp1_small", "xu_small", "nie2016_sliding_small", "du2010_wide_swath"):
        sarproc("simulate", CONFIGS / f"{name}.yaml", "-o", d / f"{name}_raw.h5", "--no-progress")
    cfg = CONFIGS / "an2012_exp1_small.yaml"
    sarproc("preprocess", d / "an2012_exp1_small_raw.h5", "--config", cfg, "-o", d / "pre.h5", "--no-progress")
    sarproc("coarse-focus", d / "pre.h5", "--config", cfg, "-o", d / "coarse.h5", "--no-progress")
    sarproc(
        "backproject", d / "demo_raw.h5", "--config", CONFIGS / "demo.yaml", "-o", d / "demo_image.h5", "--no-progress"
    )
    cube = ["--config", CONFIGS / "du2010_wide_swath.yaml", "-o", d / "du2010_cube.h5", "--no-progress"]
    sarproc("array3d", d / "du2010_wide_swath_raw.h5", *cube)
    return d


# stage, input (in the fixture's folder, or a config), config
STAGES = [
    ("simulate", "config:demo", None),
    ("backproject", "demo_raw.h5", "demo"),
    ("evaluate", "demo_image.h5", "demo"),
    ("quicklook", "demo_image.h5", None),
    # a cube's chips and kernels (numba's here: the tests run SARPROC_AOT=0; 362 MB peak RSS, 582 MB planned before)
    ("evaluate", "du2010_cube.h5", "du2010_wide_swath"),
    # a 3D cube's preview holds every voxel (49 MB of complex64: 131 MB peak RSS against 64 MB planned before)
    ("quicklook", "du2010_cube.h5", None),
    ("preprocess", "an2012_exp1_small_raw.h5", "an2012_exp1_small"),
    ("coarse-focus", "pre.h5", "an2012_exp1_small"),
    ("fine-focus", "coarse.h5", "an2012_exp1_small"),
    ("pfa2", "nie2016_sliding_small_raw.h5", "nie2016_sliding_small"),
    ("reconstruct", "xu_small_raw.h5", "xu_small"),
    ("array3d", "du2010_wide_swath_raw.h5", "du2010_wide_swath"),
]


def stage_args(inputs, stage, source, config):
    src = CONFIGS / f"{source[7:]}.yaml" if source.startswith("config:") else inputs / source
    cfg = ["--config", CONFIGS / f"{config}.yaml"] if config else []
    out = inputs / f"out_{stage}{ {'evaluate': '.json', 'quicklook': '.png'}.get(stage, '.h5') }"
    return [stage, src, *cfg, "-o", out]


def in_process(args, extra):
    """The --dry-run in this process (its imports are paid once): (status, stdout, stderr)."""
    res = CliRunner().invoke(cli, [str(a) for a in args] + list(extra))
    return res.exit_code, res.output, ""


@pytest.mark.parametrize("stage,source,config", STAGES, ids=[s[0] + ("-cube" * ("cube" in s[1])) for s in STAGES])
def test_plan_within_2x_of_the_measured_run(inputs, stage, source, config):
    row = run_stage(stage_args(inputs, stage, source, config), repeat=3, accept=within, dry_run=in_process, cwd=ROOT)
    assert "refused" not in row, row
    assert not row["dry_run_wrote"], "--dry-run wrote its output"
    assert within(row), (  # the whole row, so that a failure on CI says which bound and by how much
        f"{config}: plan/rss {row['plan_mem'] / row['rss']:.2f}, plan/wall {row['plan_s'] / row['wall']:.2f}, "
        f"plan/min(wall, cpu) {row['plan_s'] / min(row['wall'], row['cpu']):.2f}; {row}"
    )


def test_dry_run_checks_like_a_run_and_writes_nothing(inputs):
    out = inputs / "dry.h5"
    res = CliRunner().invoke(cli, ["simulate", str(CONFIGS / "demo.yaml"), "-o", str(out), "--dry-run"])
    assert res.exit_code == 0 and not out.exists(), res.output
    assert res.output.startswith("simulate: plan: output ~2.89 MB, peak memory ~") and "run time ~" in res.output
    # the checks of a real run come first: an existing output without --overwrite is refused (exit 2)
    out.write_bytes(b"x")
    res = CliRunner().invoke(cli, ["backproject", str(inputs / "demo_raw.h5"), "-o", str(out), "--dry-run"])
    assert res.exit_code == 2 and "exists" in res.output and out.read_bytes() == b"x"
    # a plan that cannot fit is refused as in a real run
    res = CliRunner().invoke(
        cli,
        ["backproject", str(inputs / "demo_raw.h5"), "-o", str(inputs / "d2.h5"), "--dry-run", "--max-memory", "1M"],
    )
    assert res.exit_code == 2 and "--max-memory" in res.output and not (inputs / "d2.h5").exists()
    # every product-writing command offers it
    for command in (
        "simulate",
        "preprocess",
        "coarse-focus",
        "fine-focus",
        "pfa2",
        "reconstruct",
        "array3d",
        "backproject",
        "evaluate",
        "quicklook",
        "import-gotcha",
        "export-sicd",
        "export-cphd",
        "import-cphd",
    ):
        assert "--dry-run" in CliRunner().invoke(cli, [command, "--help"]).output, command


def test_plan_accuracy_has_a_chain_for_every_shipped_config_and_makes_each_input_before_reading_it(tmp_path):
    """`make plan-accuracy` (scripts/plan_accuracy.py) runs :func:`all_chains` in order: every shipped config
    (evaluate_campaign.yaml, pfa2_plain.yaml and gotcha_two_step.yaml made it stop with a KeyError), each
    stage reading a config that exists and a product an earlier stage wrote (xu_conventional, a variant,
    ran before xu_scene, whose raw product it reads)."""
    gotcha = tmp_path / "gotcha"
    names = all_chains(CONFIGS)
    shipped = {p.stem for p in CONFIGS.glob("*.yaml") if not p.stem.endswith("_expect")}
    assert shipped <= set(names)
    made: set[Path] = set()
    for name in names:
        for args in chain(name, tmp_path, CONFIGS, gotcha):
            if "--config" in args:
                assert Path(args[args.index("--config") + 1]).is_file(), (name, args)
            source = Path(args[1])
            assert source in made or source == gotcha or source.parent == CONFIGS, (name, args)
            made.add(Path(args[args.index("-o") + 1]))
