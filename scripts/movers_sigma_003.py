"""Are the moving_targets table's 1-sigma velocity uncertainties true? (paper 003, issue 19)

A small Monte-Carlo of reduced scenes, each simulated and reconstructed through the command line (``sarproc
simulate`` and ``sarproc reconstruct`` with the scene's YAML; about 20-30 s of CPU per scene):

* clutter: tests/focus/test_movers.py's SLOWISH scene (the radar of configs/xu_scene.yaml with 4 receivers
  1.5 m apart, a 30 MHz chirp at 36 MHz, 60 clutter scatterers as bright as the mover over 400 x 200 m around it,
  clutter null on) for each clutter seed and mover velocity (v_r, v_a);
* clean: the same radar with no clutter and no null (two movers as tests/focus/test_movers.py's two_movers, xu_scene's
  C, and CLEAN_PAIRS): the movers the estimators' floors (reconstruct.LOS_FLOOR, ALONG_TRACK_FLOOR) are measured on.

Per mover: the error of v_r and v_a against the truth and the stated 1-sigma; per column, the fraction of
|error| <= 1 sigma (68 % if calibrated) and <= 2 sigma (95 %). The rule before (main_rule_sigmas: the clutter-null
residual's detection SNR taken for the mover's own, v_a's floor 0.05 m/s) is tabulated beside it; "v_los by" is the
criterion that estimated v_los (eq. 5, or the null fit); "pull" is v_a's offset on the mover's illumination alone
(reconstruct.illumination_pull). Writes <results>/sigma_calibration.md.

    PYTHONPATH=. python scripts/movers_sigma_003.py --results results/003-movers
"""

from __future__ import annotations

import argparse
import math
import resource
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import yaml

from sarproc.product.io import read_product
from sarproc.product.model import moving_target_table

BASE = Path(__file__).resolve().parents[1] / "configs" / "xu_scene.yaml"
VELOCITIES = ((-2.0, 10.0), (-3.0, 12.0), (4.0, -6.0), (-5.0, 5.0))  # (v_r, v_a) m/s: v_los 1.5, 1.3, 1.7, -3.0
SEEDS = (9, 1, 2, 3)
# two clean movers per scene, (v_r, v_a) m/s each, 80 m apart in walk-corrected range as two_movers
CLEAN_PAIRS = (((-8.0, 5.0), (5.0, -8.0)), ((15.0, -12.0), (-12.0, 15.0)), ((3.0, 8.0), (-15.0, -4.0)))


def vehicle(name: str, azimuth: float, rng: float, v_a: float, v_r: float) -> dict:
    return {
        "name": name,
        "azimuth": f"{azimuth} m",
        "range": f"{rng} m",
        "velocity": [f"{v_a} m/s", f"{v_r} m/s", "0 m/s"],
    }


def scene(points: list[dict], clutter_seed: int | None) -> dict:
    m = yaml.safe_load(BASE.read_text())
    for key in ("reconstruct", "backproject", "evaluate"):
        m.pop(key, None)
    m["targets"]["points"] = points
    if clutter_seed is None:  # tests/focus/test_movers.py's reduced scene
        m["radar"].update({"bandwidth": "10 MHz", "range_sampling_rate": "12 MHz"})
    else:
        m["effects"]["azimuth_channels"] = {"n_receivers": 4, "spacing": "1.5 m"}
        m["effects"]["clutter"] = {
            "n_scatterers": 60,
            "azimuth_extent": "400 m",
            "range_extent": "200 m",
            "seed": clutter_seed,
        }
    return m


def main_rule_sigmas(
    snr_db: float, af_db: float, pull: float, n: int, dx: float, apparent_range: float
) -> tuple[float, float]:
    """The rule before (main at 0f76d93): v_r and v_a 1-sigma with the detection SNR itself as the mover's SNR (the
    clutter-null residual's, in the v_los CRB and the autofocus CRB) and floors 0.02 (v_r) and 0.05 (v_a) m/s."""
    lam, v, theta = 299792458.0 / 9.6e9, 7500.0, math.radians(20)
    snr = 10 ** (snr_db / 10)
    snr_af = snr if math.isnan(af_db) else min(snr, 10 ** (af_db / 10))
    tau = np.arange(n) * dx / (2 * v)
    spread = math.sqrt(float(np.sum((tau - tau.mean()) ** 2)))
    s_los = lam / (4 * math.pi * spread) / math.sqrt(2 * snr / n)
    half_band = v * math.cos(theta) * math.radians(0.507) / lam
    ka = 2 * (v * math.cos(theta)) ** 2 / (lam * apparent_range)
    t_ill = 2 * half_band / ka
    s_k = math.sqrt(90 / snr_af) / (math.pi * t_ill**2)
    s_a = math.hypot(math.hypot(s_k * v / (2 * ka), 0.05), 0.0 if math.isnan(pull) else pull)
    return math.hypot(math.hypot(s_los / math.cos(theta), 0.02), math.tan(theta) * s_a), s_a


