#!/usr/bin/env python3
"""Stage benchmark, interleaved in one run: time, one-2D-FFT equivalents, peak RSS, CPU/wall, FastSAR side by side.

    python scripts/bench.py [--rounds 3] [--bp-rounds 5] [--stages bp,gotcha,exp2,array3d]
                            [--fastsar-python .venv-bench/bin/python] [--out results/bench]

Every round runs, for each stage, one complex64 2D FFT of an array shaped like the stage's input (scipy.fft,
all cores) and then the stage itself, so a stage and its FFT yardstick see the same machine load; each is
the best of its rounds. Per stage:

- time (s) and time / one 2D FFT of its input ("FFT equivalents");
- peak RSS over input + output: (input bytes + rise of the process's peak resident set during the stage,
  reset before it through /proc/self/clear_refs) / (input + output bytes); a backprojection's input is its
  range-compressed pulses and its pixel positions (float64 x, y, z), its output the complex64 image;
- CPU/wall: user + system time of all threads over wall time (2.0 = both cores busy throughout).

Backprojection (bench scene: 600 pulses, 512 x 512 ground grid at 0.3 m; Gotcha pass 1 HH 0-4 deg when
../shared/data/gotcha exists: 469 pulses, 512 x 512 at 0.15 m: 424 frequencies 1.5 MHz apart leave 100 m
of unambiguous range, which a 0.2 m grid's corners exceed at Gotcha's elevation, so processors that wrap
range profiles differently disagree there): our float64 reference engine, the compiled
engine (linear and cubic on the x8 pulse; Knab, 8 taps, on the x2 pulse) and FastSAR's exact former (linear and cubic,
x8; run by scripts/bench_fastsar.py in the bench-only venv, its own call time) on the same pulses and grid.
Agreement: 20 log10(|a - ref| / |ref|) over the image against the float64 reference engine (FastSAR after
a least-squares complex scale: its normalisation differs), and against a x32 float64 reference ("truth").
Results go to OUT/latest.json and OUT/bench-<UTC time>.json; a previous latest.json is shown beside.
"""

from __future__ import annotations

import argparse
import ctypes
import datetime
import gc
import inspect
import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import scipy.fft as sfft

from sarproc.product.budget import fft_seconds

ROOT = Path(__file__).resolve().parents[1]
C = 299_792_458.0


# ---- measurement --------------------------------------------------------------------------------------------
def _status_kib(key: str) -> int:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith(key + ":"):
            return int(line.split()[1])
    return 0


def measure(fn):
    """(result, wall s, cpu/wall, peak RSS rise in bytes) of fn()."""
    gc.collect()
    try:  # hand freed heap memory back first: glibc keeps it resident, and a later stage reusing it reads no rise
        ctypes.CDLL("libc.so.6").malloc_trim(0)
    except (OSError, AttributeError):
        pass
    try:
        Path("/proc/self/clear_refs").write_text("5")  # reset the peak RSS (VmHWM) to the current RSS
    except OSError:
        pass
    rss0 = _status_kib("VmRSS")
    ru0 = resource.getrusage(resource.RUSAGE_SELF)
    t0 = time.perf_counter()
    out = fn()
    wall = time.perf_counter() - t0
    ru1 = resource.getrusage(resource.RUSAGE_SELF)
    cpu = (ru1.ru_utime - ru0.ru_utime) + (ru1.ru_stime - ru0.ru_stime)
    rise = max(_status_kib("VmHWM") - rss0, 0) * 1024
    return out, wall, cpu / wall, rise


