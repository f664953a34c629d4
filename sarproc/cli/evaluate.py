"""sarproc evaluate IMAGE.h5 [-o report.json] [--plot DIR] [--expect FILE.yaml] [--config FILE.yaml]"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import math
from pathlib import Path
from typing import TYPE_CHECKING

import click

from sarproc.cli.markdown import markdown_table
from sarproc.cli.options import (
    SectionCommand,
    config_option,
    dry_run,
    dry_run_option,
    input_argument,
    load_config,
    max_memory_option,
    progress_option,
    stdout_taken,
    summary,
    verbosity,
    want_progress,
)

if TYPE_CHECKING:
    from collections.abc import Mapping, Sequence

    from sarproc.product.model import Product
    from sarproc.quality.metrics import AxisMetrics, CheckFailure, EvaluateParams, FalseTarget, QualityReport
    from sarproc.quality.moving import MoverReport
    from sarproc.quality.residual import FalseTargetList, Misfit, ResidualFloor


def _fmt(x: float | None, spec: str) -> str:
    if x is None or not math.isfinite(x):
        return "n/a"
    if spec.endswith("f"):
        x = round(x, int(spec[1:-1])) + 0.0  # no "-0.0000"
    return format(x, spec)


def _direction(m: AxisMetrics, dims: Sequence[str]) -> str:
    """The cut as 'axis' or 'axis -0.50 range' (axis-unit components per unit along its own axis)."""
    others = [f"{c:+.3f} {d}" for c, d in zip(m.direction, dims) if d != m.axis and abs(c) >= 5e-4]
    return " ".join([m.axis] + others) + (f" ({m.angle_deg:.1f} deg)" if others else "")


def _theory(value: float | None, m: AxisMetrics) -> str:
    """' (theory)' after a PSLR / ISLR when the target has its own."""
    if value is None or m.theory != "target":
        return ""
    from sarproc.product.theory import NO_SIDE_LOBES_DB

    return " (none)" if value <= NO_SIDE_LOBES_DB else f" ({value:.2f})"  # a response without side lobes


METRIC_COLUMNS = (
    "target",
    "axis",
    "cut direction",
    "IRW",
    "IRW/theory",
    "PSLR (dB)",
    "ISLR (dB)",
    "position error",
    "error (cells)",
    "window",
    "axis cut: IRW/theory",
    "axis cut: PSLR",
    "axis cut: ISLR",
)


def metrics_table(report: QualityReport, units: dict) -> str:
    """Metric table (one row per target and principal cut, image-axis cuts as extra columns) and the
    false-target line, as Markdown."""
    rows = []
    for t in report.targets:
        image_axes = t.image_axes or t.axes
        for m, i in zip(t.axes, image_axes):
            u = units.get(m.axis, "")
            window = "truncated" if m.truncated else "full"
            if t.neighbours_removed:
                window += f", minus {'+'.join(t.neighbours_removed)}"
            if m.contaminated_db is not None:
                window += f", contaminated ({m.contaminated_db:.1f} dB)"
            if m.shortened_nulls is not None:
                theory = "" if m.shortened_islr_theory_db is None else f" (sinc {m.shortened_islr_theory_db:.2f})"
                window += (
                    f", shortened to +-{m.shortened_nulls:g} nulls: PSLR {_fmt(m.shortened_pslr_db, '.2f')}, "
                    f"ISLR {_fmt(m.shortened_islr_db, '.2f')}{theory}"
                )
            rows.append(
                (
                    t.name,
                    m.axis,
                    _direction(m, report.dims),
                    f"{_fmt(m.irw, '.4g')} {u}",
                    f"{_fmt(m.irw_ratio, '.4f')}{' (own)' if m.theory == 'target' else ''}",
                    f"{_fmt(m.pslr_db, '.2f')}{_theory(m.pslr_theory_db, m)}",
                    f"{_fmt(m.islr_db, '.2f')}{_theory(m.islr_theory_db, m)}",
                    f"{_fmt(m.position_error, '.3g')} {u}",
                    _fmt(m.position_error_cells, ".4f"),
                    window,
                    _fmt(i.irw_ratio, ".4f"),
                    _fmt(i.pslr_db, ".2f"),
                    _fmt(i.islr_db, ".2f"),
                )
            )
    lines = [markdown_table(METRIC_COLUMNS, rows, "lllrrrrrrlrrr")]
    lines.append(
        "\nCuts along each response's principal axes (side-lobe ridges, from the chip's spectral support); "
        "'truncated': the ISLR window reaches the image edge (unverified); 'minus X': the fitted ideal "
        "response of target X was subtracted first; 'contaminated': neighbours that ideal responses do not fit "
        "(fit residual above -30 dB) still put that much energy, relative to the main lobe, in the window "
        "(unverified); 'shortened': the contaminated cut measured again on a window ending half-way to "
        "that neighbour (PSLR, ISLR over it, and an ideal sinc's ISLR over the same window; unverified); "
        "'(own)': the theory is the target's own from the targets table (irw_, null_, pslr_, islr_<axis>: "
        "its illumination and weighting), not the image's; PSLR and ISLR show it in parentheses."
    )
    noted = [t for t in report.targets if t.notes]
    if noted:
        lines.append("\nNotes from the focusing stage and evaluate (what the figures above describe):")
        lines += [f"- {t.name}: {'; '.join(t.notes)}." for t in noted]
    if report.movers:
        lines.append(movers_table(report.movers))
    lines += false_target_lines(report, units)
    return "\n".join(lines)


MOVER_COLUMNS = (
    "target",
    "v_r true (m/s)",
    "v_a true (m/s)",
    "measured at (azimuth, range)",
    "shift from truth (m)",
    "estimate",
    "v_r est.",
    "v_a est.",
    "v_r error",
    "v_a error",
    "relocation error (m)",
    "implied by velocity error (m)",
)


def movers_table(movers: Sequence[MoverReport]) -> str:
    """Moving truth targets: where they were measured, velocity errors, relocation, as Markdown."""

    def f(x: float | None, spec: str = ".3f") -> str:
        return "n/a" if x is None else _fmt(x, spec)

    lines = [
        "\nMoving targets: measured at their static-equivalent position (where a static-scene image focuses "
        "them, from the truth velocity and the geometry); relocated = the measured peak taken back to azimuth "
        "time 0 with the estimated velocity (or the moving_targets table's relocated position).\n",
    ]
    rows = [
        (
            m.name,
            f"{m.v_r:.3f}",
            f"{m.v_a:.3f}",
            ", ".join(f"{v:.2f}" for v in m.apparent_coords.values()),
            f"{m.shift:.1f}",
            str(m.estimate),
            f(m.v_r_estimated),
            f(m.v_a_estimated),
            f(m.v_r_error),
            f(m.v_a_error),
            f(m.relocation_error, ".2f"),
            f(m.relocation_error_from_velocity, ".2f"),
        )
        for m in movers
    ]
    lines.append(markdown_table(MOVER_COLUMNS, rows, "lrrlrlrrrrrr"))
    if any(m.estimate == "none" for m in movers):
        lines.append(
            "\n'none': the product holds no velocity estimate for this target (no moving_targets table row "
            "and no reconstruct window matched it), so it is not relocated."
        )
    return "\n".join(lines)


def false_target_lines(report: QualityReport, units: dict) -> list[str]:
    """The false-target figures: on the residual image (every target's fitted response subtracted) with the
    residual's floor, and outside the +-guard_cells windows of the image itself."""

    def where(ft: FalseTarget) -> str:
        return _position(ft.position, units)

    guard = report.false_target_guard if report.residual is not None else report.false_target
    out = []
    if report.residual is not None:
        ft, fl = report.false_target, report.residual
        out.append(
            f"\nFalse target: {_residual_false_target(ft, report, units)} (on the residual: every target's fitted "
            f"response subtracted, main lobes of +-{fl.exclusion_cells:g} cells excluded); residual floor in the "
            f"targets' guard windows {_fmt(fl.floor_db, '.2f')} dB, residual RMS {_fmt(fl.rms_db, '.2f')} dB"
        )
    if report.false_targets is not None:
        out += false_target_list_lines(report.false_targets, units)
    if report.residual is not None and report.residual.misfit_targets:
        out.append(_misfit_line(report.residual, units))
    if report.residual_note:
        out.append(f"\nResidual: {report.residual_note}.")
    label = "False target (guard window)" if report.residual is not None else "False target"
    if guard is None:
        out.append(
            f"\n{label}: none (no pixel lies outside the target neighbourhoods of "
            f"+-{report.params.guard_cells:g} cells)"
        )
    else:
        out.append(
            f"\n{label}: {_fmt(guard.level_db, '.2f')} dB relative to target {guard.reference_target}, "
            f"at {where(guard)}"
        )
    if report.false_target_predicted is not None:
        p = report.false_target_predicted
        out.append(f"\nFalse target predicted: {_fmt(p['level_db'], '.2f')} dB ({p['source']})")
    return out


def _position(position: dict, units: dict) -> str:
    """'azimuth = -421.48 m, range = 600241.76 m': 7 significant digits, so a place 600 km out is told to 0.1 m
    (4 of them gave "range = 6.002e+05 m", which the session 42 trial read as a target's own place)."""
    return ", ".join(f"{d} = {v:.7g} {units.get(d, '')}".rstrip() for d, v in position.items())


def _residual_false_target(ft: FalseTarget | None, report: QualityReport, units: dict) -> str:
    """The residual's false target as it is: a ghost (on the list), or, where the list holds none, the
    strongest residual outside the main lobes said to be the floor or the residue of its nearest target's
    model, with that target and how far (session 42 trial row 7c: a mover's own residue 2.8 cells out along
    its range ridge read as a false target)."""
    if ft is None:
        return "none (no pixel outside the main lobes)"
    level = f"{_fmt(ft.level_db, '.2f')} dB relative to the peak of {ft.reference_target} (the strongest target)"
    near = (
        ""
        if ft.nearest_target is None
        else f", {_fmt(ft.nearest_cells, '.1f')} cells from the peak of {ft.nearest_target}"
    )
    if ft.ghost is not False:
        return f"{level}, at {_position(ft.position, units)}{near}"
    listed = report.false_targets
    margin = f"{listed.margin_db:g}" if listed is not None else "?"
    inside = ft.nearest_cells is not None and ft.nearest_cells <= report.params.guard_cells
    what = (
        f"does not stand over what {ft.nearest_target}'s model leaves about it: {ft.nearest_target}'s own residue "
        "(its response where the ideal one does not fit it: its defocus, or energy the processing left beside "
        "it), or a ghost no stronger than that residue"
        if inside
        else "is the residual's floor, or a ghost no stronger than it"
    )
    return (
        f"none over the residual floor + {margin} dB that is no target's residue (the list below); the strongest "
        f"residual outside the main lobes, {level}, at {_position(ft.position, units)}{near}, {what}"
    )


def _misfit_line(residual: ResidualFloor, units: dict) -> str:
    """Which targets' models do not fit them, and, per target, how much of its own peak its model leaves and
    where: energy an ideal response does not have there (IRW and PSLR, taken on the main and first side lobes,
    need not show it)."""
    from sarproc.quality.residual import MISFIT_DB

    def offset(m: Misfit) -> str:
        parts = [
            f"{abs(v):.3g} {units.get(d, '')}".rstrip() + f" ({abs(m.samples[d])} samples) in {d}"
            for d, v in m.offset.items()
            if m.samples[d] != 0
        ]
        return " and ".join(parts) or "on its peak"

    each = "; ".join(f"{m.name}: {m.level_db:.1f} dB of its own peak {offset(m)} from it" for m in residual.misfits)
    return (
        f"\nResidual: the models of {', '.join(residual.misfit_targets)} do not fit their responses: each leaves "
        f"over {MISFIT_DB:g} dB of its own peak inside the box it was fitted on"
        + (f" ({each})" if each else "")
        + ", energy an ideal response does not have there (IRW and PSLR, measured on the main and first side "
        "lobes, need not show it): defocus, or energy the processing put beside it; or the notes say why. "
        "Those boxes are left out of the false-target search."
    )


FALSE_TARGET_COLUMNS = ("#", "level (dB)", "position", "image samples", "nearest target", "distance (cells)")


def false_target_list_lines(listed: FalseTargetList, units: dict) -> list[str]:
    """Every false target over the residual's floor (the first is the figure above unless that is a ridge's
    residue), as Markdown."""
    head = (
        f"\nFalse targets on the residual over its floor + {listed.margin_db:g} dB "
        f"({_fmt(listed.threshold_db, '.2f')} dB), strongest first, at most {listed.cap}:"
    )
    ridges = (
        f"\n{listed.on_ridges} more over the threshold along targets' ridges, not listed: links of a chain of like "
        "maxima there, the residue of that target's model, not ghosts."
        if listed.on_ridges
        else ""
    ) + (
        f"\n{listed.in_misfits} more over the threshold inside targets' fit boxes, not listed: not 3 dB over what "
        "that target's model leaves on its own main lobe, the skirt of its misfit, not ghosts."
        if listed.in_misfits
        else ""
    )
    if not listed.entries:
        return [f"{head} none.{ridges}"]
    rows = [
        (
            str(n),
            _fmt(e.level_db, ".2f"),
            _position(e.position, units),
            ", ".join(f"{v:.2f}" for v in e.index.values()),
            e.nearest_target,
            _fmt(e.nearest_cells, ".1f"),
        )
        for n, e in enumerate(listed.entries, 1)
    ]
    out = [head + "\n", markdown_table(FALSE_TARGET_COLUMNS, rows, "rrlllr")]
    if listed.beyond:
        out.append(f"\n{listed.beyond} more over the threshold, not listed.")
    if ridges:
        out.append(ridges)
    return out


def _write_text_atomic(path: Path, text: str, overwrite: bool = True) -> None:
    from sarproc.product.io import atomic_path

    with atomic_path(path, overwrite=overwrite) as tmp:
        tmp.write_text(text, encoding="utf-8")


@click.command(cls=SectionCommand, section=("evaluate", "expect"))
@input_argument
@click.option(
    "-o",
    "--output",
    type=click.Path(dir_okay=False, allow_dash=True, path_type=Path),
    default=None,
    help="Write the report as JSON (never the input; an existing file needs --overwrite; '-': standard "
    "output, the table then goes to stderr).",
)
@click.option("--overwrite", is_flag=True, help="Replace an existing -o report.")
@click.option(
    "--plot",
    "plot_dir",
    type=click.Path(file_okay=False, path_type=Path),
    default=None,
    help="Directory for quicklook.png and target_<name>.png (created if missing).",
)
@click.option(
    "--expect",
    "expect_path",
    type=click.Path(dir_okay=False, path_type=Path),
    default=None,
    help="YAML tolerances; exit 1 if any check fails.",
)
@click.option(
    "--targets",
    "target_names",
    default=None,
    metavar="NAMES",
    help=(
        "Report only these targets (comma-separated names); the others in the image are still subtracted as "
        "neighbours and stay out of the false-target search."
    ),
)
@click.option(
    "--reference",
    "reference_path",
    type=click.Path(dir_okay=False, path_type=Path),
    default=None,
    help="An image without truth only: another image of the same pixels (e.g. backprojection's) to compare with "
    "(NCC of the magnitudes, each bright point's offset from the reference's peak).",
)
@click.option(
    "--points",
    type=click.IntRange(min=1),
    default=10,
    show_default=True,
    help="An image without truth only: how many of its brightest points to locate.",
)
@click.option(
    "--workers",
    type=click.IntRange(min=1),
    default=None,
    help="Threads for the targets' and fit groups' independent work (default: every core); any number gives "
    "the same report, bit for bit.",
)
@config_option
@progress_option
@max_memory_option
@dry_run_option
def evaluate(
    input_path: Path,
    output: Path,
    overwrite: bool,
    plot_dir: Path | None,
    expect_path: Path | None,
    target_names: str | None,
    reference_path: Path | None,
    points: int,
    workers: int | None,
    config_path: Path | None,
    progress: bool | None,
) -> None:
    """Point-target metrics of an image: IRW, PSLR, ISLR, position error and false-target level.

    Cuts run along each response's principal axes (its side-lobe ridges, found from the chip's
    spectral support); the image-axis cuts are extra columns. A moving truth target is measured at
    its static-equivalent position (where a static-scene image focuses it, from its velocity and
    the geometry) and reported with its velocity and relocation errors. Neighbours inside a chip are fitted
    as ideal responses and subtracted; a cut reaching the image edge is 'truncated', one left with
    poorly fitted neighbour energy 'contaminated': --expect counts both as unverified (fail).
    Parameters come from the `evaluate:` section of --config (search_cells, guard_cells,
    upsample, islr_nulls, margin_nulls, irw_factor, principal_axes, remove_neighbours, exact; the
    residual false-target search, on by default for 2D images: residual, residual_orders, fit_nulls,
    fit_ridge_nulls, exclusion_cells). The JSON report (-o) also gives each target's tolerance_score: its
    cuts' worst deviation from their theory over the tolerances |IRW/theory - 1| 5 %, PSLR and ISLR 0.5 dB,
    position 0.5 cell (<= 1: within them; null when a figure was not measured). An image without truth (an
    empty targets table: real data) gets the truth-free measures instead: its entropy and brightest points
    (sub-pixel peaks), and with --reference the NCC of the magnitudes and each point's offset from the
    reference's peak. Prints a Markdown table; exit status 1 when --expect tolerances fail, 2 on bad input.
    """
    from sarproc.cli.progress import progress_factory
    from sarproc.cli.stage import naming, report_plan, unapplied_scene_section
    from sarproc.product.config import load_yaml
    from sarproc.product.errors import InputError
    from sarproc.product.io import check_output_path, read_product
    from sarproc.product.model import UNITS
    from sarproc.product.run import mark_published
    from sarproc.quality import threads
    from sarproc.quality.budget import evaluate_estimate
    from sarproc.quality.metrics import EvaluateParams, check_report, evaluate_product, expectations_from_mapping
    from sarproc.quality.summary import tolerance_score

    # Every argument is checked before the (possibly long) evaluation: config, tolerances, the
    # image's layout, then the outputs.
    params = load_config(EvaluateParams, config_path, section="evaluate")
    names = _target_names(target_names)
    expect = expectations_from_mapping(load_yaml(expect_path), str(expect_path)) if expect_path else None
    header = read_product(input_path, kinds=("image", "image3d"), load=False)
    if header.kind == "image" and header.targets is not None and len(header.targets) == 0:
        if expect_path is not None or plot_dir is not None or names is not None:
            raise InputError(f"{input_path}: no targets table: --expect, --plot and --targets need one")
        _truth_free(input_path, reference_path, points, output, overwrite)
        return
    if reference_path is not None:
        raise InputError(f"--reference: for an image without truth; {input_path} has a targets table")
    if config_path is None:
        unapplied_scene_section(header, EvaluateParams, "evaluate", input_path)
    if output is not None:
        check_output_path(output, [input_path], overwrite=overwrite)
    if plot_dir is not None:
        _check_plot_dir(plot_dir, input_path)
    with naming(input_path, config_path, "evaluate"):
        plan = evaluate_estimate("evaluate", header, params)
    report_plan(plan, [output], input_path)

    product = read_product(input_path, kinds=("image", "image3d"))
    with naming(input_path, config_path, "evaluate"), threads.workers(workers):
        report = evaluate_product(
            product,
            params,
            source=str(input_path),
            progress=progress_factory(want_progress(progress), "evaluate"),
            names=names,
        )
    from sarproc.focus.multichannel.channels import ghost_predictions

    report = ghost_predictions(product, report)  # the first-order ghost levels of a multichannel truth
    all_names = [n.decode() if isinstance(n, bytes) else str(n) for n in product.targets["name"]]
    failures = check_report(report, expect, source=str(expect_path), all_names=all_names) if expect else []
    units = {d: UNITS.get(d, "") for d in product.dims}
    aliases, alias_lines = _aliases(product, report)

    # Files first, the table last: a full disk fails before anything is printed.
    if output is not None:
        doc = {"input": str(input_path), "units": units, **report.to_dict()}
        doc["targets"] = [
            {**d, "tolerance_score": _finite(tolerance_score(t))} for d, t in zip(doc["targets"], report.targets)
        ]
        if aliases:
            doc["aliases"] = aliases
        if expect is not None:
            doc["expect"] = _expect_doc(expect_path, failures)
        _write_text_atomic(output, json.dumps(doc, indent=2, allow_nan=False) + "\n", overwrite)
    if plot_dir is not None:
        from sarproc.quality.moving import apparent_truth

        product.targets = apparent_truth(product, str(input_path))  # drawn where they were measured
        _plots(plot_dir, product, report, units, params)
        mark_published(plot_dir)
    if verbosity() >= 0:
        click.echo(metrics_table(report, units) + "".join(alias_lines), err=stdout_taken())
    if expect is not None:
        _verdict(failures, expect_path)


def _truth_free(
    input_path: Path, reference_path: Path | None, points: int, output: Path | None, overwrite: bool
) -> None:
    """evaluate on an image without truth: sarproc.quality.image_measures.measure_image, printed and written."""
    import numpy as np

    from sarproc.product.errors import InputError
    from sarproc.product.io import check_output_path, read_product
    from sarproc.quality.image_measures import measure_image

    if output is not None:
        check_output_path(output, [input_path] + ([reference_path] if reference_path else []), overwrite=overwrite)
    if dry_run():
        click.echo(f"{input_path}: no truth; the truth-free measures would be taken (nothing computed or written)")
        return
    image = read_product(input_path, kinds=("image",))
    ref = None if reference_path is None else read_product(reference_path, kinds=("image",))
    if ref is not None and (ref.data.shape != image.data.shape or ref.dims != image.dims):
        raise InputError(f"--reference: {reference_path} {ref.data.shape} is not on the pixels of {input_path}")
    found = measure_image(image.data, None if ref is None else ref.data, n=points)
    spacing = {d: float(image.coords[d][1] - image.coords[d][0]) for d in image.dims}
    same_grid = None if ref is None else all(np.allclose(image.coords[d], ref.coords[d]) for d in image.dims)
    doc = {
        "input": str(input_path),
        "reference": None if reference_path is None else str(reference_path),
        "dims": list(image.dims),
        "spacing": spacing,
        "same_grid": same_grid,
        **found.to_dict(),
    }
    if output is not None:
        _write_text_atomic(output, json.dumps(doc, indent=2) + "\n", overwrite)
    if verbosity() >= 0:
        click.echo(truth_free_table(doc), err=stdout_taken())


def truth_free_table(doc: dict) -> str:
    """The truth-free measures as Markdown (see :func:`_truth_free`)."""
    pixels = " x ".join(f"{s:.3f}" for s in doc["spacing"].values())
    head = (
        f"No truth: {' x '.join(map(str, doc['shape']))} pixels of {pixels} ({', '.join(doc['dims'])}); entropy "
        f"{doc['entropy']:.4f} nats."
    )
    if doc["reference"] is not None:
        head += (
            f" Against {doc['reference']} (same grid: {doc['same_grid']}; its entropy "
            f"{doc['reference_entropy']:.4f} nats): NCC of the magnitudes {doc['ncc']:.4f}; offsets image - reference."
        )
    with_ref = doc["reference"] is not None
    columns = ["pixel", "sub-pixel peak", "level (dB)"] + (["offset (px)"] if with_ref else [])
    rows = [
        [str(tuple(p["pixel"])), ", ".join(f"{v:.3f}" for v in p["peak"]), f"{p['level_db']:.1f}"]
        + ([", ".join(f"{v:+.3f}" for v in p["offset"])] if with_ref else [])
        for p in doc["points"]
    ]
    return head + "\n\n" + markdown_table(columns, rows, "lrr" + "r" * with_ref)


def _finite(x: float) -> float | None:
    """A figure for the JSON report: NaN (unmeasured) as null."""
    return x if math.isfinite(x) else None


def _aliases(product: Product, report: QualityReport) -> tuple[list[dict], list[str]]:
    """The targets' PRF aliases in the image or putting their side lobes into it from beyond its azimuth edge
    (:func:`sarproc.focus.backprojection_alias.image_edge_aliases`, as fine-focus warns of them), each with the
    listed false target standing where it lands (1-based, null for none): for the JSON report, and as notes."""
    if product.kind != "image" or product.data.ndim != 2:
        return [], []
    from sarproc.focus.backprojection_alias import image_edge_aliases, listed_at_aliases

    found = image_edge_aliases(product)
    if not found:
        return [], []
    entries = report.false_targets.entries if report.false_targets is not None else ()
    at = listed_at_aliases(found, product, [e.index for e in entries])
    guard = report.false_target_guard if report.residual is not None else report.false_target
    at_guard = listed_at_aliases(found, product, [_sample_index(product, guard.position)] if guard else [])
    doc = [
        dataclasses.asdict(a) | {"false_target": k + 1 if k >= 0 else None, "guard_window_figure": g >= 0}
        for a, k, g in zip(found, at, at_guard)
    ]
    lines = [
        "\n\nTarget aliases the PRF folds into the image or next to its azimuth edge (the data cannot tell them "
        "from their targets; not scatterers), measured in the image against their target:"
    ]
    for a, k, g in zip(found, at, at_guard):
        where = ([f"false target #{k + 1} above"] if k >= 0 else []) + (["the guard-window figure"] if g >= 0 else [])
        lines.append(f"\n- {a.describe()}" + (f": {' and '.join(where)}" if where else ""))
    return doc, lines


def _sample_index(product: Product, position: Mapping[str, float]) -> dict[str, float]:
    """Image-sample indices {dim: sample} of a position in the frame's coordinates (nearest sample)."""
    import numpy as np

    return {d: float(np.argmin(np.abs(np.asarray(product.coords[d], float) - position[d]))) for d in position}


def _target_names(target_names: str | None) -> list[str] | None:
    """--targets as a list of names (None: every target); raises InputError when it names none."""
    from sarproc.product.errors import InputError

    if target_names is None:
        return None
    names = [n.strip() for n in target_names.split(",") if n.strip()]
    if not names:
        raise InputError(f"--targets: no target names in {target_names!r}")
    return names


def _check_plot_dir(plot_dir: Path, input_path: Path) -> None:
    """--plot must be a directory that takes new files (existing) or can be created (missing)."""
    from sarproc.product.errors import InputError
    from sarproc.product.io import check_output_path

    try:
        exists = plot_dir.exists()
    except PermissionError:  # a directory on its path this user may not search: check_output_path says so
        exists = False
    if exists and not plot_dir.is_dir():
        raise InputError(f"{plot_dir}: --plot needs a directory, this is a file")
    check_output_path(plot_dir / "quicklook.png" if exists else plot_dir, [input_path], overwrite=True)


def _expect_doc(expect_path: Path | None, failures: Sequence[CheckFailure]) -> dict:
    """The report JSON's "expect" entry: the tolerance file, whether it passed, and each failure."""
    return {
        "file": str(expect_path),
        "passed": not failures,
        "failures": [
            {
                "target": f.target,
                "axis": f.axis,
                "metric": f.metric,
                "value": f.value if math.isfinite(f.value) else None,
                "bound": f.bound,
            }
            for f in failures
        ],
    }


def _verdict(failures: Sequence[CheckFailure], expect_path: Path | None) -> None:
    """Each failed check on stderr and exit 1, or the all-passed summary line."""
    for f in failures:
        click.echo(str(f), err=True)
    if failures:
        click.echo(f"evaluate: {len(failures)} check(s) failed against {expect_path}", err=True)
        click.get_current_context().exit(1)
    summary(f"evaluate: all checks passed against {expect_path}")


def _plots(
    plot_dir: Path, product: Product, report: QualityReport, units: Mapping[str, str], params: EvaluateParams
) -> None:
    created = not plot_dir.exists()
    plot_dir.mkdir(parents=True, exist_ok=True)
    try:
        _draw(plot_dir, product, report, units, params)
    except BaseException:
        if created:  # leave no empty folder behind
            with contextlib.suppress(OSError):
                plot_dir.rmdir()
        raise


def _draw(
    plot_dir: Path, product: Product, report: QualityReport, units: Mapping[str, str], params: EvaluateParams
) -> None:
    import numpy as np

    from sarproc.cli.quicklook import import_matplotlib_lean
    from sarproc.product.io import atomic_path
    from sarproc.quality.plotting import TargetFigure, plot_quicklook, safe_name

    import_matplotlib_lean()

    truth = np.stack([product.targets[d].astype(float) for d in product.dims], axis=1)
    names = [t.name for t in report.targets]
    irw = product.attrs["theoretical_irw"]
    # Figures are drawn to temporary files and renamed, like every other output.
    with atomic_path(plot_dir / "quicklook.png") as tmp:
        plot_quicklook(
            tmp,
            product.data,
            product.dims,
            product.coords,
            truth,
            names,
            units,
            title=product.kind,
            frame=product.attrs.get("frame", {}).get("name", ""),
        )
    figure = TargetFigure(product.data, product.dims, product.coords, irw, units, params)  # one for all targets
    for t in report.targets:
        with atomic_path(plot_dir / f"target_{safe_name(t.name)}.png") as tmp:
            figure.draw(tmp, t)