def rows_of(mapping: dict, clutter: bool) -> tuple[list[dict], float]:
    """The scene through ``sarproc simulate`` and ``sarproc reconstruct`` (reconstruct's defaults but the clutter
    null); its moving_targets rows matched to the truth, and the two commands' CPU seconds."""
    mapping = {**mapping, "reconstruct": {"clutter_suppression": clutter}}
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    with tempfile.TemporaryDirectory(prefix="movers-sigma-") as tmp:
        cfg, raw, rec_path = Path(tmp) / "scene.yaml", Path(tmp) / "raw.h5", Path(tmp) / "rec.h5"
        cfg.write_text(yaml.safe_dump(mapping))
        cli = [sys.executable, "-m", "sarproc"]
        for args in (
            ["simulate", str(cfg), "-o", str(raw)],
            ["reconstruct", str(raw), "-o", str(rec_path), "--config", str(cfg)],
        ):
            subprocess.run([*cli, *args, "--no-progress"], check=True, capture_output=True, text=True)
        rec = read_product(rec_path, load=False)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    secs = (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)
    table = moving_target_table(rec.aux)
    names = [n.decode() for n in rec.targets["name"]]
    info = rec.attrs["reconstruct"]["moving_targets"]
    n_rx = 4 if clutter else 3
    dx = 1.5 if clutter else 2.0
    out = []
    for i in range(len(table["id"])):
        k = int(table["truth_index"][i])
        if k < 0:
            continue
        r = {c: float(v[i]) for c, v in table.items()}
        af = info[int(r["id"])].get("autofocus_snr_db")
        pull = info[int(r["id"])].get("autofocus_pull")
        old_r, old_a = main_rule_sigmas(
            r["snr"], float("nan") if af is None else af, float("nan") if pull is None else pull, n_rx, dx, 600e3
        )
        out.append(
            {
                "name": names[k],
                "snr": r["snr"],
                "af_snr": float("nan") if af is None else af,
                "pull": float("nan") if pull is None else pull,
                "path": "null fit" if info[int(r["id"])].get("null_fit") else "eq. 5",
                "dv_r": r["v_r"] - float(rec.targets["vy"][k]),
                "s_r": r["v_r_sigma"],
                "dv_a": r["v_a"] - float(rec.targets["vx"][k]),
                "s_a": r["v_a_sigma"],
                "old_r": old_r,
                "old_a": old_a,
            }
        )
    return out, secs


def coverage(rows: list[dict], err: str, sig: str) -> str:
    z = np.array([abs(r[err]) / r[sig] for r in rows])
    return f"{np.mean(z <= 1):.0%} / {np.mean(z <= 2):.0%}" if len(z) else "-"


def rms_z(rows: list[dict], err: str, sig: str) -> str:
    """rms of error / stated sigma (1 if calibrated; under 1: sigma over-stated by its inverse)."""
    z = np.array([r[err] / r[sig] for r in rows])
    return f"{math.sqrt(float(np.mean(z**2))):.2f}" if len(z) else "-"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--results", default="results/003-movers")
    ap.add_argument("--seeds", type=int, nargs="*", default=list(SEEDS))
    ap.add_argument("--velocities", type=int, default=len(VELOCITIES), help="the first this many of VELOCITIES")
    args = ap.parse_args()
    lines = [
        "# 1-sigma calibration of the moving_targets velocities (scripts/movers_sigma_003.py)",
        "",
        "| case | v_los by | SNR dB | autofocus SNR dB | pull | dv_r | sigma_r (before) | dv_a | sigma_a (before) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    cluttered: list[dict] = []
    clean: list[dict] = []

    def add(case: str, rows: list[dict], secs: float, into: list[dict]) -> None:
        for r in rows:
            into.append(r)
            line = (
                f"| {case} {r['name']} | {r['path']} | {r['snr']:.1f} | {r['af_snr']:.1f} | {r['pull']:+.3f} | {r['dv_r']:+.3f} "
                f"| {r['s_r']:.3f} "
                f"({r['old_r']:.3f}) | {r['dv_a']:+.3f} | {r['s_a']:.3f} ({r['old_a']:.3f}) |"
            )
            lines.append(line)
            print(line, f"{secs:.0f} s CPU", flush=True)

    rows, secs = rows_of(scene([vehicle("M1", 800, 0, 0, 10), vehicle("M2", 600, 148, 0, -6)], None), False)
    add("clean two_movers", rows, secs, clean)
    rows, secs = rows_of(scene([vehicle("C", 1090, -650, 10, 10)], None), False)
    add("clean xu_scene C", rows, secs, clean)
    for (r1, a1), (r2, a2) in CLEAN_PAIRS:
        rows, secs = rows_of(scene([vehicle("P", 800, 0, a1, r1), vehicle("Q", 600, 148, a2, r2)], None), False)
        add(f"clean ({r1:g}, {a1:g}) ({r2:g}, {a2:g})", rows, secs, clean)
    for v_r, v_a in VELOCITIES[: args.velocities]:
        for seed in args.seeds:
            rows, secs = rows_of(scene([vehicle("SLOWISH", 0, 0, v_a, v_r)], seed), True)
            add(f"clutter seed {seed} v_r {v_r:g} v_a {v_a:g}", rows, secs, cluttered)
            if not rows:
                lines.append(f"| clutter seed {seed} v_r {v_r:g} v_a {v_a:g}: not found | | | | | | | | |")
    lines += [
        "",
        "Fraction of movers with |error| <= 1 sigma / <= 2 sigma (68 % / 95 % if calibrated); rms z: the rms of",
        "error / sigma (1 if calibrated):",
        "",
        "| movers | n | v_r | v_r (before) | v_a | v_a (before) | rms z v_r (before) | rms z v_a (before) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for label, rows in (("in clutter", cluttered), ("clean", clean)):
        lines.append(
            f"| {label} | {len(rows)} | {coverage(rows, 'dv_r', 's_r')} | {coverage(rows, 'dv_r', 'old_r')} | "
            f"{coverage(rows, 'dv_a', 's_a')} | {coverage(rows, 'dv_a', 'old_a')} | "
            f"{rms_z(rows, 'dv_r', 's_r')} ({rms_z(rows, 'dv_r', 'old_r')}) | "
            f"{rms_z(rows, 'dv_a', 's_a')} ({rms_z(rows, 'dv_a', 'old_a')}) |"
        )
    out = Path(args.results)
    out.mkdir(parents=True, exist_ok=True)
    (out / "sigma_calibration.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines[-4:]))


if __name__ == "__main__":
    main()
