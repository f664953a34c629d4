"""sarproc reconstruct RAW_MC.h5 -o RAW.h5 [--config FILE.yaml]  (paper 003, section `reconstruct:`)"""

from __future__ import annotations

import time
from pathlib import Path

import click

from sarproc.cli.options import common_options, input_argument, summary, want_progress


@click.command()
@input_argument
@common_options
def reconstruct(input_path: Path, output: Path, config_path, overwrite: bool, progress):
    """Azimuth multichannel reconstruction (paper 003): raw_multichannel -> one raw channel at N x PRF.

    Squint deramp, Krieger filter bank, and for `method: modified` moving-target detection,
    slant-range velocity search, along-track autofocus and the modified filter bank. The
    estimates and search curves are stored in the output (attribute `reconstruct`, aux
    `velocity_search_<k>`, `estimated_velocity`); `sarproc backproject` focuses the output.
    """
    from sarproc.cli.progress import progress_factory
    from sarproc.focus.multichannel.reconstruct import ReconstructParams, reconstruct as run
    from sarproc.cli.stage import naming, prepare
    from sarproc.product.io import write_product

    # config, input header, output location, plan (the output holds as many samples as the input)
    params, raw = prepare("reconstruct", input_path, [output], config_path, overwrite, ("raw_multichannel",),
                          ReconstructParams, "reconstruct")
    start = time.perf_counter()
    with naming(input_path, config_path, "reconstruct"):
        out = run(raw, params, progress=progress_factory(want_progress(progress), "reconstruct"))
    out.history[-1]["command"] = f"sarproc reconstruct {input_path}"
    write_product(output, out, inputs=[input_path], overwrite=overwrite)
    info = out.attrs["reconstruct"]
    movers = "; ".join(f"v_r {m['radial_velocity']:.2f} m/s v_a {m['along_track_velocity']:.2f} m/s"
                       for m in info["moving_targets"])
    summary(f"reconstruct: {info['n_channels']} channels x {raw.data.shape[1]} pulses -> {out.data.shape[0]} pulses "
            f"at {info['prf_out']:.6g} Hz (condition {info['condition_number']:.3g}"
            + (f"; {len(info['moving_targets'])} moving: {movers}" if movers else "")
            + f") -> {output} ({time.perf_counter() - start:.2f} s)")