class Stage:
    """One timed stage: best time over rounds, its FFT yardstick, peak RSS ratio, CPU/wall of the best run."""

    def __init__(self, name, fn, in_shape, in_bytes, detail=""):
        self.name, self.fn, self.in_shape, self.in_bytes, self.detail = name, fn, tuple(in_shape), in_bytes, detail
        self.time = self.fft = np.inf
        self.cpu = self.rss = None
        self.out = None
        self.extra = {}

    def run(self):
        self.fft = min(self.fft, fft_seconds(self.in_shape, repeats=1))
        out, wall, cpu, rise = measure(self.fn)
        out_bytes = sum(np.asarray(o).nbytes for o in (out if isinstance(out, tuple) else (out,)))
        ratio = (self.in_bytes + rise) / (self.in_bytes + out_bytes)
        self.rss = ratio if self.rss is None else min(self.rss, ratio)
        if wall < self.time:
            self.time, self.cpu = wall, cpu
        self.out = out

    def row(self):
        return {
            "stage": self.name,
            "detail": self.detail,
            "time_s": self.time,
            "fft_s": self.fft,
            "fft_equivalents": self.time / self.fft,
            "peak_rss_over_in_out": self.rss,
            "cpu_per_wall": self.cpu,
            **self.extra,
        }


# ---- backprojection cases -----------------------------------------------------------------------------------
def agreement_db(img, ref, fit=False):
    img, ref = np.asarray(img, complex).ravel(), np.asarray(ref, complex).ravel()
    if fit:
        img = img * (np.vdot(img, ref) / np.vdot(img, img))
    return float(20 * np.log10(np.linalg.norm(img - ref) / np.linalg.norm(ref)))


def plane_grid(centre, e1, e2, n, spacing):
    """FastSAR's grid: x_i = (i - n/2) spacing along e1, y_j likewise along e2, about ``centre``; (n*n, 3)."""
    a = (np.arange(n) - n / 2) * spacing
    return (
        np.asarray(centre)[None, None, :] + a[:, None, None] * np.asarray(e1) + a[None, :, None] * np.asarray(e2)
    ).reshape(-1, 3)


def history_from_pulses(rc, range_time, gate, pos, centre, fc, fs):
    """Range-compressed pulses -> FastSAR's phase history S(f) = exp(-j 4 pi f (R - ref) / c), ascending f.

    The DFT of pulse p, whose sample n lies at delay t_p + n / f_s (t_p = range_time[0] + gate_p), holds the
    echo's spectrum times exp(j 2 pi f_b t_p); the echo of a point at R is exp(-j 2 pi (f_c + f_b) 2R / c);
    referring it to ref_p = |antenna - centre| gives FastSAR's form."""
    n = rc.shape[1]
    f_b = sfft.fftfreq(n, 1.0 / fs)
    t_p = range_time[0] + gate
    ref = np.linalg.norm(pos - centre, axis=1)
    cyc = -f_b[None, :] * t_p[:, None] + 2 * (fc + f_b[None, :]) * ref[:, None] / C
    S = sfft.fft(rc.astype(np.complex128), axis=1) * np.exp(2j * np.pi * np.mod(cyc, 1.0))
    S = sfft.fftshift(S, axes=1).astype(np.complex64)
    return S, ref, fc + sfft.fftshift(f_b)[0], fs / n


def bench_scene_case():
    from sarproc.dsp.rangecomp import range_compress
    from sarproc.simulation.scene import scene_from_mapping
    from sarproc.simulation.simulate import simulate

    pts = [{"name": f"T{i}", "azimuth": f"{(i % 5 - 2) * 20} m", "range": f"{(i // 5 - 2) * 20} m"} for i in range(25)]
    mapping = {
        "radar": {
            "carrier_frequency": "10 GHz",
            "bandwidth": "150 MHz",
            "pulse_duration": "5 us",
            "range_sampling_rate": "180 MHz",
            "prf": "600 Hz",
        },
        "platform": {"velocity": "150 m/s", "altitude": "3 km"},
        "geometry": {"reference_range": "10 km", "squint": "20 deg"},
        "acquisition": {"mode": "spotlight", "aperture_time": "1.0 s"},
        "targets": {"frame": "los", "points": pts},
    }
    raw = simulate(scene_from_mapping(mapping, "bench"))
    rc = range_compress(raw.data, raw.radar)
    pos = raw.aux["platform_position"]
    centre = np.asarray(raw.radar.scene_center, float)
    vel = pos[-1] - pos[0]
    e1 = vel / np.linalg.norm(vel)
    e2 = np.cross([0.0, 0.0, 1.0], e1)  # horizontal, across track
    gate = raw.aux.get("range_gate_offset", np.zeros(len(pos)))
    return {
        "name": "bench scene",
        "rc": rc,
        "range_time": raw.coords["range_time"],
        "gate": gate,
        "pos": pos,
        "fc": raw.radar.carrier_frequency,
        "fs": raw.radar.range_sampling_rate,
        "bandwidth": raw.radar.bandwidth,
        "centre": centre,
        "e1": e1,
        "e2": e2,
        "n": 512,
        "spacing": 0.3,
        "history": None,
    }


