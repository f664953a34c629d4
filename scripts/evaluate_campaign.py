"""Campaign of randomly drawn scenes through `sarproc simulate`, `backproject` and `evaluate` (issue 20).

Checks evaluate's figures on scenes nobody tuned. Each scene is a squinted stripmap (0-30 deg, 2 deg beam,
sinc / gaussian / rect pattern, 120 m track) with 1-5 truth targets (some 2-6 cells apart, some near or
beyond the beam's passage off the end of the track), 0-2 ghosts left out of the truth table at -40 to -50 dB
of the strongest target's peak, Hamming windows or none, and receiver noise off or at a level that leaves
the ghosts well above it. How the ghosts are left out: the truth scene is simulated and backprojected (its
image keeps only the truth in its targets table), and each ghost alone on the same grid (the truth targets
at amplitude 0, `backproject --targets TRUTH`); the ghosts' images are scaled to their levels and added to
the truth image's pixels (h5py), and `evaluate` reads the sum with the truth table.
Only the command line computes; this script draws, adds pixels and tabulates the reports.

Per scene: each truth target's IRW / own theory per axis, PSLR and ISLR against its own theory, position
error (cells) and flags; each ghost matched to an entry of the report's list of false targets (every
residual maximum over the floor) at its place (+-2 cells) and level (+-1 dB), or missed (under the floor, or
not); the clean image's residual floor; false targets where nothing was injected (the single figure over
-50 dB, or any listed entry; in the ghosted image any entry that matches no ghost); simulate's illumination warnings against
the lit fraction of each target's -3 dB passage (computed here from the platform track and the beam); CPU
seconds of evaluate against backproject's.

Usage: python scripts/evaluate_campaign.py --scenes 30 --seed 1 --out results/evaluate-campaign
       PYTHONPATH=OTHER_CHECKOUT python scripts/evaluate_campaign.py --reevaluate results/evaluate-campaign \
           --out results/evaluate-campaign-other   (the same images, evaluated by other code)
       python scripts/evaluate_campaign.py --out AFTER --compare BEFORE   (both runs side by side)
"""

from __future__ import annotations

import argparse
import copy
import dataclasses
import json
import math
import os
import re
import resource
import shutil
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import yaml

# every scene's radar, track and beam; the campaign draws the rest over it
BASE_SCENE = yaml.safe_load((Path(__file__).resolve().parents[1] / "configs" / "evaluate_campaign.yaml").read_text())


def _number(text: str, unit: str) -> float:
    value, got = text.split()
    if got != unit:
        raise SystemExit(f"configs/evaluate_campaign.yaml: {text!r} is not in {unit}")
    return float(value)


BEAMWIDTH_DEG = _number(BASE_SCENE["effects"]["antenna"]["azimuth_beamwidth"], "deg")
TRACK_S = _number(BASE_SCENE["acquisition"]["aperture_time"], "s")
VELOCITY = _number(BASE_SCENE["platform"]["velocity"], "m/s")
R0 = _number(BASE_SCENE["geometry"]["reference_range"], "m")
PLACE_CELLS = 2.0  # a ghost is found within this many cells of its place
LEVEL_DB = 1.0  # and this close to its level
LIST_MARGIN_DB = 1.0  # evaluate lists a false target this far over its residual floor (residual.LIST_MARGIN_DB)
FLOOR_DB = -50.0  # clean scenes: residual floor and false target at or below
NOISE_FT_DB = -52.0  # with noise on, a false target below this is the noise (its peak pixel), not invented
IRW_TOL, SIDE_DB, POS_CELLS = 0.03, 1.0, 0.1  # a well-focused target judged off its own theory beyond these
LIT_WARN, LIT_FULL = 0.90, 0.99  # lit fraction: warned below, not warned above (between: either)


@dataclasses.dataclass
class Point:
    name: str
    azimuth: float
    range: float
    amplitude: float = 1.0
    level_db: float = 0.0  # ghosts: the injected level


