#!/usr/bin/env python
"""The paper-000 chain's hard cases: refusals and special scenes that are no grid of one scene.

    python scripts/accuracy_000.py [--out results/000-accuracy]

Squint 60 deg, 800 km with complex64 storage and float32 intermediates, the Stolt square-root limit,
alpha near 1/2, a target at the edge of the data window, PRF just above / below what the coarse step
needs: each goes to hardcases.md with its measured worst quality over targets and axes
(sarproc.quality.summary) or the refusal message. The knobs' accuracy against time on one scene is the
sweep configs/sweeps/accuracy_000.yaml (``make accuracy-000`` runs both).
"""

from __future__ import annotations

import argparse
import copy
from collections.abc import Callable, Collection
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import yaml

if TYPE_CHECKING:
    from sarproc.product.model import Product

ROOT = Path(__file__).resolve().parents[1]
STAGES = ("preprocess", "coarse_focus", "fine_focus")
_Case = tuple["Product", str, tuple[str, ...] | None]  # a hard case: image, note, targets scored (None: all)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "000-accuracy")
    a = ap.parse_args(argv)
    a.out.mkdir(parents=True, exist_ok=True)
    hard_cases(a.out)
    print(f"accuracy_000: {a.out / 'hardcases.md'}")


def _chain(cfg: dict, raw: Product | None = None, **over: dict) -> tuple[Product, Product, Product]:
    from sarproc.focus.squint_deramp.coarse_focus import CoarseFocusParams, coarse_focus
    from sarproc.focus.squint_deramp.fine_focus import FineFocusParams, fine_focus
    from sarproc.focus.squint_deramp.preprocess import PreprocessParams, preprocess
    from sarproc.product.config import build
    from sarproc.simulation.scene import scene_from_mapping
    from sarproc.simulation.simulate import simulate

    cfg = copy.deepcopy(cfg)
    for s in STAGES:
        cfg[s] = {**(cfg.get(s) or {}), **over.get(s, {})}
    if raw is None:
        raw = simulate(scene_from_mapping({k: v for k, v in cfg.items() if k not in STAGES}))
    c = coarse_focus(
        preprocess(raw, build(PreprocessParams, cfg["preprocess"])), build(CoarseFocusParams, cfg["coarse_focus"])
    )
    return raw, c, fine_focus(c, build(FineFocusParams, cfg["fine_focus"]))


def _worst(
    img: Product, names: Collection[str] | None = None
) -> tuple[float | None, float | None, float | None, float | None]:
    from sarproc.quality.metrics import evaluate_product
    from sarproc.quality.summary import worst_of_targets

    rep = evaluate_product(img)
    w = worst_of_targets(t for t in rep.targets if names is None or t.name in names)
    return w.irw_dev, w.pslr_db, w.islr_db, w.position_cells


