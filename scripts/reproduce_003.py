"""Tabulate and plot paper 003's reproduction (Xu et al.: multichannel squint SAR, moving targets).

Every processing step runs through the command line (``make reproduce-003``, mk/003.mk); this script
only reads the products and reports it left under --results:

* scene A, B, C (paper Fig. 11, Table 2): raw_{conventional,modified}.h5 (sarproc reconstruct),
  image_*.h5 and report_*.json (sarproc backproject, evaluate: moving targets measured at their
  static-equivalent positions), strip_<method>_<target>.json (evaluate of the azimuth strip around each
  target, configs/xu_strip.yaml: the maximum false-target amplitude, MFTA);
* sweep-cases/ (configs/sweeps/reproduce_003_cases.yaml): Figs. 9 (v_a 10 m/s) and 10 (v_r 10 m/s), the
  static target, and the static target as one channel at N PRF (the static images against it: `sarproc compare
  -o`, compare_static_*.json, its signal_db and peak_db);
* sweep-given/ (reproduce_003_given.yaml): the false-target level against the velocity error (with the
  first-order prediction, eq. 6 of docs/multichannel.md, from evaluate's moving-target report) and with the
  true velocity given;
* sweep-speeds/ (reproduce_003_speeds.yaml): the false-target level against v_r (paper Fig. 12);
* sweep-clutter/ (reproduce_003_clutter.yaml): the clutter null with the redundant channel.

Writes summary.md, summary.json, the two compare_static_*.json and the figures under --results.
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from sarproc.cli.markdown import markdown_table
from sarproc.cli.sweep_output import pick_row as pick, sweep_rows
from sarproc.product.io import read_product
from sarproc.product.model import Product

CASES = {"fig9": "Fig. 9 v_a 10 m/s", "fig10": "Fig. 10 v_r 10 m/s", "static": "static A"}
SPEEDS = (0, 2.5, 5, 7.5, 10, 12.5, 15, 17.5, 20)
ERRORS = (0.0, 0.05, 0.1, 0.2, 0.5, 1.0, 2.0)


def load_json(path: Path) -> dict:
    return json.loads(Path(path).read_text())


def compare(base: Path, new: Path, out: Path) -> dict:
    """`sarproc compare BASE NEW -o OUT`: the product entry of its JSON (signal_db: ||new - base||^2 / ||base||^2
    in dB; peak_db: max |new| / max |base| in dB)."""
    cmd = [sys.executable, "-m", "sarproc", "compare", str(base), str(new), "-o", str(out), "--overwrite"]
    subprocess.run(cmd, check=True, capture_output=True)
    (entry,) = load_json(out)["files"]
    return entry


def mfta_db(report: dict) -> float:
    """The paper's MFTA: the strongest response outside the target's guard window (the strips' +-0.45 ghost
    spacing; evaluate's guard-window figure)."""
    return _level(report, "false_target_guard")


def residual_db(report: dict) -> float:
    """evaluate's false target on the residual (every target's fitted response subtracted): below the side
    lobes, but on a strip it also reads the target's own misfit where the strip cuts its range window."""
    return _level(report, "false_target")


def _level(report: dict, key: str) -> float:
    ft = report.get(key)
    return ft["level_db"] if ft and ft["level_db"] is not None else float("-inf")


def levels(report: dict) -> dict[str, float]:
    return {"mfta_db": mfta_db(report), "residual_db": residual_db(report)}


def metrics_rows(report: dict, mfta: dict[str, dict[str, float]], label: str) -> list[dict]:
    rows = []
    for t in report["targets"]:
        ax = {a["axis"]: a for a in t["axes"]}
        az, rg = ax["azimuth"], ax["range"]
        rows.append(
            {
                "case": label,
                "target": t["name"],
                "peak": t["peak_amplitude"],
                "az_irw_ratio": az["irw_ratio"],
                "rg_irw_ratio": rg["irw_ratio"],
                "az_pslr": az["pslr_db"],
                "rg_pslr": rg["pslr_db"],
                "az_islr": az["islr_db"],
                "rg_islr": rg["islr_db"],
                "az_err_cells": az["position_error_cells"],
                "rg_err_cells": rg["position_error_cells"],
                "mfta_db": mfta.get(t["name"], {}).get("mfta_db", float("nan")),
                "residual_db": mfta.get(t["name"], {}).get("residual_db", float("nan")),
            }
        )
    return rows


def doppler_spectrum(reconstructed: Path) -> tuple[np.ndarray, np.ndarray]:
    """(Doppler frequency, Hz; power) of a reconstructed product: reconstruct's aux doppler_frequency, doppler_power."""
    aux = read_product(reconstructed, load=False).aux
    return aux["doppler_frequency"], aux["doppler_power"]


def estimate(reconstructed: Path) -> tuple[float, float]:
    """(v_r, v_a) of the one moving-target window of a reconstructed product (nan if none)."""
    mts = read_product(reconstructed, load=False).attrs["reconstruct"]["moving_targets"]
    return (mts[0]["radial_velocity"], mts[0]["along_track_velocity"]) if mts else (float("nan"), float("nan"))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--results", default="results/003")
    args = ap.parse_args()
    res = Path(args.results)
    summary: dict[str, Any] = {}

    # ---- scene A, B, C (paper Fig. 11, Table 2)
    raw = read_product(res / "raw_mc.h5", load=False)
    rows: list[dict] = []
    images: dict[str, Product] = {}
    movers: dict[str, list] = {}
    for method in ("conventional", "modified"):
        report = load_json(res / f"report_{method}.json")
        strip_levels = {t: levels(load_json(res / f"strip_{method}_{t}.json")) for t in ("A", "B", "C")}
        rows += metrics_rows(report, strip_levels, f"scene {method}")
        images[method] = read_product(res / f"image_{method}.h5")
        movers[method] = report.get("movers", [])
    info = read_product(res / "raw_modified.h5", load=False).attrs["reconstruct"]
    summary["scene_estimates"] = [
        (m["first_cell"], m["radial_velocity"], m["along_track_velocity"], m["search_evaluations"])
        for m in info["moving_targets"]
    ]
    summary["scene_condition"] = info["condition_number"]
    summary["scene_truth"] = {
        n.decode(): (float(vy), float(vx))
        for n, vx, vy in zip(raw.targets["name"], raw.targets["vx"], raw.targets["vy"])
    }
    summary["scene_movers"] = movers["modified"]
    expect = load_json(res / "report_modified.json").get("expect")
    summary["scene_expect"] = expect

    # ---- single targets (Figs. 9, 10), the static check
    cases = sweep_rows(res / "sweep-cases")
    single_rows: list[dict] = []
    strips: dict[tuple[str, str], Product] = {}  # (case, method): its azimuth strip
    spectra: dict[tuple[str, str], tuple[np.ndarray, np.ndarray]] = {}
    case_images: dict[tuple[str, str], Path] = {}
    for scene, label in CASES.items():
        for method in ("conventional", "modified"):
            img = pick(cases, scene=f"{scene}-{method}-image")
            strip = pick(cases, scene=f"{scene}-{method}-strip")
            strip_report = load_json(strip["dir"] / "report.json")
            image_report = load_json(img["dir"] / "report.json")
            row = metrics_rows(image_report, {"T": levels(strip_report)}, f"{label} {method}")[0]
            row["v_r_est"], row["v_a_est"] = estimate(img["dir"] / "reconstruct.h5")
            single_rows.append(row)
            strips[(label, method)] = read_product(strip["dir"] / "backproject.h5")
            spectra[(label, method)] = doppler_spectrum(img["dir"] / "reconstruct.h5")
            case_images[(scene, method)] = img["dir"] / "backproject.h5"
    ref_row = pick(cases, scene="single_n_prf-image")
    conventional, modified = case_images[("static", "conventional")], case_images[("static", "modified")]
    single = compare(ref_row["dir"] / "backproject.h5", conventional, res / "compare_static_single_conventional.json")
    mod = compare(conventional, modified, res / "compare_static_conventional_modified.json")
    summary["static_vs_single_channel"] = {  # ||new - base|| / ||base|| = 10^(signal_db / 20)
        "relative_difference": 10 ** (single["signal_db"] / 20),
        "peak_ratio_db": single["peak_db"],
        "modified_vs_conventional": 10 ** (mod["signal_db"] / 20),
    }
    single_rows += metrics_rows(load_json(ref_row["dir"] / "report.json"), {}, "static A single channel N PRF")

    # ---- false-target level against the velocity error (paper: about -40 dB at 0.1 m/s)
    given = sweep_rows(res / "sweep-given")
    err_rows: list[dict[str, float]] = []
    for err in ERRORS:
        report = load_json(pick(given, scene=f"e{err:g}")["dir"] / "report.json")
        (mover,) = [m for m in report["movers"] if m["name"] == "T"]  # evaluate: the velocity error's ghosts
        predicted = mover["ghost_level_from_velocity_db"]
        err_rows.append(
            {
                "error": err,
                "mfta_db": mfta_db(report),
                "residual_db": residual_db(report),
                "max_phase_deg": math.degrees(mover["channel_phase_from_velocity"]),
                "predicted_db": float("-inf") if predicted is None else predicted,
            }
        )

    # ---- false-target level against the slant-range velocity (paper Fig. 12)
    speeds = sweep_rows(res / "sweep-speeds")
    vel_rows: list[dict[str, Any]] = []
    for v_r in SPEEDS:
        row = {"v_r": v_r}
        for method in ("conventional", "modified"):
            r = pick(speeds, scene=f"v{v_r:g}", **{"reconstruct.method": method})
            row[f"{method}_db"] = mfta_db(load_json(r["dir"] / "report.json"))
            if method == "modified":
                v = estimate(r["dir"] / "reconstruct.h5")
                row["v_r_est"], row["v_a_est"] = (0.0, 0.0) if math.isnan(v[0]) else v
        row["given_db"] = mfta_db(load_json(pick(given, scene=f"g{v_r:g}")["dir"] / "report.json"))
        vel_rows.append(row)

    # ---- clutter null with the redundant channel
    clutter = sweep_rows(res / "sweep-clutter")
    summary["clutter"] = {}
    for scene, label in (
        ("clutter_only", "clutter only"),
        ("target_only", "target only"),
        ("clutter_and_target", "clutter + target"),
    ):
        r = pick(clutter, scene=scene)
        info = read_product(r["dir"] / "reconstruct.h5", load=False).attrs["reconstruct"]
        summary["clutter"][label] = {
            "residual_db": info["clutter_suppression_db"],
            "redundant": info["clutter_redundant_channels"],
            "simulate_s": r["simulate_s"],
        }

    summary["timings_s"] = {
        name: round(sum((r["focus_s"] or 0) + (r["evaluate_s"] or 0) for r in sweep_rows(res / name)), 2)
        for name in ("sweep-cases", "sweep-given", "sweep-speeds", "sweep-clutter")
    }
    summary.update(rows=rows, single_rows=single_rows, error_curve=err_rows, velocity_curve=vel_rows)
    (res / "summary.json").write_text(json.dumps(summary, indent=1, default=float))
    figures(res, images, strips, spectra, err_rows, vel_rows)
    write_summary(res, summary)


def figures(
    res: Path,
    images: dict[str, Product],
    strips: dict[tuple[str, str], Product],
    spectra: dict[tuple[str, str], tuple[np.ndarray, np.ndarray]],
    err_rows: list[dict[str, float]],
    vel_rows: list[dict[str, Any]],
) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 5))
    for ax, method in zip(axes, ("conventional", "modified")):
        img = images[method]
        mag = 20 * np.log10(np.abs(img.data) / np.abs(img.data).max() + 1e-12)
        az, rg = img.coords["azimuth"], img.coords["range"]
        ax.imshow(
            mag.T,
            origin="lower",
            aspect="auto",
            vmin=-40,
            vmax=0,
            cmap="gray",
            extent=[az[0], az[-1], rg[0] - 600e3, rg[-1] - 600e3],
        )
        ax.set_title(f"scene A, B, C: {method} reconstruction")
        ax.set_xlabel("azimuth x_n, m")
        ax.set_ylabel("range r_0 - 600 km, m")
    fig.tight_layout()
    fig.savefig(res / "fig11_scene.png", dpi=110)
    plt.close(fig)

    fig, axes = plt.subplots(3, 1, figsize=(10, 9), sharex=True)
    for ax, label in zip(axes, CASES.values()):
        for method, style in (("conventional", "r-"), ("modified", "k-")):
            s = strips[(label, method)]
            prof = np.abs(s.data).max(axis=1)
            ax.plot(
                s.coords["azimuth"] - s.coords["azimuth"][len(prof) // 2],
                20 * np.log10(prof / prof.max() + 1e-12),
                style,
                lw=0.7,
                label=method,
            )
        ax.set_ylim(-70, 3)
        ax.set_title(label + ": azimuth strip through the target (ghosts at multiples of PRF / K_a)")
        ax.set_ylabel("dB")
        ax.legend()
    axes[-1].set_xlabel("azimuth offset, m")
    fig.tight_layout()
    fig.savefig(res / "fig9_10_ghosts.png", dpi=110)
    plt.close(fig)

    fig, axes = plt.subplots(1, 2, figsize=(11, 4), sharey=True)
    for ax, label in zip(axes, (CASES["fig10"], CASES["static"])):
        for method, style in (("conventional", "r-"), ("modified", "k-")):
            f, pw = spectra[(label, method)]
            ax.plot(f, 10 * np.log10(pw / pw.max() + 1e-12), style, lw=0.6, label=method)
        ax.set_title(f"{label}: reconstructed Doppler spectrum", fontsize=10)
        ax.set_xlabel("Doppler, Hz")
        ax.set_ylim(-60, 3)
        ax.legend()
    axes[0].set_ylabel("dB")
    fig.tight_layout()
    fig.savefig(res / "fig10_spectrum.png", dpi=110)
    plt.close(fig)

    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    e = [r["error"] for r in err_rows]
    axes[0].plot(e, [r["mfta_db"] for r in err_rows], "ko-", label="measured (backprojected strip)")
    axes[0].plot(e[1:], [r["predicted_db"] for r in err_rows[1:]], "b--", label="first-order prediction")
    axes[0].axhline(-40, color="gray", ls=":", label="paper: about -40 dB at 0.1 m/s")
    axes[0].set_xlabel("slant-range velocity error, m/s")
    axes[0].set_ylabel("max false target, dB")
    axes[0].legend()
    v = [r["v_r"] for r in vel_rows]
    axes[1].plot(v, [r["conventional_db"] for r in vel_rows], "r^-", label="conventional")
    axes[1].plot(v, [r["modified_db"] for r in vel_rows], "ko-", label="modified (estimated velocity)")
    axes[1].plot(v, [r["given_db"] for r in vel_rows], "b.--", label="modified (true velocity)")
    axes[1].set_xlabel("slant-range velocity v_r, m/s")
    axes[1].set_ylabel("max false target, dB")
    axes[1].legend()
    fig.tight_layout()
    fig.savefig(res / "fig12_false_targets.png", dpi=110)
    plt.close(fig)


def md_table(rows: Sequence[dict], cols: Sequence[str], fmt: dict[str, str]) -> str:
    def cell(r: dict, c: str) -> str:
        return "n/a" if r.get(c) is None else fmt.get(c, "{}").format(r[c])

    return markdown_table(cols, [[cell(r, c) for c in cols] for r in rows]) + "\n"


METRIC_COLS = [
    "case",
    "target",
    "az_irw_ratio",
    "rg_irw_ratio",
    "az_pslr",
    "rg_pslr",
    "az_islr",
    "rg_islr",
    "az_err_cells",
    "rg_err_cells",
    "mfta_db",
    "residual_db",
]
METRIC_FMT = dict.fromkeys(("az_irw_ratio", "rg_irw_ratio", "az_err_cells", "rg_err_cells"), "{:.3f}")
METRIC_FMT.update(dict.fromkeys(("az_pslr", "rg_pslr", "az_islr", "rg_islr", "mfta_db", "residual_db"), "{:.2f}"))
MOVER_COLS = [
    "name",
    "v_r",
    "v_a",
    "v_r_estimated",
    "v_a_estimated",
    "v_r_error",
    "v_a_error",
    "shift",
    "relocation_error",
    "relocation_error_from_velocity",
]


def write_summary(res: Path, s: dict[str, Any]) -> None:
    fmt = dict.fromkeys(MOVER_COLS[1:], "{:.3f}")
    fmt.update(shift="{:.1f}", relocation_error="{:.2f}", relocation_error_from_velocity="{:.2f}")
    expect = s.get("scene_expect") or {}
    lines = [
        "# Paper 003 (Xu et al.): multichannel squint SAR, moving targets — reproduction",
        "",
        "Produced by `make reproduce-003`: every step through the command line (mk/003.mk: simulate, reconstruct, "
        "backproject, evaluate, and the sweeps configs/sweeps/reproduce_003_*.yaml); scripts/reproduce_003.py "
        "only tabulates. Moving targets are evaluated at their static-equivalent position "
        "(sarproc/product/moving.py); MFTA: strongest response on an azimuth strip of +-1.5 ghost spacings "
        "outside +-0.45 spacing of the target (evaluate's guard-window figure); residual: evaluate's false target "
        "on the residual, every fitted response subtracted (on a strip it also reads the target's own misfit "
        "where the strip cuts its range window).",
        "",
        "## Velocity estimates (scene A, B, C; modified reconstruction)",
        "",
        "| window first cell | v_r estimated (m/s) | v_a estimated (m/s) | leakage evaluations |",
        "|---|---|---|---|",
    ]
    for cell, vr, va, n in s["scene_estimates"]:
        lines.append(f"| {cell} | {vr:.3f} | {va:.3f} | {n} |")
    lines += [
        "",
        f"Truth (v_r, v_a): {s['scene_truth']}",
        "",
        "## Moving targets of the scene through the CLI (`sarproc evaluate`, modified reconstruction)",
        "",
        md_table(s["scene_movers"], MOVER_COLS, fmt),
        f"`evaluate --expect {expect.get('file')}`: "
        + ("passed" if expect.get("passed") else f"FAILED {expect.get('failures')}"),
        "",
        "## Table 2: point targets (scene and single-target cases)",
        "",
        md_table(s["rows"] + s["single_rows"], METRIC_COLS, METRIC_FMT),
        "## Static target against a single-channel simulation at N PRF",
        "",
        json.dumps(s["static_vs_single_channel"]),
        "",
        "## False-target level against the slant-range velocity error (paper: about -40 dB at 0.1 m/s)",
        "",
        md_table(
            s["error_curve"],
            ["error", "max_phase_deg", "mfta_db", "predicted_db", "residual_db"],
            {"max_phase_deg": "{:.2f}", "mfta_db": "{:.2f}", "predicted_db": "{:.2f}", "residual_db": "{:.2f}"},
        ),
        "## False-target level against the slant-range velocity (paper Fig. 12)",
        "",
        md_table(
            s["velocity_curve"],
            ["v_r", "v_r_est", "v_a_est", "conventional_db", "modified_db", "given_db"],
            dict.fromkeys(("v_r_est", "v_a_est", "conventional_db", "modified_db", "given_db"), "{:.2f}"),
        ),
        "## Clutter null with the redundant channel (energy after / before, dB)",
        "",
        json.dumps(s["clutter"]),
        "",
        "Sweep step times, focus + evaluate summed (s): " + json.dumps(s["timings_s"]),
        "",
    ]
    (res / "summary.md").write_text("\n".join(lines))


if __name__ == "__main__":
    main()