def gotcha_case():
    from sarproc.formats.gotcha import gotcha_product, read_gotcha

    files = sorted((ROOT.parent / "shared" / "data" / "gotcha").glob("data_3dsar_pass1_az00*_HH.mat"))
    if not files:
        return None
    g = read_gotcha(files)
    raw = gotcha_product(g)
    S = g.phase_history
    freq = np.asarray(g.freq, float)
    if freq[1] < freq[0]:
        S, freq = S[:, ::-1], freq[::-1]
    history = (
        np.ascontiguousarray(S, np.complex64),
        np.asarray(g.r0, float),
        float(freq[0]),
        float(freq[1] - freq[0]),
    )
    return {
        "name": "Gotcha",
        "rc": raw.data,
        "range_time": raw.coords["range_time"],
        "gate": raw.aux["range_gate_offset"],
        "pos": raw.aux["platform_position"],
        "fc": raw.radar.carrier_frequency,
        "fs": raw.radar.range_sampling_rate,
        "bandwidth": raw.radar.bandwidth,
        "centre": np.zeros(3),
        "e1": np.array([1.0, 0, 0]),
        "e2": np.array([0, 1.0, 0]),
        "n": 512,
        "spacing": 0.15,
        "history": history,
    }


def bp_stages(case):
    from sarproc.focus.backprojection import backproject_points

    n, pos = case["n"], case["pos"]
    pts = plane_grid(case["centre"], case["e1"], case["e2"], n, case["spacing"])
    args = (case["rc"], case["range_time"], pos, pos, pts, case["fc"])
    kw = {"gate_offset": case["gate"]}
    over = case["fs"] / case["bandwidth"]
    engines = [
        ("reference", {"engine": "reference"}),
        ("compiled linear x8", {"engine": "compiled"}),
        ("compiled cubic x8", {"engine": "compiled", "interpolation": "cubic"}),
        ("compiled knab8 x2", {"engine": "compiled", "interpolation": "knab", "upsample": 2, "oversampling": 2 * over}),
    ]
    if "engine" not in inspect.signature(backproject_points).parameters:  # an older sarproc (--stages before)
        engines = [("reference", {})]
    stages = []
    for label, opts in engines:
        fn = lambda o=opts: backproject_points(*args, **kw, **o).reshape(n, n).astype(np.complex64)
        st = Stage(
            f"backproject {label}",
            fn,
            case["rc"].shape,
            case["rc"].nbytes + pts.nbytes,
            f"{case['name']}: {len(pos)} pulses x {case['rc'].shape[1]} -> {n} x {n}",
        )
        st.pixel_pulses = n * n * len(pos)
        stages.append(st)
    truth = backproject_points(*args, **kw, **engines[0][1], upsample=32).reshape(n, n)
    return stages, truth