def cpu_run(args: list[str], cwd: Path) -> tuple[float, str]:
    """Run the CLI; (CPU seconds of the child, its stderr)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    p = subprocess.run(
        [sys.executable, "-m", "sarproc", *args, "--overwrite", "--no-progress"],
        cwd=cwd,
        capture_output=True,
        text=True,
    )
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if p.returncode not in (0, 1):
        raise RuntimeError(f"sarproc {' '.join(args)} exit {p.returncode}:\n{p.stderr[-3000:]}")
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), p.stderr


def draw_scene(rng: np.random.Generator) -> dict:
    """Random draws of one scene: geometry, pattern, window, noise, truth and ghosts."""
    squint = float(rng.uniform(0, 30))
    pattern = str(rng.choice(["sinc", "gaussian", "rect"]))
    window = str(rng.choice(["none", "hamming"]))
    noise = bool(rng.random() < 0.4)
    az_cell = 0.886 * 0.03 / (2 * math.radians(BEAMWIDTH_DEG))  # stripmap: half the antenna's length
    rg_cell = 0.886 * 299792458.0 / (2 * 150e6)
    if window == "hamming":
        az_cell, rg_cell = az_cell * 1.30 / 0.886, rg_cell * 1.30 / 0.886
    # the -3 dB passage of a target along the track (squinted footprint) and where it leaves the track
    foot = R0 * math.radians(BEAMWIDTH_DEG) / math.cos(math.radians(squint))
    half_full = max(0.0, (VELOCITY * TRACK_S - foot) / 2)  # fully lit within +-half_full of the centre
    edge = VELOCITY * TRACK_S / 2 + foot / 2  # beyond: outside the main beam over the whole track
    n = int(rng.integers(1, 6))
    truth: list[Point] = []
    while len(truth) < n:
        kind = rng.choice(["lit", "pair", "edge", "beyond"], p=[0.45, 0.25, 0.2, 0.1])
        amp = float(rng.uniform(0.3, 1.0))
        if kind == "pair" and truth:
            ref = truth[int(rng.integers(len(truth)))]
            sep, ang = rng.uniform(2, 6), rng.uniform(0, 2 * math.pi)
            az, rg = ref.azimuth + sep * az_cell * math.cos(ang), ref.range + sep * rg_cell * math.sin(ang)
        elif kind == "edge":
            az = float(rng.choice([-1, 1]) * rng.uniform(half_full, edge))
            rg = float(rng.uniform(-30, 30))
        elif kind == "beyond":
            az = float(rng.choice([-1, 1]) * rng.uniform(edge, edge + 25))
            rg = float(rng.uniform(-30, 30))
        else:
            az, rg = float(rng.uniform(-half_full, half_full)), float(rng.uniform(-30, 30))
        truth.append(Point(f"T{len(truth) + 1}", round(az, 3), round(rg, 3), round(amp, 3)))
    ghosts: list[Point] = []
    lo_a, hi_a = min(p.azimuth for p in truth), max(p.azimuth for p in truth)
    lo_r, hi_r = min(p.range for p in truth), max(p.range for p in truth)
    for _ in range(int(rng.integers(0, 3))):
        for _try in range(200):  # anywhere in the truth's extent (+10 cells), off every main lobe
            az = float(rng.uniform(lo_a - 10 * az_cell, hi_a + 10 * az_cell))
            rg = float(rng.uniform(lo_r - 10 * rg_cell, hi_r + 10 * rg_cell))
            near = [math.hypot((az - p.azimuth) / az_cell, (rg - p.range) / rg_cell) for p in truth + ghosts]
            if min(near) > 4:
                break
        level = float(rng.uniform(-50, -40))
        ghosts.append(Point(f"G{len(ghosts) + 1}", round(az, 3), round(rg, 3), 1.0, round(level, 2)))
    return {
        "squint": round(squint, 2),
        "pattern": pattern,
        "window": window,
        "snr_db": round(float(rng.uniform(40, 46)), 1) if noise else None,
        "truth": truth,
        "ghosts": ghosts,
    }


def scene_yaml(d: dict, points: list[Point], noise: bool, waveform: str) -> dict:
    scene = copy.deepcopy(BASE_SCENE)
    scene["effects"]["antenna"]["pattern"] = d["pattern"]
    if noise and d["snr_db"] is not None:
        scene["effects"]["noise"] = {"snr": f"{d['snr_db']} dB"}
    scene["geometry"]["squint"] = f"{d['squint']} deg"
    scene["targets"]["points"] = [
        {"name": p.name, "azimuth": f"{p.azimuth} m", "range": f"{p.range} m", "amplitude": p.amplitude} for p in points
    ]
    scene["simulation"]["waveform"] = waveform
    scene["backproject"] = {
        "frame": "zero_doppler",
        "margin_cells": 28,
        "range_window": d["window"],
        "azimuth_window": d["window"],
    }
    return scene


def lit_fractions(raw: Path) -> dict[str, float]:
    """Each target's lit fraction: the part of its -3 dB passage (platform along-track positions where it
    lies within half the beamwidth of the stripmap boresight, on the track extended both ways) on the track."""
    with h5py.File(raw, "r") as f:
        radar = dict(f["radar"].attrs)
        pos = f["aux/platform_position"][:]
        tab = f["targets"][:]
    centre = np.asarray(radar["scene_center"], float)
    ap = np.array([0.0, 0.0, radar["altitude"]])
    bore = (centre - ap) / np.linalg.norm(centre - ap)
    e_az = np.array([1.0, 0, 0]) - bore[0] * bore
    e_az /= np.linalg.norm(e_az)
    lo, hi = pos[0, 0], pos[-1, 0]
    x = np.linspace(lo - 4 * (hi - lo), hi + 4 * (hi - lo), 40001)
    track = np.stack([x, np.full_like(x, pos[0, 1]), np.full_like(x, pos[0, 2])], axis=1)
    out = {}
    for row in tab:
        u = np.array([row["x"], row["y"], row["z"]]) - track
        u /= np.linalg.norm(u, axis=1, keepdims=True)
        lit = np.abs(np.arcsin(u @ e_az)) <= radar["azimuth_beamwidth"] / 2
        name = row["name"].decode()
        if not lit.any():
            out[name] = 0.0
            continue
        a, b = x[lit].min(), x[lit].max()
        out[name] = max(0.0, min(b, hi) - max(a, lo)) / (b - a)
    return out


def image_targets(path: Path) -> tuple[dict[str, dict[str, float]], dict[str, float]]:
    """(name -> image-frame position, axis -> the image's theoretical IRW) of an image product."""
    with h5py.File(path, "r") as f:
        tab = f["targets"][:]
        dims = [d.decode() if isinstance(d, bytes) else str(d) for d in f["image"].attrs["DIMENSION_LABELS"]]
        irw = dict(zip(dims, (float(v) for v in f["image"].attrs["theoretical_irw"])))
    pos = {r["name"].decode(): {d: float(r[d]) for d in dims} for r in tab}
    return pos, irw


def run_scene(i: int, d: dict, work: Path, waveform: str) -> dict:
    sdir = work / f"scene{i:02d}"
    sdir.mkdir(parents=True, exist_ok=True)
    names = ",".join(p.name for p in d["truth"])
    # truth alone (noise as drawn)
    (sdir / "truth.yaml").write_text(yaml.safe_dump(scene_yaml(d, d["truth"], True, waveform)))
    _, sim_err = cpu_run(["simulate", "truth.yaml", "-o", "raw.h5"], sdir)
    bp_cpu, _ = cpu_run(["backproject", "raw.h5", "--config", "truth.yaml", "-o", "clean.h5"], sdir)
    lit = lit_fractions(sdir / "raw.h5")
    ev_cpu, _ = cpu_run(["evaluate", "clean.h5", "-o", "clean.json"], sdir)
    clean = json.loads((sdir / "clean.json").read_text())
    pos, cells = image_targets(sdir / "clean.h5")
    ref_amp = max(t["peak_amplitude"] for t in clean["targets"])
    out = {"scene": i, **{k: d[k] for k in ("squint", "pattern", "window", "snr_db")}, "clean": clean}
    out.update(lit=lit, cells=cells, truth_pos=pos, bp_cpu=bp_cpu, eval_cpu=ev_cpu)
    out["warned"] = sorted(set(re.findall(r"target '([^']+)' is", sim_err)))
    out["ghosts"] = []
    if d["ghosts"]:
        with h5py.File(sdir / "clean.h5", "r") as f:
            summed = f["image"][:].astype(np.complex128)
        for g in d["ghosts"]:
            zeros = [dataclasses.replace(p, amplitude=0.0) for p in d["truth"]]
            (sdir / f"{g.name}.yaml").write_text(yaml.safe_dump(scene_yaml(d, zeros + [g], False, waveform)))
            cpu_run(["simulate", f"{g.name}.yaml", "-o", f"{g.name}_raw.h5"], sdir)
            cfg = ["--config", f"{g.name}.yaml", "--targets", names, "-o", f"{g.name}.h5"]
            cpu_run(["backproject", f"{g.name}_raw.h5", *cfg], sdir)
            gpos, _ = image_targets(sdir / f"{g.name}.h5")
            with h5py.File(sdir / f"{g.name}.h5", "r") as f:
                resp = f["image"][:].astype(np.complex128)
            if resp.shape != summed.shape:
                raise RuntimeError(f"scene {i}: ghost {g.name} changed the image grid")
            peak = float(np.abs(resp).max())
            summed += 10 ** (g.level_db / 20) * ref_amp / peak * resp  # its strongest pixel at its level
            out["ghosts"].append({"name": g.name, "level_db": g.level_db, "position": gpos[g.name]})
        shutil.copy(sdir / "clean.h5", sdir / "ghosted.h5")
        with h5py.File(sdir / "ghosted.h5", "r+") as f:
            f["image"][...] = summed.astype(np.complex64)
        cpu_run(["evaluate", "ghosted.h5", "-o", "ghosted.json"], sdir)
        out["ghosted"] = json.loads((sdir / "ghosted.json").read_text())
    return out


def _nan(v: float | None) -> float:
    return math.nan if v is None else float(v)


def _db(v: float | None) -> str:
    return "-" if v is None or not math.isfinite(v) else f"{v:.1f}"


def judge(r: dict) -> tuple[list[str], list[str], list[str]]:
    """(per-target rows, per-ghost rows, failure classes found) of one scene's result."""
    clean, cells, failures = r["clean"], r["cells"], []
    trows = []
    for t in clean["targets"]:
        flags = []
        if t["chip_clipped"]:
            flags.append("clipped")
        for a in t["axes"]:
            if a["truncated"]:
                flags.append(f"{a['axis']} truncated")
            if a["contaminated_db"] is not None:
                flags.append(f"{a['axis']} contaminated")
        if t["name"] in (clean.get("residual") or {}).get("misfit_targets", ()):
            flags.append("misfit")
        cols, off = [], []
        for a in t["axes"]:
            dp = None if a["pslr_db"] is None or a["pslr_theory_db"] is None else a["pslr_db"] - a["pslr_theory_db"]
            di = None if a["islr_db"] is None or a["islr_theory_db"] is None else a["islr_db"] - a["islr_theory_db"]
            ratio, cells_off = _nan(a["irw_ratio"]), _nan(a["position_error_cells"])
            cols.append(
                f"{ratio:.3f} / {_db(a['pslr_db'])} ({_db(a['pslr_theory_db'])}) / "
                f"{_db(a['islr_db'])} ({_db(a['islr_theory_db'])}) / {cells_off:+.3f}"
            )
            if not (abs(ratio - 1) <= IRW_TOL and abs(cells_off) <= POS_CELLS):
                off.append(f"{a['axis']} IRW/pos")
            if (dp is not None and abs(dp) > SIDE_DB) or (di is not None and abs(di) > SIDE_DB):
                off.append(f"{a['axis']} side lobes")
        lit = r["lit"].get(t["name"], 1.0)
        if off and not flags and lit >= LIT_FULL:
            failures.append("off own theory")
        trows.append(
            f"| {r['scene']} | {t['name']} | {lit:.2f} | " + " | ".join(cols) + f" | {', '.join(flags + off) or '-'} |"
        )
    # illumination warnings
    for name, frac in r["lit"].items():
        warned = name in r["warned"]
        if (frac < LIT_WARN and not warned) or (frac > LIT_FULL and warned):
            failures.append("illumination warning")
    # clean floor / false target
    res, ft = clean.get("residual"), clean.get("false_target")
    noisy = r["snr_db"] is not None
    if not noisy and res is not None and res["floor_db"] > FLOOR_DB:
        failures.append("floor above -50 dB")
    if ft is not None and ft["level_db"] > (NOISE_FT_DB if noisy else FLOOR_DB):
        failures.append("false target invented")
    listed = (clean.get("false_targets") or {}).get("entries", [])
    if listed:
        failures.append("false target listed in a clean image")
    grows = []
    if r["ghosts"]:
        ghosted = r["ghosted"]
        entries = (ghosted.get("false_targets") or {}).get("entries")
        if entries is None:  # a report without the list (older code): its single figure only
            entries = [ghosted["false_target"]] if ghosted["false_target"] else []
        floor = (ghosted.get("residual") or {}).get("floor_db")
        matched: set[int] = set()
        for g in sorted(r["ghosts"], key=lambda g: -g["level_db"]):
            best: int | None = None
            err: dict[str, float] = {}
            for k, e in enumerate(entries):
                gap = {d: (e["position"][d] - v) / cells[d] for d, v in g["position"].items()}
                near = k not in matched and all(abs(o) <= PLACE_CELLS for o in gap.values())
                if near and (best is None or math.hypot(*gap.values()) < math.hypot(*err.values())):
                    best, err = k, gap
            level = None if best is None else entries[best]["pixel_level_db"]
            if best is not None:
                matched.add(best)
            if level is not None and abs(level - g["level_db"]) <= LEVEL_DB:
                verdict = "found"
            elif level is not None:
                verdict = "mis-levelled"
            elif floor is not None and g["level_db"] <= floor + LIST_MARGIN_DB:
                verdict = "missed (under the floor)"
            else:
                verdict = "missed"
            if verdict != "found":
                failures.append(f"ghost {verdict}")
            grows.append(
                f"| {r['scene']} | {g['name']} | {g['level_db']:.2f} | {_db(level)} | "
                + (", ".join(f"{k} {e:+.2f}" for k, e in err.items()) or "-")
                + f" | {_db(floor)} | {verdict} |"
            )
        unmatched = len(entries) - len(matched)
        if unmatched:
            failures.append("listed false target where no ghost was put")
    return trows, grows, failures


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", type=int, default=30)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--out", type=Path, default=Path("results/evaluate-campaign"))
    ap.add_argument("--waveform", default="band_limited", help="simulation.waveform (continuous: the chirp's pedestal)")
    ap.add_argument("--only", type=int, nargs="*", default=None, help="run only these scene numbers")
    ap.add_argument(
        "--compare", type=Path, default=None, help="a run of older code (its --out): tabulate both, run nothing"
    )
    ap.add_argument(
        "--reevaluate",
        type=Path,
        default=None,
        help="a finished run (its --out): evaluate its kept images again (clean.h5, ghosted.h5) with the sarproc "
        "on this PYTHONPATH, tabulate into --out; nothing simulated or backprojected",
    )
    args = ap.parse_args(argv)
    if args.reevaluate is not None:
        reevaluate(args)
        return
    if args.compare is not None:
        before = json.loads((args.compare / "results.json").read_text())
        after = json.loads((args.out / "results.json").read_text())
        (args.out / "compare.md").write_text(compare(before, after, args))
        print((args.out / "compare.md").read_text())
        return
    args.out.mkdir(parents=True, exist_ok=True)
    work = args.out / "work"
    results = []
    for i in range(args.scenes):
        d = draw_scene(np.random.default_rng([args.seed, i]))
        if args.only is not None and i not in args.only:
            continue
        try:
            r = run_scene(i, d, work, args.waveform)
        except RuntimeError as e:
            results.append({"scene": i, "crash": str(e)})
            print(f"scene {i}: crash {str(e).splitlines()[0]}", flush=True)
            continue
        r["draw"] = {**d, "truth": [dataclasses.asdict(p) for p in d["truth"]]}
        r["draw"]["ghosts"] = [dataclasses.asdict(p) for p in d["ghosts"]]
        results.append(r)
        print(f"scene {i}: {judge(r)[2] or 'ok'}", flush=True)
        (args.out / "results.json").write_text(json.dumps(results, indent=1))  # a stopped run keeps its scenes
        publish(results, args)
    (args.out / "results.json").write_text(json.dumps(results, indent=1))
    publish(results, args)


