"""Paper 000 chain: sarproc preprocess | coarse-focus | fine-focus (An et al. 2012).

sarproc preprocess   RAW.h5    -o PRE.h5    [--config FILE.yaml]   # section preprocess:
sarproc coarse-focus PRE.h5    -o COARSE.h5 [--config FILE.yaml]   # section coarse_focus:
sarproc fine-focus   COARSE.h5 -o IMAGE.h5  [--config FILE.yaml]   # section fine_focus:
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import TYPE_CHECKING

import click

from sarproc.cli.options import SectionCommand, common_options, input_argument, summary, want_progress

if TYPE_CHECKING:
    from collections.abc import Callable

    from sarproc.product.budget import Plan
    from sarproc.product.model import Product


def _run(
    stage: str,
    input_path: Path,
    output: Path,
    config_path: Path | None,
    overwrite: bool,
    kinds: tuple[str, ...],
    params_cls: type,
    func: Callable[..., Product],
    progress: bool | None,
    estimate: Callable[..., Plan],
) -> tuple[Product, float]:
    """The shared body of the three commands: prepare (config, input, output, plan), run, write."""
    from sarproc.cli.progress import progress_factory
    from sarproc.cli.stage import naming, prepare
    from sarproc.product.io import write_product

    command = stage.replace("_", "-")
    params, product = prepare(command, input_path, [output], config_path, overwrite, kinds, params_cls, stage, estimate)
    start = time.perf_counter()
    with naming(input_path, config_path, stage):
        out = func(product, params, progress=progress_factory(want_progress(progress), command))
    out.history[-1]["command"] = f"sarproc {command} {input_path}"
    write_product(output, out, inputs=[input_path], overwrite=overwrite)
    return out, time.perf_counter() - start


@click.command(cls=SectionCommand, section="preprocess")
@input_argument
@common_options
def preprocess(
    input_path: Path, output: Path, config_path: Path | None, overwrite: bool, progress: bool | None
) -> None:
    """Doppler-centroid correction of a raw product (paper 000 eq. 7; section `preprocess:`)."""
    from sarproc.focus.budget import preprocess_estimate
    from sarproc.focus.squint_deramp.preprocess import PreprocessParams, preprocess as run

    out, dt = _run(
        "preprocess",
        input_path,
        output,
        config_path,
        overwrite,
        ("raw",),
        PreprocessParams,
        run,
        progress,
        preprocess_estimate,
    )
    summary(
        f"preprocess: {out.attrs['doppler_correction']} correction, {out.data.shape[0]}x{out.data.shape[1]} "
        f"-> {output} ({dt:.2f} s)"
    )


@click.command(cls=SectionCommand, section="coarse_focus")
@input_argument
@common_options
def coarse_focus(
    input_path: Path, output: Path, config_path: Path | None, overwrite: bool, progress: bool | None
) -> None:
    """Azimuth deramp / SPECAN coarse focusing (paper 000 eqs. 9-11; section `coarse_focus:`)."""
    from sarproc.focus.budget import coarse_focus_estimate
    from sarproc.focus.squint_deramp.coarse_focus import CoarseFocusParams, coarse_focus as run

    out, dt = _run(
        "coarse_focus",
        input_path,
        output,
        config_path,
        overwrite,
        ("preprocessed",),
        CoarseFocusParams,
        run,
        progress,
        coarse_focus_estimate,
    )
    a = out.attrs
    summary(
        f"coarse-focus: F_a'' = {a['azimuth_sampling_rate']:.1f} Hz, deramped spread "
        f"{a['deramp_spread']:.1f} Hz (PRF {out.radar.prf:.1f} Hz), {out.data.shape[0]}x{out.data.shape[1]} "
        f"-> {output} ({dt:.2f} s)"
    )


@click.command(cls=SectionCommand, section="fine_focus")
@input_argument
@common_options
def fine_focus(
    input_path: Path, output: Path, config_path: Path | None, overwrite: bool, progress: bool | None
) -> None:
    """Stolt range focusing and azimuth compression, flow 1 or NLCS flow 2 (section `fine_focus:`)."""
    from sarproc.focus.budget import fine_focus_estimate
    from sarproc.focus.squint_deramp.fine_focus import FineFocusParams, fine_focus as run

    out, dt = _run(
        "fine_focus",
        input_path,
        output,
        config_path,
        overwrite,
        ("coarse",),
        FineFocusParams,
        run,
        progress,
        fine_focus_estimate,
    )
    summary(
        f"fine-focus: flow {out.attrs['flow']}, {out.data.shape[0]}x{out.data.shape[1]} image in frame "
        f"{out.attrs['frame']['name']} -> {output} ({dt:.2f} s)"
    )
