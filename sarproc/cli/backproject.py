"""sarproc backproject RAW.h5 -o IMAGE.h5 [--config FILE.yaml]"""

from __future__ import annotations

import time
from pathlib import Path

import click

from sarproc.cli.options import common_options, input_argument, load_config, summary, want_progress


@click.command()
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
def backproject(input_path: Path, target_names, output: Path, config_path, overwrite: bool, progress):
    """Exact time-domain backprojection of a raw product onto a frame grid (section `backproject:`).

    The default grid covers the targets table, moving targets at their static-equivalent positions
    (where a static-scene image focuses them).
    """
    from sarproc.focus.backprojection import BackprojectParams, backproject as run
    from sarproc.product.io import write_product
    from sarproc.cli.progress import progress_factory
    from sarproc.cli.stage import backproject_estimate, naming, prepare

    params, raw = prepare(
        "backproject",
        input_path,
        [output],
        config_path,
        overwrite,
        ("raw", "raw_multichannel", "raw_array"),
        BackprojectParams,
        "backproject",
        backproject_estimate,
    )
    from sarproc.product.frames import frame_names
    from sarproc.product.errors import InputError

    if params.frame != "product" and params.frame not in frame_names():
        raise InputError(
            f"{config_path}: backproject.frame: {params.frame!r} is not 'product' or one of {frame_names()}"
        )
    start = time.perf_counter()
    with naming(input_path, config_path, "backproject"):
        image = run(
            raw,
            params,
            progress=progress_factory(want_progress(progress), "backproject"),
            grid_targets=None if target_names is None else [n.strip() for n in target_names.split(",") if n.strip()],
        )
    image.history[-1]["command"] = f"sarproc backproject {input_path}"
    write_product(output, image, inputs=[input_path], overwrite=overwrite)
    n_az, n_rg = image.data.shape
    summary(
        f"backproject: {n_az}x{n_rg} image in frame {image.attrs['frame']['name']} -> {output} "
        f"({time.perf_counter() - start:.2f} s)"
    )
