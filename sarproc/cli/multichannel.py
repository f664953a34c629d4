"""sarproc reconstruct RAW_MC.h5 -o RAW.h5 [--config FILE.yaml]  (paper 003, section `reconstruct:`)"""

from __future__ import annotations

import time
from pathlib import Path

import click

from sarproc.cli.options import SectionCommand, common_options, input_argument, summary, want_progress


@click.command(cls=SectionCommand, section="reconstruct")
@input_argument
@common_options
def reconstruct(
    input_path: Path, output: Path, config_path: Path | None, overwrite: bool, progress: bool | None
) -> None:
    """Azimuth multichannel reconstruction (paper 003): raw_multichannel -> one raw channel at N x PRF.

    Squint deramp, Krieger filter bank, and for `method: modified` moving-target detection (CFAR on
    the azimuth-compressed, optionally clutter-nulled, reconstruction), separation of each mover,
    slant-range velocity search, along-track autofocus and the modified filter bank per mover. The
    movers are the aux table `moving_targets` (velocities with 1-sigma, apparent and relocated
    positions, matched truth; docs/product.md); estimates and search curves also in attribute
    `reconstruct` and aux `velocity_search_<k>`; `sarproc backproject` focuses the output.
    """
    from sarproc.cli.progress import progress_factory
    from sarproc.cli.stage import naming, prepare
    from sarproc.focus.budget import reconstruct_estimate
    from sarproc.focus.multichannel.reconstruct import ReconstructParams, reconstruct as run
    from sarproc.product.io import write_product

    # config, input header, output location, plan (the output holds as many samples as the input)
    params, raw = prepare(
        "reconstruct",
        input_path,
        [output],
        config_path,
        overwrite,
        ("raw_multichannel",),
        ReconstructParams,
        "reconstruct",
        reconstruct_estimate,
    )
    start = time.perf_counter()
    with naming(input_path, config_path, "reconstruct"):
        out = run(raw, params, progress=progress_factory(want_progress(progress), "reconstruct"))
    out.history[-1]["command"] = f"sarproc reconstruct {input_path}"
    write_product(output, out, inputs=[input_path], overwrite=overwrite)
    info = out.attrs["reconstruct"]
    movers = "; ".join(
        f"v_r {m['radial_velocity']:.2f} m/s v_a {m['along_track_velocity']:.2f} m/s" for m in info["moving_targets"]
    )
    truth = info.get("truth")
    found = (
        (
            f"; truth: {truth['found']} of {truth['movers']} movers found"
            + (f", missed {', '.join(truth['missed'])}" if truth["missed"] else "")
            + f", {truth['false_alarms']} false alarm(s)"
        )
        if truth
        else ""
    )
    summary(
        f"reconstruct: {info['n_channels']} channels x {raw.data.shape[1]} pulses -> {out.data.shape[0]} pulses "
        f"at {info['prf_out']:.6g} Hz (condition {info['condition_number']:.3g}"
        + (f"; {len(info['moving_targets'])} moving: {movers}" if movers else "")
        + found
        + f") -> {output} ({time.perf_counter() - start:.2f} s)"
    )
