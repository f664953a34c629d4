"""Standard formats through NGA's sarkit (pip install 'sarproc[formats]'):

    sarproc export-sicd IMAGE.h5 -o IMAGE.nitf [--config FILE.yaml]   focused 2D image -> SICD 1.4.0 (or 1.3.0)
    sarproc export-cphd RAW.h5   -o RAW.cphd   [--config FILE.yaml]   raw phase history -> CPHD 1.1.0
    sarproc import-cphd RAW.cphd -o RAW.h5                            FX/TOA-domain CPHD -> raw product
                                                                      (backproject, pfa2)

The absolute time and the Earth placement come from the `geolocation:` section of --config, else the
product's reference (the scene's `reference:` section), else documented defaults (docs/formats.md).
Every export is read back and run through sarkit's consistency checker; errors exit 1.
"""

from __future__ import annotations

import json
from pathlib import Path

import click

from sarproc.cli.options import (
    SectionCommand,
    config_option,
    dry_run_option,
    input_argument,
    load_config,
    output_option,
    overwrite_option,
    summary,
)


def _check_line(name: str, result: dict) -> str:
    warn = f", warnings: {', '.join(result['warnings'])}" if result["warnings"] else ""
    return (
        f"{name} consistency: {'PASS' if result['passed'] else 'FAIL'} ({result['n_passed']} passed, "
        f"{len(result['errors'])} errors, {len(result['warnings'])} warnings, {result['n_skipped']} not "
        f"applicable{warn})"
    )


def _finish(name: str, output: Path, result: dict, report_path: Path | None) -> None:
    from sarproc.product.errors import ProcessingError
    from sarproc.product.io import atomic_path

    if report_path is not None:  # atomic like every output (a device or '-' is written through)
        with atomic_path(report_path) as tmp:
            tmp.write_text(json.dumps(dict(result.items()), indent=1) + "\n")
    if not result["passed"]:
        click.echo(result["report"], err=True)
        raise ProcessingError(f"{output}: sarkit's {name} consistency checks failed: {', '.join(result['errors'])}")


check_option = click.option(
    "--check-report",
    "report_path",
    type=click.Path(dir_okay=False, allow_dash=True, path_type=Path),
    default=None,
    help="Write sarkit's consistency results as JSON.",
)


@click.command("export-sicd", cls=SectionCommand, section="geolocation")
@input_argument
@output_option
@config_option
@overwrite_option
@check_option
@dry_run_option
@click.option(
    "--image-formation",
    type=click.Choice(["auto", "OTHER", "PFA"], case_sensitive=False),
    default="auto",
    show_default=True,
    help="ImageFormAlgo: auto = PFA (Grid RGAZIM and a PFA block) for pfa2 images in "
    "polar-format geometry (method plain), OTHER (Grid PLANE) for every other image; PFA only for pfa2 "
    "images (docs/formats.md).",
)
@click.option(
    "--sicd-version",
    type=click.Choice(["1.4.0", "1.3.0"]),
    default="1.4.0",
    show_default=True,
    help="SICD version written: 1.3.0 for readers that do not know 1.4.0 (the content is the same).",
)
def export_sicd(
    input_path: Path,
    output: Path,
    config_path: Path | None,
    overwrite: bool,
    report_path: Path | None,
    image_formation: str,
    sicd_version: str,
) -> None:
    """Export a focused 2D image product to SICD (NITF), checked by sarkit's SicdConsistency."""
    import numpy as np

    from sarproc.cli.stage import naming, plan_outputs
    from sarproc.formats.budget import export_sicd_estimate
    from sarproc.formats.geolocation import GeolocationParams, placement
    from sarproc.formats.sicd import (
        check_sicd,
        consistency_checker,
        formed_by_pfa,
        image_grid,
        read_sicd,
        sicd_pixels,
        write_sicd,
    )
    from sarproc.product.errors import InputError, ProcessingError
    from sarproc.product.io import atomic_path, read_product

    consistency_checker("SICD")  # the output is checked with it
    # config, input header (and its placement), output location, plan; then the data
    params = load_config(GeolocationParams, config_path, section="geolocation")
    header = read_product(input_path, kinds=("image",), load=False)
    with naming(input_path, config_path, "geolocation"):
        place = placement(header.radar, params)
        image_grid(header, place)  # a plane, orthogonal, uniform grid (no pixels read)
    formation = None if image_formation.lower() == "auto" else image_formation.upper()
    if formation == "PFA" and not formed_by_pfa(header):
        raise InputError(
            f"{input_path}: --image-formation PFA needs an image made by pfa2 (its history and "
            "attribute 'support_rectangle')"
        )
    plan_outputs(input_path, [output], overwrite, lambda: export_sicd_estimate("export-sicd", header, params))
    image = read_product(input_path, kinds=("image",))
    # written, read back and checked before it is published: a failed check leaves no file
    with atomic_path(output, overwrite) as tmp:
        with naming(input_path):
            grid = write_sicd(tmp, image, place, image_formation=formation, version=sicd_version)
        _, pixels = read_sicd(tmp)
        if not np.array_equal(pixels, sicd_pixels(image.data, grid)):
            raise ProcessingError(f"{output}: the pixels read back differ from those written for {input_path}")
        result = check_sicd(tmp)
        _finish("SICD", output, result, report_path)
    summary(
        f"export-sicd: {pixels.shape[0]}x{pixels.shape[1]} SICD {sicd_version} (rows = range"
        f"{', columns = reversed azimuth' if grid.flip_cols else ', columns = azimuth'}; carrier at the SCP "
        f"{grid.carrier[0]:.4g}, {grid.carrier[1]:.4g} cycles/m removed) -> {output}; pixels read back identical"
    )
    summary(_check_line("SICD", result))