def fastsar_run(case, python, workdir, calls=2):
    """One FastSAR call set in the bench venv: {interp: (time, image)} or None with a reason."""
    if case["history"] is None:
        S, ref, fmin, df = history_from_pulses(
            case["rc"], case["range_time"], case["gate"], case["pos"], case["centre"], case["fc"], case["fs"]
        )
        ant = case["pos"] - case["centre"]
    else:
        S, ref, fmin, df = case["history"]
        ant = case["pos"] - case["centre"]
    path = Path(workdir) / "case.npz"
    if not path.exists():
        np.savez(
            path,
            S=S,
            ant=ant,
            ref=ref,
            fmin=fmin,
            df=df,
            nx=case["n"],
            ny=case["n"],
            spx=case["spacing"],
            spy=case["spacing"],
            e1=case["e1"],
            e2=case["e2"],
            center=np.zeros(3),
        )
    out = Path(workdir) / "images.npz"
    res = subprocess.run(
        [python, str(ROOT / "scripts" / "bench_fastsar.py"), str(path), str(out), "--calls", str(calls)],
        capture_output=True,
        text=True,
    )
    if res.returncode != 0:
        return None, res.stderr.strip().splitlines()[-1] if res.stderr.strip() else f"exit {res.returncode}"
    info = json.loads(res.stdout.strip().splitlines()[-1])
    imgs = np.load(out)
    return {k: (info[k]["time_s"], imgs[k], info[k]) for k in ("linear", "cubic")}, info.get("version")


# ---- paper 000 (exp. 2, full size) and paper 004 stages ----------------------------------------------------
def exp2_stages():
    from sarproc.focus.squint_deramp.coarse_focus import CoarseFocusParams, coarse_focus
    from sarproc.focus.squint_deramp.fine_focus import FineFocusParams, fine_focus
    from sarproc.focus.squint_deramp.preprocess import PreprocessParams, preprocess
    from sarproc.product.config import build, load_yaml
    from sarproc.simulation.scene import scene_from_mapping
    from sarproc.simulation.simulate import simulate

    m = load_yaml(ROOT / "configs" / "an2012_exp2.yaml")
    sec = {k: m.pop(k, {}) or {} for k in ("preprocess", "coarse_focus", "fine_focus")}
    sec["fine_focus"] = {**sec["fine_focus"], "flow": 2, "output_frame": "squint"}
    pp = build(PreprocessParams, sec["preprocess"], "an2012_exp2.yaml", "preprocess")
    cp = build(CoarseFocusParams, sec["coarse_focus"], "an2012_exp2.yaml", "coarse_focus")
    fp = build(FineFocusParams, sec["fine_focus"], "an2012_exp2.yaml", "fine_focus")
    raw = simulate(scene_from_mapping(m, "an2012_exp2.yaml"))
    pre = preprocess(raw, pp)
    coarse = coarse_focus(pre, cp)
    detail = "exp. 2 full size"
    return [
        Stage("preprocess", lambda: preprocess(raw, pp).data, raw.data.shape, raw.data.nbytes, detail),
        Stage("coarse-focus", lambda: coarse_focus(pre, cp).data, pre.data.shape, pre.data.nbytes, detail),
        Stage("fine-focus", lambda: fine_focus(coarse, fp).data, coarse.data.shape, coarse.data.nbytes, detail),
    ]


def array3d_stages():
    from sarproc.focus.array3d.linear_array import Array3DParams, array3d_product
    from sarproc.product.config import build, load_yaml
    from sarproc.simulation.scene import scene_from_mapping
    from sarproc.simulation.simulate import simulate

    m = load_yaml(ROOT / "configs" / "du2010.yaml")
    section = m.pop("array3d", {}) or {}
    params = build(Array3DParams, section, "du2010.yaml", "array3d")
    raw = simulate(scene_from_mapping(m, "du2010.yaml"))
    return [
        Stage(
            "array3d",
            lambda: array3d_product(raw, params)[0].data,
            raw.data.shape,
            raw.data.nbytes,
            "du2010 (paper 004)",
        )
    ]