def hard_cases(out: Path) -> None:
    import math

    from sarproc.product.errors import InputError

    small = yaml.safe_load((ROOT / "configs" / "an2012_exp1_small.yaml").read_text())
    pts3 = [
        {"name": "C", "azimuth": "0 m", "range": "0 m"},
        {"name": "E", "azimuth": "200 m", "range": "500 m"},
        {"name": "W", "azimuth": "-200 m", "range": "-500 m"},
    ]
    rows = []

    def record(case: str, fn: Callable[[], _Case]) -> None:
        try:
            img, note, names = fn()
            finite = bool(np.all(np.isfinite(img.data)))
            w = _worst(img, names)
            rows.append(f"| {case} | ran | {finite} | {w[0]:.3f} | {w[1]:.2f} | {w[2]:.2f} | {w[3]:.3f} | {note} |")
        except InputError as exc:
            rows.append(f"| {case} | refused (exit 2) | - | - | - | - | - | {str(exc)[:160]} |")
        print(rows[-1], flush=True)

    def squint60() -> _Case:
        cfg = copy.deepcopy(small)
        cfg["geometry"]["squint"] = "60 deg"
        cfg["targets"]["points"] = pts3
        cfg["coarse_focus"] = {"scene_margin": "60 m"}
        raw, _, img = _chain(cfg, fine_focus={"output_frame": "lrwc"})
        return (
            img,
            "exp1_small geometry at 60 deg (agreement with backprojection: tests/focus/test_squint_deramp.py)",
            None,
        )

    def far800() -> _Case:
        cfg = copy.deepcopy(small)
        cfg["geometry"]["reference_range"] = "800 km"
        cfg["acquisition"]["aperture_time"] = "0.25 s"
        cfg["targets"]["points"] = pts3
        cfg["coarse_focus"] = {"scene_margin": "60 m"}
        f32 = {"precision": "float32"}
        raw, _, img = _chain(cfg, preprocess=f32, coarse_focus=f32, fine_focus={**f32, "output_frame": "lrwc"})
        return img, f"raw stored {raw.data.dtype}, all intermediates complex64", None

    def sqrt_limit() -> _Case:
        cfg = yaml.safe_load((ROOT / "configs" / "an2012_hard_sqrt_limit.yaml").read_text())
        raw, c, img = _chain(cfg)
        lim = 2 * 10e9 * 100 * (1 - math.sin(math.radians(60))) / 299792458.0
        return (
            img,
            (
                f"F_a''/2 = {c.attrs['azimuth_sampling_rate'] / 2:.0f} Hz beyond the limit {lim:.0f} Hz; "
                f"{100 * img.attrs['stolt_masked_fraction']:.1f} % of the spectrum masked (zero), no NaN; "
                "range IRW is wide-angle (1.5 s at 1 km), same with the grid inside the limit"
            ),
            None,
        )

    exp2s = yaml.safe_load((ROOT / "configs" / "an2012_exp2_small.yaml").read_text())
    raw2 = None

    def alpha(val: float) -> Callable[[], _Case]:
        def f() -> _Case:
            nonlocal raw2
            raw2, _, img = _chain(exp2s, raw2, fine_focus={"alpha": val, "output_frame": "lrwc"})
            h = img.history[-1]["parameters"]
            return img, f"{h['nlcs_azimuth_samples']} azimuth samples, dispersion {h['nlcs_dispersion']:.3g} s", None

        return f

    def window_edge() -> _Case:
        cfg = copy.deepcopy(small)
        cfg["targets"]["points"] = pts3
        cfg["coarse_focus"] = {"scene_margin": "60 m"}
        cfg["acquisition"]["range_window"] = {"start": "298500 m", "end": "300830 m"}
        raw, _, img = _chain(cfg, fine_focus={"output_frame": "lrwc"})
        return img, "window ends 150 m past E's latest echo start: E's chirps cut; metrics of E only", ("E",)

    def prf(factor: float) -> Callable[[], _Case]:
        def f() -> _Case:
            cfg = copy.deepcopy(small)
            cfg["targets"]["points"] = pts3
            cfg["coarse_focus"] = {"scene_margin": "60 m"}
            _, c, _ = _chain(cfg)
            cfg["radar"]["prf"] = f"{c.attrs['deramp_extent'] * factor:.3f} Hz"
            _, c2, img = _chain(cfg, fine_focus={"output_frame": "lrwc"})
            return img, f"PRF = {factor:.2f} x the needed {c.attrs['deramp_extent']:.1f} Hz", None

        return f

    record("squint 60 deg", squint60)
    record("800 km, complex64", far800)
    record("Stolt square-root limit", sqrt_limit)
    for val in (0.5, 0.45, 0.55, 0.4):
        record(f"alpha = {val}", alpha(val))
    record("target at the data-window edge", window_edge)
    record("PRF 2 % above coarse need", prf(1.02))
    record("PRF 2 % below coarse need", prf(0.98))
    lines = [
        "# Paper 000 chain: hard cases",
        "",
        "Worst over targets and both axes (squint_lrwc frame). 'refused' = InputError, CLI exit 2, with the message.",
        "",
        "| case | outcome | finite | worst IRW dev | worst PSLR (dB) | worst ISLR (dB) | worst position (cells) | note |",
        "|---|---|---|---:|---:|---:|---:|---|",
    ] + rows
    (out / "hardcases.md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