def reevaluate(args: argparse.Namespace) -> None:
    """Every scene of the run in ``args.reevaluate`` with its images evaluated again (evaluate's CPU too)."""
    results = json.loads((args.reevaluate / "results.json").read_text())
    args.out.mkdir(parents=True, exist_ok=True)
    for r in results:
        if "crash" in r:
            continue
        sdir = (args.reevaluate / "work" / f"scene{r['scene']:02d}").resolve()
        for image, key in (("clean", "clean"), ("ghosted", "ghosted")):
            if key not in r:
                continue
            report = args.out.resolve() / f"scene{r['scene']:02d}_{image}.json"
            cpu, _ = cpu_run(["evaluate", str(sdir / f"{image}.h5"), "-o", str(report)], sdir)
            r[key] = json.loads(report.read_text())
            if key == "clean":
                r["eval_cpu"] = cpu
        print(f"scene {r['scene']}: {judge(r)[2] or 'ok'}", flush=True)
    (args.out / "results.json").write_text(json.dumps(results, indent=1))
    publish(results, args)


def _scene_figures(r: dict) -> tuple[str, int, int, list[str]]:
    """(residual floor, targets judged off their own theory (lit, no flag), residual misfits, failures)."""
    if "crash" in r:
        return "crash", 0, 0, ["crash"]
    trows, _, failures = judge(r)
    res = r["clean"].get("residual") or {}
    off = sum(1 for row in trows if "IRW/pos" in row or "side lobes" in row)
    return _db(res.get("floor_db")), off, len(res.get("misfit_targets", ())), sorted(set(failures))


