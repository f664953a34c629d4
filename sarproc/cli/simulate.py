"""sarproc simulate SCENE.yaml -o RAW.h5"""

from __future__ import annotations

import time
from pathlib import Path

import click

from sarproc.cli.dask_map import scheduler_option
from sarproc.cli.options import (
    SectionCommand,
    dry_run_option,
    max_memory_option,
    output_option,
    overwrite_option,
    progress_option,
    summary,
    want_progress,
)


@click.command(cls=SectionCommand, section="scene")
@click.argument("scene_path", type=click.Path(allow_dash=True, path_type=Path))
@output_option
@overwrite_option
@progress_option
@max_memory_option
@dry_run_option
@scheduler_option
def simulate(scene_path: Path, output: Path, overwrite: bool, progress: bool | None, scheduler: str | None) -> None:
    """Simulate exact-geometry raw echoes of the point targets declared in SCENE_PATH ('-': standard input)."""
    from sarproc.cli.dask_map import dask_mapper, scheduler_client
    from sarproc.cli.progress import progress_factory
    from sarproc.cli.stage import naming, report_plan
    from sarproc.product.io import ProductWriter, WriteBehind, check_output_path
    from sarproc.simulation.budget import simulate_estimate
    from sarproc.simulation.scene import load_scene
    from sarproc.simulation.simulate import illumination_warnings, plan_simulation, simulate_blocks

    start = time.perf_counter()
    scene = load_scene(scene_path)  # the scene is validated before the output is looked at
    check_output_path(output, [scene_path], overwrite)
    with naming(scene_path):
        plan_estimate = simulate_estimate(scene)
    report_plan(plan_estimate, [output], scene_path)
    with naming(scene_path):
        plan = plan_simulation(scene)
        illumination_warnings(scene, plan)
    history = [scene.history_entry(f"sarproc simulate {scene_path}")]
    with (
        ProductWriter(
            output,
            plan.kind,
            plan.dims,
            plan.coords,
            plan.radar,
            plan.targets,
            attrs=plan.attrs,
            aux=plan.aux,
            history=history,
            inputs=[scene_path],
            overwrite=overwrite,
        ) as writer,
        scheduler_client(scheduler) as client,
        WriteBehind(writer) as behind,  # block k is stored while block k + 1 is computed
    ):
        mapper = dask_mapper(client, "simulate-block") if client is not None else None
        for sl, block in simulate_blocks(scene, plan, progress_factory(want_progress(progress), "simulate"), mapper):
            behind.write(
                (slice(None), sl, slice(None)) if plan.kind != "raw" else (sl, slice(None)),
                block if plan.kind != "raw" else block[0],
            )
    shape = "x".join(map(str, plan.shape))
    summary(
        f"simulate: {len(plan.targets)} targets, {plan.kind} {shape} -> {output} ({time.perf_counter() - start:.2f} s)"
    )