def simulate_stages():
    """simulate on the exp. 2 scene (paper 000) and the reduced Table 1 scene (paper 002): echo samples/s."""
    from sarproc.product.config import load_yaml
    from sarproc.simulation.scene import scene_from_mapping
    from sarproc.simulation.simulate import plan_simulation, simulate

    stages = []
    for name in ("an2012_exp2.yaml", "nie2016_small.yaml"):
        m = load_yaml(ROOT / "configs" / name)
        scene = scene_from_mapping(m, name)
        plan = plan_simulation(scene)
        r = scene.radar
        samples = (
            plan.shape[-2]
            * len(plan.rx_offsets)
            * len(scene.target_amplitude)
            * r.pulse_duration
            * r.range_sampling_rate
        )
        st = Stage("simulate", lambda scene=scene: simulate(scene).data, plan.shape, 0, name.removesuffix(".yaml"))
        st.echo_samples = samples
        stages.append(st)
    return stages


# ---- report -------------------------------------------------------------------------------------------------
def fmt_table(rows, previous):
    prev = {r["stage"] + "|" + r.get("detail", ""): r for r in (previous or {}).get("stages", [])}
    lines = [
        "| stage | data | time (s) | FFT equivalents | peak RSS / (in+out) | CPU/wall | rate | agreement (dB) "
        "| previous time (s) |",
        "|---|---|---:|---:|---:|---:|---|---|---:|",
    ]
    for r in rows:
        p = prev.get(r["stage"] + "|" + r.get("detail", ""))
        rate = f"{r['rate'] / 1e6:.0f} M px-pulse/s" if "rate" in r else ""
        agr = ""
        if "truth_db" in r:
            a = "reference" if r["agreement_db"] is None else f"{r['agreement_db']:.1f} vs ref"
            agr = f"{a}, {r['truth_db']:.1f} vs x32"
        rss = f"{r['peak_rss_over_in_out']:.2f}" if r.get("peak_rss_over_in_out") is not None else "-"
        cpu = f"{r['cpu_per_wall']:.2f}" if r.get("cpu_per_wall") is not None else "-"
        fe = f"{r['fft_equivalents']:.1f}" if np.isfinite(r.get("fft_equivalents", np.nan)) else "-"
        lines.append(
            f"| {r['stage']} | {r.get('detail', '')} | {r['time_s']:.3f} | {fe} | {rss} | {cpu} | {rate} | "
            f"{agr} | {p['time_s']:.3f} |"
            if p
            else f"| {r['stage']} | {r.get('detail', '')} | {r['time_s']:.3f} | {fe} | {rss} | {cpu} | {rate} | "
            f"{agr} | |"
        )
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rounds", type=int, default=3, help="rounds of the heavy stages (best of)")
    ap.add_argument("--bp-rounds", type=int, default=5, help="rounds of the backprojection stages (best of)")
    ap.add_argument("--stages", default="bp,gotcha,exp2,array3d,simulate")
    ap.add_argument("--fastsar-python", default=str(ROOT / ".venv-bench" / "bin" / "python"))
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "bench")
    args = ap.parse_args(argv)
    want = set(args.stages.split(","))
    previous = None
    if (args.out / "latest.json").exists():
        previous = json.loads((args.out / "latest.json").read_text())
    rows, notes = [], []

    cases = []
    if "bp" in want:
        cases.append(bench_scene_case())
    if "gotcha" in want:
        try:
            g = gotcha_case()
        except ImportError:  # an older sarproc without the Gotcha importer
            g = None
        if g is None:
            notes.append("Gotcha: ../shared/data/gotcha not found, skipped")
        else:
            cases.append(g)
    have_fastsar = Path(args.fastsar_python).exists()
    if cases and not have_fastsar:
        notes.append(f"FastSAR: {args.fastsar_python} missing (make bench-venv), skipped")
    for case in cases:
        stages, truth = bp_stages(case)
        fast = {"linear": [np.inf, None, None], "cubic": [np.inf, None, None]}
        version = None
        with tempfile.TemporaryDirectory() as tmp:
            for r in range(args.bp_rounds):
                for st in stages:
                    st.run()
                if have_fastsar:
                    res, version = fastsar_run(case, args.fastsar_python, tmp)
                    if res is None:
                        notes.append(f"FastSAR failed on {case['name']}: {version}")
                        have_fastsar = False
                        continue
                    for k, (t, img, info) in res.items():
                        if t < fast[k][0]:
                            fast[k] = [t, img, info]
                print(f"  {case['name']}: round {r + 1}/{args.bp_rounds} done", file=sys.stderr)
        ref = stages[0].out
        for st in stages:
            row = st.row()
            row.update(
                rate=st.pixel_pulses / st.time,
                agreement_db=agreement_db(st.out, ref) if st is not stages[0] else None,
                truth_db=agreement_db(st.out, truth),
            )
            rows.append(row)
        for k, (t, img, info) in fast.items():
            if img is None:
                continue
            rows.append(
                {
                    "stage": f"FastSAR {version} exact {k} x8",
                    "detail": stages[0].detail,
                    "time_s": t,
                    "fft_s": stages[0].fft,
                    "fft_equivalents": t / stages[0].fft,
                    "peak_rss_over_in_out": None,
                    "cpu_per_wall": None,
                    "rate": stages[0].pixel_pulses / t,
                    "agreement_db": agreement_db(img, ref, fit=True),
                    "truth_db": agreement_db(img, truth, fit=True),
                    "fastsar_tile": info["tile"],
                    "fastsar_predicted_error_db": info["predicted_error_db"],
                }
            )
        if len(stages) < 2:
            continue
        for kind in ("linear", "cubic"):
            peer = next(
                (
                    r
                    for r in rows
                    if r["stage"].startswith("FastSAR") and kind in r["stage"] and r["detail"] == stages[0].detail
                ),
                None,
            )
            comp = next(
                (
                    r
                    for r in rows
                    if r["stage"] == f"backproject compiled {kind} x8" and r["detail"] == stages[0].detail
                ),
                None,
            )
            if peer is not None and comp is not None:
                notes.append(
                    f"{case['name']}: compiled {kind} x8 at {comp['rate'] / peer['rate']:.2f} x FastSAR's "
                    f"exact {kind} rate, {comp['agreement_db']:.1f} dB from the float64 reference and "
                    f"{comp['truth_db']:.1f} dB from the x32 one (FastSAR {peer['agreement_db']:.1f} / "
                    f"{peer['truth_db']:.1f} dB)"
                )
        print(fmt_table(rows, previous), file=sys.stderr)

    heavy = []
    for key, make in (("exp2", exp2_stages), ("array3d", array3d_stages), ("simulate", simulate_stages)):
        if key in want:
            try:
                heavy += make()
            except Exception as exc:  # e.g. an older sarproc that rejects a newer config key
                notes.append(f"{key}: not run ({type(exc).__name__}: {exc})")
    for r in range(args.rounds):
        for st in heavy:
            st.run()
            print(f"  {st.name}: round {r + 1}/{args.rounds} {st.time:.2f} s", file=sys.stderr)
    for st in heavy:
        row = st.row()
        if hasattr(st, "echo_samples"):
            row["echo_rate"] = st.echo_samples / st.time
            notes.append(
                f"simulate {st.detail}: {st.echo_samples / st.time / 1e6:.0f} M echo samples/s "
                f"(pulses x channels x targets x T_p f_s), {st.time / st.fft:.2f} one-FFT units of its output"
            )
        rows.append(row)

    stamp = datetime.datetime.now(datetime.timezone.utc).strftime("%Y%m%dT%H%M%SZ")
    text = "\n".join([f"# sarproc bench {stamp}", "", fmt_table(rows, previous), ""] + [f"- {n}" for n in notes])
    print(text)
    args.out.mkdir(parents=True, exist_ok=True)
    doc = {
        "utc": stamp,
        "rounds": args.rounds,
        "bp_rounds": args.bp_rounds,
        "stages": rows,
        "notes": notes,
        "peak_rss_process_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
    }
    blob = json.dumps(doc, indent=1, default=lambda o: None if not np.isfinite(o) else float(o))
    (args.out / f"bench-{stamp}.json").write_text(blob)
    (args.out / "latest.json").write_text(blob)
    (args.out / "latest.md").write_text(text + "\n")


if __name__ == "__main__":
    main()
