"""Paper 002 (Nie 2016): sarproc pfa2 RAW.h5 -o IMAGE.h5 [--config FILE.yaml]   # section pfa2:

and sarproc import-gotcha DIR_OR_MAT... -o RAW.h5 (the AFRL Gotcha phase history as a raw product).
"""

from __future__ import annotations

import time
from pathlib import Path

import click

from sarproc.cli.dask_map import scheduler_option
from sarproc.cli.options import SectionCommand, common_options, dry_run_option, input_argument, summary, want_progress


@click.command(cls=SectionCommand, section="pfa2")
@input_argument
@common_options
@scheduler_option
def pfa2(
    input_path: Path,
    output: Path,
    config_path: Path | None,
    overwrite: bool,
    progress: bool | None,
    scheduler: str | None,
) -> None:
    """Polar format with the varied gate, sub-aperture de-aliasing and two-step PFA (section `pfa2:`)."""
    from sarproc.cli.dask_map import dask_mapper, scheduler_client
    from sarproc.cli.progress import progress_factory
    from sarproc.cli.stage import naming, prepare
    from sarproc.focus.budget import pfa2_estimate
    from sarproc.focus.pfa.chain import Pfa2Params, pfa2 as run
    from sarproc.product.io import write_product

    params, raw = prepare(
        "pfa2", input_path, [output], config_path, overwrite, ("raw",), Pfa2Params, "pfa2", pfa2_estimate
    )
    start = time.perf_counter()
    with naming(input_path, config_path, "pfa2"), scheduler_client(scheduler) as client:
        # with --scheduler, the two-step sub-images are Dask tasks (same mosaic as the serial run)
        mapper = dask_mapper(client, "pfa2-subimage") if client is not None else None
        image = run(raw, params, progress=progress_factory(want_progress(progress), "pfa2"), mapper=mapper)
    image.history[-1]["command"] = f"sarproc pfa2 {input_path}"
    write_product(output, image, inputs=[input_path], overwrite=overwrite)
    n_az, n_rg = image.data.shape
    extra = f", {image.attrs['subimages']} sub-images" if "subimages" in image.attrs else ""
    summary(
        f"pfa2: {params.method}{extra}, {n_az}x{n_rg} image in frame ground_los -> {output} "
        f"({time.perf_counter() - start:.2f} s)"
    )


@click.command("import-gotcha")
@click.argument("inputs", nargs=-1, required=True, type=click.Path(path_type=Path))
@click.option(
    "-o", "--output", required=True, type=click.Path(dir_okay=False, path_type=Path), help="Output raw HDF5 product."
)
@click.option("--overwrite", is_flag=True, help="Replace an existing output file.")
@dry_run_option
@click.option(
    "--autofocus/--no-autofocus",
    default=False,
    help="Apply the files' autofocus solution (af.r_correct, af.ph_correct).",
)
def import_gotcha(inputs: tuple[Path, ...], output: Path, overwrite: bool, autofocus: bool) -> None:
    """Convert AFRL Gotcha phase-history .mat files (one pass, consecutive azimuths) into a raw product."""
    from sarproc.cli.stage import plan_outputs
    from sarproc.formats.budget import import_gotcha_estimate
    from sarproc.formats.gotcha import gotcha_files, gotcha_product, read_gotcha
    from sarproc.product.io import write_product

    files = gotcha_files(inputs)  # every file checked before the output is looked at
    plan_outputs(files[0], [output], overwrite, lambda: import_gotcha_estimate("import-gotcha", files), inputs=files)
    raw = gotcha_product(read_gotcha(files, autofocus=autofocus))
    raw.history[-1]["command"] = "sarproc import-gotcha " + " ".join(map(str, inputs))
    write_product(output, raw, inputs=files, overwrite=overwrite)
    n_az, n_rg = raw.data.shape
    summary(f"import-gotcha: {len(files)} file(s), {n_az} pulses x {n_rg} samples -> {output}")
