"""sarproc backproject RAW.h5 -o IMAGE.h5 [--config FILE.yaml]"""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import TYPE_CHECKING

import click

from sarproc.cli.dask_map import scheduler_option
from sarproc.cli.options import SectionCommand, common_options, input_argument, summary, want_progress

if TYPE_CHECKING:
    from collections.abc import Sequence

    from dask.distributed import Client

    from sarproc.focus.backprojection import BackprojectionPlan, BackprojectParams, PulseSet
    from sarproc.product.budget import Plan
    from sarproc.product.io import ProductWriter
    from sarproc.product.model import Product
    from sarproc.product.steps import ProgressFactory


@click.command(cls=SectionCommand, section="backproject")
@input_argument
@click.option(
    "--targets",
    "target_names",
    default=None,
    metavar="NAMES",
    help="Centre and size the default grid on these targets only (comma-separated names; moving ones "
    "where they appear); every target stays in the image's table.",
)
@common_options
@scheduler_option
def backproject(
    input_path: Path,
    target_names: str | None,
    output: Path,
    config_path: Path | None,
    overwrite: bool,
    progress: bool | None,
    scheduler: str | None,
) -> None:
    """Exact time-domain backprojection of a raw product onto a frame grid (section `backproject:`).

    In the 3D frame `elevation` (a raw_array product: a cross-track receiver array) the grid is
    (elevation, azimuth, range), keys elevation_center / _extent / _spacing as angles, and the
    output an image3d cube: the exact time-domain reference for `sarproc array3d`'s cubes.

    The default grid covers the targets table, moving targets at their static-equivalent positions
    (where a static-scene image focuses them). The image is computed and written in blocks of rows
    (`block_pixels`, smaller under --max-memory), so it need not fit in memory; with --scheduler the
    blocks are computed on Dask workers, the image identical to the local one.
    """
    import dataclasses

    import numpy as np

    from sarproc.cli.dask_map import scheduler_client
    from sarproc.cli.options import max_memory
    from sarproc.cli.progress import progress_factory
    from sarproc.cli.stage import naming, prepare
    from sarproc.focus import backprojection as bp
    from sarproc.focus.budget import backproject_block_pixels, backproject_estimate
    from sarproc.product.errors import InputError
    from sarproc.product.frames import frame_names

    names = None if target_names is None else [n.strip() for n in target_names.split(",") if n.strip()]
    grids: list[bp.BackprojectionPlan] = []

    def estimate(stage: str, header: Product, params: bp.BackprojectParams) -> Plan:
        # the run's grid, made once for both: the plan's size (moving targets where they appear, a --targets
        # subset) and ffbp's predicted error are those of the image the run writes
        bp.check_params(params)
        if params.frame != "product" and params.frame not in frame_names():
            raise InputError(
                f"{config_path}: backproject.frame: {params.frame!r} is not 'product' or one of {frame_names()}"
            )
        grids.append(bp.plan_backprojection(header, params, grid_targets=names))
        return backproject_estimate(stage, header, params, max_memory(), grids[0])

    params, raw = prepare(
        "backproject",
        input_path,
        [output],
        config_path,
        overwrite,
        ("raw", "raw_multichannel", "raw_array"),
        bp.BackprojectParams,
        "backproject",
        estimate,
    )
    plan = grids[0]
    params = dataclasses.replace(params, block_pixels=backproject_block_pixels(raw, params, max_memory(), plan))
    start = time.perf_counter()
    with naming(input_path, config_path, "backproject"):
        pulses = bp.pulse_set(raw, params)
        edge_aliases = bp.warn_ambiguities(raw, plan, pulses)
    raw.data = None  # type: ignore[assignment]  # the pulses hold what the blocks need: free the echoes
    header = bp.image_product(raw, plan, params, np.broadcast_to(np.complex64(0), plan.shape), edge_aliases)
    header.history[-1]["command"] = f"sarproc backproject {input_path}"
    blocks = bp.row_blocks(plan.shape, params.block_pixels)
    with (
        naming(input_path, config_path, "backproject"),
        scheduler_client(scheduler) as client,
        _writer(output, header, input_path, overwrite) as writer,
    ):
        _write_blocks(
            writer, pulses, plan, params, blocks, client, progress_factory(want_progress(progress), "backproject")
        )
    parts = f" in {len(blocks)} blocks" if len(blocks) > 1 else ""
    summary(
        f"backproject: {'x'.join(map(str, plan.shape))} ({' x '.join(plan.dims)}) image{parts} in frame "
        f"{_frame_said(params.frame, plan.frame.spec)} -> {output} ({time.perf_counter() - start:.2f} s)"
    )


def _frame_said(asked: str, spec: dict) -> str:
    """The frame as the summary names it: the user's word first where the product's frame is named otherwise
    (``frame: zero_doppler`` is a squint frame at 0 deg; Session 41 new-user trial, docs/cli.md row 1)."""
    name = str(spec["name"])
    if asked in ("product", name):
        return name
    if name == "squint" and "squint" in spec:
        return f"{asked} (a {name} frame at {math.degrees(float(spec['squint'])):g} deg)"
    return f"{asked} (a {name} frame)"


def _writer(output: Path, header: Product, input_path: Path, overwrite: bool) -> ProductWriter:
    """The image's block writer: ``header``'s grid, metadata and history."""
    from sarproc.product.io import ProductWriter

    return ProductWriter.like(output, header, inputs=[input_path], overwrite=overwrite)


def _write_blocks(
    writer: ProductWriter,
    pulses: PulseSet,
    plan: BackprojectionPlan,
    params: BackprojectParams,
    blocks: Sequence[slice],
    client: Client | None,
    progress: ProgressFactory | None,
) -> None:
    """Backproject the row blocks, here or on the Dask ``client``'s workers, and write each as it comes."""
    from sarproc.cli.dask_map import dask_mapper, worker_threads, workers_peak_memory
    from sarproc.cli.options import info
    from sarproc.focus import backprojection as bp
    from sarproc.product.budget import human

    mapper, source, threads = None, pulses, None
    if client is not None:  # the pulses travel to every worker once; each block is a task
        mapper = dask_mapper(client, "backproject-block")
        source = client.scatter(pulses, broadcast=True)
        threads = worker_threads(client)
    for rows, block in bp.backproject_blocks(source, plan, params, blocks, mapper, progress, threads):
        writer.write((rows, slice(None)), block)
    if client is not None:
        peaks = workers_peak_memory(client)
        info(
            f"backproject: {len(blocks)} blocks on {len(peaks)} Dask workers, peak memory per worker "
            + ", ".join(human(v) for v in sorted(peaks.values()))
        )