@click.command("export-cphd", cls=SectionCommand, section="geolocation")
@input_argument
@output_option
@config_option
@overwrite_option
@check_option
@dry_run_option
def export_cphd(
    input_path: Path, output: Path, config_path: Path | None, overwrite: bool, report_path: Path | None
) -> None:
    """Export a single-channel raw product to CPHD 1.1.0 (FX domain), checked by sarkit's CphdConsistency."""
    from sarproc.cli.stage import naming, plan_outputs
    from sarproc.formats.budget import export_cphd_estimate
    from sarproc.formats.cphd import check_cphd, consistency_checker, write_cphd
    from sarproc.formats.geolocation import GeolocationParams, placement
    from sarproc.product.io import atomic_path, read_product

    consistency_checker("CPHD")  # the output is checked with it
    params = load_config(GeolocationParams, config_path, section="geolocation")
    header = read_product(input_path, kinds=("raw",), load=False)
    with naming(input_path, config_path, "geolocation"):
        place = placement(header.radar, params)
    plan_outputs(input_path, [output], overwrite, lambda: export_cphd_estimate("export-cphd", header, params))
    raw = read_product(input_path, kinds=("raw",))
    with atomic_path(output, overwrite) as tmp:  # published only once the checks pass
        with naming(input_path):
            sizes = write_cphd(tmp, raw, place)
        result = check_cphd(tmp)
        _finish("CPHD", output, result, report_path)
    summary(f"export-cphd: {sizes['vectors']} vectors x {sizes['samples']} FX samples -> {output}")
    summary(_check_line("CPHD", result))


@click.command("import-cphd")
@input_argument
@output_option
@overwrite_option
@dry_run_option
def import_cphd(input_path: Path, output: Path, overwrite: bool) -> None:
    """Import a CPHD file (FX or TOA domain, monostatic) as a raw product (backproject and pfa2 focus it).

    Files from export-cphd come back losslessly; others are read from their standard fields alone
    (FX band, grid and SRP may vary per vector; no targets: give the focusers grid extents). See
    docs/formats.md.
    """
    from sarproc.cli.stage import plan_outputs
    from sarproc.formats.budget import import_cphd_estimate
    from sarproc.formats.cphd import cphd_header, read_cphd, require_sarkit
    from sarproc.product.io import history_entry, write_product

    require_sarkit()
    header = cphd_header(input_path)  # the XML is checked before the output is looked at
    plan_outputs(input_path, [output], overwrite, lambda: import_cphd_estimate("import-cphd", header))
    raw = read_cphd(input_path)
    raw.history.append(history_entry(f"sarproc import-cphd {input_path}", {}))
    write_product(output, raw, inputs=[input_path], overwrite=overwrite)
    n_az, n_rg = raw.data.shape
    summary(f"import-cphd: raw {n_az}x{n_rg} -> {output}")