def compare(before: list[dict], after: list[dict], args: argparse.Namespace) -> str:
    """Per scene, the older run's figures against this one's (same seed, same scenes), and both summaries."""
    rows = [
        f"Same scenes (seed {args.seed}): before = the run in {args.compare}, after = {args.out}.",
        "",
        "| scene | residual floor (dB) before / after | targets off own theory before / after | residual misfits "
        "before / after | failures before | failures after |",
        "|---:|---|---|---|---|---|",
    ]
    count: dict[str, list[int]] = {"before": [0, 0], "after": [0, 0]}
    classes: dict[str, dict[str, int]] = {}
    for b, a in zip(before, after):
        fb, fa = _scene_figures(b), _scene_figures(a)
        for tag, f in (("before", fb), ("after", fa)):
            count[tag][0] += f[1]
            count[tag][1] += f[2]
            for c in f[3]:
                classes.setdefault(c, {"before": 0, "after": 0})[tag] += 1
        rows.append(
            f"| {a['scene']} | {fb[0]} / {fa[0]} | {fb[1]} / {fa[1]} | {fb[2]} / {fa[2]} | "
            f"{', '.join(fb[3]) or '-'} | {', '.join(fa[3]) or '-'} |"
        )
    rows += ["", "| failure class | scenes before | scenes after |", "|---|---:|---:|"]
    rows += [f"| {c} | {v['before']} | {v['after']} |" for c, v in sorted(classes.items())]
    rows.append(
        f"| targets off own theory (all scenes) | {count['before'][0]} | {count['after'][0]} |\n"
        f"| residual misfits (all scenes) | {count['before'][1]} | {count['after'][1]} |"
    )
    return "\n".join(rows) + "\n"


