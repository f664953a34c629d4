"""sarproc array3d RAW.h5 -o CUBE.h5 [--config FILE] [--channel-image N --channel-output IMG.h5] [--channel-overlap]"""

from __future__ import annotations

import time
from pathlib import Path

import click

from sarproc.cli.options import SectionCommand, common_options, info, input_argument, summary, want_progress


@click.command(cls=SectionCommand, section="array3d")
@input_argument
@common_options
@click.option(
    "--channel-image",
    type=int,
    default=None,
    metavar="N",
    help="Also write receiver N's 2D image (1-based) before elevation compression (paper Fig. 5).",
)
@click.option(
    "--channel-output",
    type=click.Path(dir_okay=False, path_type=Path),
    default=None,
    help="Output of --channel-image (an `image` product, dims azimuth, range).",
)
@click.option(
    "--channel-overlap",
    is_flag=True,
    default=False,
    help="Measure, over every receiver's 2D image before elevation compression, the energy of targets sharing "
    "one (azimuth, range) cell over that of lone targets, beside its coherent-sum prediction (paper Fig. 5); "
    "recorded as the cube's attribute channel_overlap.",
)
def array3d(
    input_path: Path,
    output: Path,
    config_path: Path | None,
    overwrite: bool,
    progress: bool | None,
    channel_image: int | None,
    channel_output: Path | None,
    channel_overlap: bool,
) -> None:
    """Linear-array down-looking 3D SAR (paper 004): range, azimuth and elevation-angle compression.

    Reads a raw_array product, writes an image3d cube with dims (elevation, azimuth, range),
    elevation in rad. Parameters: section `array3d:` of --config.
    """
    from sarproc.cli.progress import progress_factory
    from sarproc.cli.stage import naming, prepare
    from sarproc.focus.array3d.linear_array import Array3DParams, array3d_product
    from sarproc.focus.budget import array3d_estimate
    from sarproc.product.errors import InputError
    from sarproc.product.io import write_product

    if (channel_image is None) != (channel_output is None):
        raise InputError("--channel-image and --channel-output go together")
    if channel_output is not None and Path(channel_output).resolve() == Path(output).resolve():
        raise InputError(f"{channel_output}: --channel-output is the same file as --output")
    params, raw = prepare(
        "array3d",
        input_path,
        [output, channel_output],
        config_path,
        overwrite,
        ("raw_array",),
        Array3DParams,
        "array3d",
        array3d_estimate,
    )
    start = time.perf_counter()
    with naming(input_path, config_path, "array3d"):
        cube, chan = array3d_product(
            raw,
            params,
            channel_image=channel_image,
            channel_overlap=channel_overlap,
            progress=progress_factory(want_progress(progress), "array3d"),
            command=f"sarproc array3d {input_path}",
        )
    write_product(output, cube, inputs=[input_path], overwrite=overwrite)
    if chan is not None:
        assert channel_output is not None  # --channel-image comes with --channel-output
        write_product(channel_output, chan, inputs=[input_path], overwrite=overwrite)
    shape = "x".join(map(str, cube.data.shape))
    for g in cube.attrs.get("channel_overlap", {}).get("groups", []):
        info(
            f"array3d: targets {', '.join(g['targets'])} share one 2D cell: energy over the lone targets' "
            f"{g['mean_ratio']:.2f} on average over the receivers (coherent sum {g['mean_predicted']:.2f})"
        )
    summary(
        f"array3d: {shape} (elevation x azimuth x range) cube -> {output}"
        + (f", channel {channel_image} image -> {channel_output}" if chan is not None else "")
        + f" ({time.perf_counter() - start:.2f} s)"
    )
