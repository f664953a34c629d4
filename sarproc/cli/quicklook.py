"""sarproc quicklook IMAGE.h5 -o PICTURE.png [--dynamic-range DB] [--targets/--no-targets] [--max-pixels N]"""

from __future__ import annotations

import sys
from pathlib import Path

import click

from sarproc.cli.options import dry_run_option, input_argument, overwrite_option, summary

ARTIST_DOC_STUB = "(properties not listed: matplotlib was imported by sarproc quicklook)"


def import_matplotlib_lean() -> None:
    """Import matplotlib's figure and Agg canvas without building its property docstrings.

    matplotlib writes every Artist subclass's ``set`` docstring (and each ``%(X:kwdoc)s`` section) as it
    defines the class, by inspecting every setter's docstring: ~0.2 s of quicklook's ~0.45 s matplotlib
    import, and a one-shot process never reads them. ``matplotlib.artist.kwdoc`` answers a stub only while
    the modules load and is restored after; drawing is unaffected (the PNG is byte-identical). Nothing is
    done once matplotlib.artist is imported (its classes are built already).
    """
    if "matplotlib.artist" in sys.modules:
        return
    import matplotlib.artist as martist

    kwdoc = getattr(martist, "kwdoc", None)
    if not callable(kwdoc):  # another matplotlib: import it as it is
        return
    martist.kwdoc = lambda artist: ARTIST_DOC_STUB
    try:
        import matplotlib.backends.backend_agg
        import matplotlib.figure  # noqa: F401
    finally:
        martist.kwdoc = kwdoc


@click.command()
@input_argument
@click.option(
    "-o", "--output", required=True, type=click.Path(dir_okay=False, path_type=Path), help="Output picture (PNG)."
)
@overwrite_option
@dry_run_option
@click.option(
    "--dynamic-range",
    "dynamic_range_db",
    type=click.FloatRange(min=1.0, max=300.0),
    default=50.0,
    show_default=True,
    help="dB below the image peak drawn as black.",
)
@click.option(
    "--targets/--no-targets",
    "mark_targets",
    default=True,
    show_default=True,
    help="Circle and name the truth targets of the targets table (when it has any).",
)
@click.option(
    "--max-pixels",
    type=click.IntRange(min=16, max=16384),
    default=2048,
    show_default=True,
    help="Largest number of pixels drawn along an axis; longer axes are reduced by taking the "
    "maximum of each block, so a one-pixel target stays visible.",
)
def quicklook(
    input_path: Path, output: Path, overwrite: bool, dynamic_range_db: float, mark_targets: bool, max_pixels: int
) -> None:
    """Picture of any image product, with or without truth targets.

    2D images: magnitude in dB relative to the peak, axes in metres named by the image frame.
    3D cubes: the three maximum projections. Big images are read block by block and reduced
    by block maxima (--max-pixels), so memory stays small. The same drawing as evaluate --plot.
    """
    import numpy as np

    from sarproc.cli.stage import plan_outputs
    from sarproc.product.io import atomic_path, read_magnitude_preview, read_product
    from sarproc.product.model import UNITS, target_names
    from sarproc.quality.budget import quicklook_estimate
    from sarproc.quality.plotting import plot_quicklook

    header = read_product(input_path, kinds=("image", "image3d"), load=False)
    plan_outputs(input_path, [output], overwrite, lambda: quicklook_estimate("quicklook", header, max_pixels))
    magnitude, dims, coords, factors = read_magnitude_preview(input_path, max_side=max_pixels, header=header)
    truth, names = None, []
    if mark_targets and len(header.targets):
        from sarproc.quality.moving import apparent_truth

        table = apparent_truth(header, str(input_path))  # moving targets where the image focuses them
        truth = np.stack([table[d].astype(float) for d in dims], axis=1)
        names = target_names(table)
    frame = header.attrs.get("frame", {}).get("name", "")
    reduced = "" if all(f == 1 for f in factors) else ", block max " + " x ".join(str(f) for f in factors)
    title = f"{input_path.name}: {header.kind}, {dynamic_range_db:g} dB{reduced}"
    import_matplotlib_lean()
    with atomic_path(output, overwrite=overwrite) as tmp:
        plot_quicklook(
            tmp,
            magnitude,
            dims,
            coords,
            truth,
            names,
            {d: UNITS.get(d, "") for d in dims},
            dynamic_range_db=dynamic_range_db,
            title=title,
            frame=frame,
        )
    summary(f"quicklook: wrote {output} ({' x '.join(str(n) for n in magnitude.shape)} pixels drawn)")