def publish(results: list[dict], args: argparse.Namespace) -> None:
    scenes = [
        "| scene | squint (deg) | pattern | window | SNR (dB) | truth | ghosts | warned | residual floor (dB) | "
        "false target, clean (dB) | evaluate / backproject CPU (s) | failures |",
        "|---:|---:|---|---|---:|---|---|---|---:|---:|---|---|",
    ]
    targets = [
        "| scene | target | lit fraction | "
        "azimuth: IRW/theory / PSLR (theory) / ISLR (theory) / error (cells) | range: same | flags |",
        "|---:|---|---:|---|---|---|",
    ]
    ghosts = [
        "| scene | ghost | injected (dB) | found (dB) | error (cells) | residual floor (dB) | verdict |",
        "|---:|---|---:|---:|---|---:|---|",
    ]
    classes: dict[str, list[int]] = {}
    ratios = []
    for r in results:
        if "crash" in r:
            classes.setdefault("crash", []).append(r["scene"])
            scenes.append(f"| {r['scene']} | | | | | | | | | | | crash: {r['crash'].splitlines()[0]} |")
            continue
        trows, grows, failures = judge(r)
        targets += trows
        ghosts += grows
        for f in sorted(set(failures)):
            classes.setdefault(f, []).append(r["scene"])
        dr = r["draw"]
        truth = ", ".join(f"{p['name']} ({p['azimuth']:.1f}, {p['range']:.1f})" for p in dr["truth"])
        gs = ", ".join(f"{g['name']} ({g['azimuth']:.1f}, {g['range']:.1f})" for g in dr["ghosts"]) or "-"
        res, ft = r["clean"].get("residual"), r["clean"].get("false_target")
        ratios.append(r["eval_cpu"] / r["bp_cpu"])
        scenes.append(
            f"| {r['scene']} | {r['squint']:.1f} | {r['pattern']} | {r['window']} | {r['snr_db'] or 'off'} | {truth} | "
            f"{gs} | {', '.join(r['warned']) or '-'} | {_db(res and res['floor_db'])} | {_db(ft and ft['level_db'])} | "
            f"{r['eval_cpu']:.2f} / {r['bp_cpu']:.2f} | {', '.join(sorted(set(failures))) or '-'} |"
        )
    n = len(results)
    summary = (
        f"Summary: {n} scenes (seed {args.seed}, waveform {args.waveform}): "
        + (", ".join(f"{k}: {len(v)} ({', '.join(map(str, v))})" for k, v in sorted(classes.items())) or "no failure")
        + (f"; evaluate / backproject CPU median {np.median(ratios):.2f}, max {max(ratios):.2f}" if ratios else "")
    )
    text = "\n".join(
        [
            f"# evaluate campaign: `python scripts/evaluate_campaign.py --scenes {args.scenes} --seed {args.seed}`",
            "",
            summary,
            "",
            "Positions: (azimuth, range) m from the scene centre, zero-Doppler frame. Ghost levels: the ghost's "
            "strongest pixel against the strongest truth target's refined peak (evaluate's pixel level).",
            "",
            *scenes,
            "",
            *targets,
            "",
            *ghosts,
            "",
        ]
    )
    (args.out / "campaign.md").write_text(text)
    print(summary)
    os.sync()


if __name__ == "__main__":
    main()
