#!/usr/bin/env python3
"""Stage benchmark, interleaved in one run: time, one-2D-FFT equivalents, peak RSS, CPU/wall, FastSAR side by side.

    python scripts/bench.py [--rounds 3] [--bp-rounds 5] [--stages bp,gotcha,exp2,array3d,simulate,process]
                            [--fastsar-python .venv-bench/bin/python] [--out results/bench] [--baseline DIR]
    python scripts/bench.py ffbp [--sizes 512 1024 2048] [--repeats 3] [--json OUT] [--fastsar-python PY]

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
Per-process overhead ("process" rows, a table of their own): every stage as one `sarproc STAGE` process on a
small product (demo scene, reduced scenes of papers 000, 002, 003, 004): the process's wall time, the same
command's second run inside one process (its compute: reading, work, writing) and the difference, the overhead
(interpreter, imports, loading compiled kernels). --baseline DIR (an older checkout, e.g.
`git archive COMMIT | tar -x -C DIR`) runs the same commands from it too, interleaved round by round.
Results go to OUT/latest.json and OUT/bench-<UTC time>.json; a previous latest.json is shown beside.
"""

from __future__ import annotations

import argparse
import contextlib
import ctypes
import datetime
import functools
import gc
import inspect
import json
import math
import os
import resource
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from numpy.typing import ArrayLike

# The wait policy the sarproc command sets for the compiled kernels' threads (sarproc.cli.main.THREAD_DEFAULTS):
# this script calls the library, so it sets the policy itself, before numba starts.
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

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


def measure(fn: Callable[[], Any]) -> tuple[Any, float, float, int]:
    """(result, wall s, cpu/wall, peak RSS rise in bytes) of fn()."""
    gc.collect()
    # hand freed heap memory back first: glibc keeps it resident, and a later stage reusing it reads no rise
    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL("libc.so.6").malloc_trim(0)
    with contextlib.suppress(OSError):
        Path("/proc/self/clear_refs").write_text("5")  # reset the peak RSS (VmHWM) to the current RSS
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

    pixel_pulses: int  # set on backprojection stages only
    echo_samples: float  # set on simulate stages only (main tests hasattr)

    def __init__(
        self, name: str, fn: Callable[..., Any], in_shape: Sequence[int], in_bytes: int, detail: str = ""
    ) -> None:
        self.name, self.fn, self.in_shape, self.in_bytes, self.detail = name, fn, tuple(in_shape), in_bytes, detail
        self.time = self.fft = np.inf
        self.cpu: float | None = None
        self.rss: float | None = None
        self.out: Any = None
        self.extra: dict = {}

    def run(self) -> None:
        self.fft = min(self.fft, fft_seconds(self.in_shape, repeats=1))
        out, wall, cpu, rise = measure(self.fn)
        out_bytes = sum(np.asarray(o).nbytes for o in (out if isinstance(out, tuple) else (out,)))
        ratio = (self.in_bytes + rise) / (self.in_bytes + out_bytes)
        self.rss = ratio if self.rss is None else min(self.rss, ratio)
        if wall < self.time:
            self.time, self.cpu = wall, cpu
        self.out = out

    def row(self) -> dict:
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
def error_db(img: ArrayLike, ref: ArrayLike, fit: bool = False) -> float:
    """10 log10(|img - ref|^2 / |ref|^2) over the image, summed in complex128; fit: img scaled by the
    least-squares complex factor first (FastSAR's normalisation differs from ours)."""
    img, ref = np.asarray(img, complex).ravel(), np.asarray(ref, complex).ravel()
    if fit:
        img = img * (np.vdot(img, ref) / np.vdot(img, img))
    return _db(float(np.sum(np.abs(img - ref) ** 2) / np.sum(np.abs(ref) ** 2)))


def plane_grid(centre: ArrayLike, e1: ArrayLike, e2: ArrayLike, n: int, spacing: float) -> np.ndarray:
    """FastSAR's grid: x_i = (i - n/2) spacing along e1, y_j likewise along e2, about ``centre``; (n*n, 3)."""
    a = (np.arange(n) - n / 2) * spacing
    return (
        np.asarray(centre)[None, None, :] + a[:, None, None] * np.asarray(e1) + a[None, :, None] * np.asarray(e2)
    ).reshape(-1, 3)


def history_from_pulses(
    rc: np.ndarray, range_time: np.ndarray, gate: np.ndarray, pos: np.ndarray, centre: np.ndarray, fc: float, fs: float
) -> tuple[np.ndarray, np.ndarray, float, float]:
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


def bench_scene_case() -> dict[str, Any]:
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


def gotcha_case() -> dict[str, Any] | None:
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


def bp_stages(case: dict[str, Any]) -> tuple[list[Stage], np.ndarray]:
    from sarproc.focus.backprojection import backproject_points

    n, pos = case["n"], case["pos"]
    pts = plane_grid(case["centre"], case["e1"], case["e2"], n, case["spacing"])
    args: tuple[Any, ...] = (case["rc"], case["range_time"], pos, pos, pts, case["fc"])
    kw: dict[str, Any] = {"gate_offset": case["gate"]}
    over = case["fs"] / case["bandwidth"]
    engines: list[tuple[str, dict[str, Any]]] = [
        ("reference", {"engine": "reference", "upsample": 8}),
        ("compiled linear x8", {"engine": "compiled", "upsample": 8}),
        ("compiled cubic x8", {"engine": "compiled", "interpolation": "cubic", "upsample": 8}),
        ("compiled knab8 x2", {"engine": "compiled", "interpolation": "knab", "upsample": 2, "oversampling": 2 * over}),
    ]
    if "engine" not in inspect.signature(backproject_points).parameters:  # an older sarproc (--stages before)
        engines = [("reference", {})]
    stages = []
    for label, opts in engines:

        def fn(o: dict[str, Any] = opts) -> np.ndarray:
            # mypy cannot tell that kw and o hold only keyword-only knobs, none of args' six positionals
            return backproject_points(*args, **kw, **o).reshape(n, n).astype(np.complex64)  # type: ignore[misc]

        st = Stage(
            f"backproject {label}",
            fn,
            case["rc"].shape,
            case["rc"].nbytes + pts.nbytes,
            f"{case['name']}: {len(pos)} pulses x {case['rc'].shape[1]} -> {n} x {n}",
        )
        st.pixel_pulses = n * n * len(pos)
        stages.append(st)
    truth = backproject_points(*args, **kw, **{**engines[0][1], "upsample": 32}).reshape(n, n)  # type: ignore[misc]
    return stages, truth


def fastsar_run(
    case: dict[str, Any], python: str, workdir: str | Path, calls: int = 2
) -> tuple[dict | None, str | None]:
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
        env=dict(os.environ, OMP_NUM_THREADS=str(os.cpu_count() or 1)),  # as many threads as numba's default
    )
    if res.returncode != 0:
        return None, res.stderr.strip().splitlines()[-1] if res.stderr.strip() else f"exit {res.returncode}"
    info = json.loads(res.stdout.strip().splitlines()[-1])
    imgs = np.load(out)
    return {k: (info[k]["time_s"], imgs[k], info[k]) for k in ("linear", "cubic")}, info.get("version")


# ---- paper 000 (exp. 2, full size) and paper 004 stages ----------------------------------------------------
def exp2_stages() -> list[Stage]:
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


def array3d_stages() -> list[Stage]:
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


def simulate_stages() -> list[Stage]:
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


# ---- per-process overhead -----------------------------------------------------------------------------------
# Each stage as users run it: one `sarproc STAGE` process on a small product (inputs made first, by this tree).
# "process": the wall time of that process; "compute": the same command's second run inside one process (imports
# done, kernels loaded: the stage's own reading, work and writing); overhead = process - compute. The stage's
# printed time "(x s)" is shown beside where it prints one. With --baseline (a checkout of an older commit, e.g.
# `git archive <commit> | tar -x -C DIR`) the same commands run from it too, interleaved round by round.
PROCESS_SETUP = (
    ("simulate", "configs/demo.yaml", "-o", "{d}/demo_raw.h5"),
    ("backproject", "{d}/demo_raw.h5", "--config", "configs/demo.yaml", "-o", "{d}/demo_img.h5"),
    ("export-cphd", "{d}/demo_raw.h5", "-o", "{d}/demo.cphd"),
    ("simulate", "configs/an2012_exp1_small.yaml", "-o", "{d}/sq_raw.h5"),
    ("preprocess", "{d}/sq_raw.h5", "--config", "configs/an2012_exp1_small.yaml", "-o", "{d}/sq_pre.h5"),
    ("coarse-focus", "{d}/sq_pre.h5", "--config", "configs/an2012_exp1_small.yaml", "-o", "{d}/sq_coarse.h5"),
    ("simulate", "configs/nie2016_small.yaml", "-o", "{d}/nie_raw.h5"),
    ("simulate", "configs/xu_small.yaml", "-o", "{d}/xu_raw.h5"),
    ("simulate", "configs/du2010.yaml", "-o", "{d}/du_raw.h5"),
)
PROCESS_CASES = (
    ("simulate", "demo", ("simulate", "configs/demo.yaml", "-o", "{d}/out_raw.h5")),
    ("backproject", "demo", ("backproject", "{d}/demo_raw.h5", "--config", "configs/demo.yaml", "-o", "{d}/out.h5")),
    ("evaluate", "demo image", ("evaluate", "{d}/demo_img.h5", "-o", "{d}/out.json")),
    ("quicklook", "demo image", ("quicklook", "{d}/demo_img.h5", "-o", "{d}/out.png")),
    ("export-sicd", "demo image", ("export-sicd", "{d}/demo_img.h5", "-o", "{d}/out.nitf")),
    ("export-cphd", "demo raw", ("export-cphd", "{d}/demo_raw.h5", "-o", "{d}/out.cphd")),
    ("import-cphd", "demo raw", ("import-cphd", "{d}/demo.cphd", "-o", "{d}/out_cphd.h5")),
    (
        "preprocess",
        "an2012_exp1_small",
        ("preprocess", "{d}/sq_raw.h5", "--config", "configs/an2012_exp1_small.yaml", "-o", "{d}/out.h5"),
    ),
    (
        "coarse-focus",
        "an2012_exp1_small",
        ("coarse-focus", "{d}/sq_pre.h5", "--config", "configs/an2012_exp1_small.yaml", "-o", "{d}/out.h5"),
    ),
    (
        "fine-focus",
        "an2012_exp1_small",
        ("fine-focus", "{d}/sq_coarse.h5", "--config", "configs/an2012_exp1_small.yaml", "-o", "{d}/out.h5"),
    ),
    ("pfa2", "nie2016_small", ("pfa2", "{d}/nie_raw.h5", "--config", "configs/nie2016_small.yaml", "-o", "{d}/out.h5")),
    (
        "reconstruct",
        "xu_small",
        ("reconstruct", "{d}/xu_raw.h5", "--config", "configs/xu_small.yaml", "-o", "{d}/out.h5"),
    ),
    ("array3d", "du2010", ("array3d", "{d}/du_raw.h5", "--config", "configs/du2010.yaml", "-o", "{d}/out.h5")),
)
# Runs a command twice in one process; prints the second run's wall time (the stage's compute) last.
WARM_RUN = """
import os, sys, time
from sarproc.cli.main import run_cli, set_thread_defaults
set_thread_defaults()  # the command's thread settings, before numpy loads OpenBLAS
assert run_cli(sys.argv[1:]) == 0
try:  # the second run takes the kernels the first took: the compiled modules' serial budget starts again
    import sarproc.product.aot as aot
    aot._SERIAL_SPENT = 0.0
except ImportError:
    pass
t = time.perf_counter()
assert run_cli(sys.argv[1:]) == 0
print(f"WARM {time.perf_counter() - t:.6f}")
"""


def _sarproc(tree: Path, argv: Sequence[str], warm: bool = False) -> tuple[float, float | None]:
    """(wall s of one `sarproc` process run from ``tree``, the stage's printed time or, warm, the second run's)."""
    import re

    env = {**os.environ, "PYTHONPATH": str(tree)}
    # bytecode cached as in a user's install (pip compiles it; an editable tree caches it on first import): an
    # environment with PYTHONDONTWRITEBYTECODE set would recompile sarproc's sources in every timed process
    # (~0.1-0.15 s of evaluate's start, measured; docs/performance.md, sixth round)
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    cmd = [sys.executable, "-c", WARM_RUN, "-q", *argv] if warm else [sys.executable, "-m", "sarproc", *argv]
    t0 = time.perf_counter()
    done = subprocess.run(cmd, cwd=tree, env=env, capture_output=True, text=True, check=False)
    wall = time.perf_counter() - t0
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(argv)} ({tree}): exit {done.returncode}: {done.stderr.strip()[-300:]}")
    text = done.stdout + done.stderr
    found = re.findall(r"WARM ([0-9.]+)", text) if warm else re.findall(r"\(([0-9.]+) s\)\s*$", text, re.MULTILINE)
    return wall, float(found[-1]) if found else None


def _wait_for_aot_builds(directory: Path, timeout: float = 300.0) -> None:
    """Until the kernels compiled ahead of time that the untimed runs started building (in the background, on
    first use: sarproc.product.aot) are built, so the timed runs measure what every later run does."""
    t0 = time.perf_counter()
    while any(directory.glob("*.lock")) and time.perf_counter() - t0 < timeout:
        time.sleep(0.5)


def _setup_for(cases: Sequence[tuple]) -> list[tuple]:
    """The PROCESS_SETUP commands whose outputs the ``cases`` read, and those these read in turn (in order)."""
    needed = {a for _, _, argv in cases for a in argv if a.startswith("{d}/")}
    chosen = []
    for argv in reversed(PROCESS_SETUP):
        if argv[argv.index("-o") + 1] in needed:
            chosen.append(argv)
            needed |= {a for a in argv if a.startswith("{d}/")}
    return chosen[::-1]


def process_rows(trees: dict[str, Path], rounds: int, workdir: Path, only: set[str] | None = None) -> list[dict]:
    """Per stage and tree: process wall, in-process compute and overhead (best of ``rounds``, interleaved).
    Kernels compiled ahead of time go to a fresh directory under ``workdir`` (built by the untimed first runs)."""
    os.environ["SARPROC_AOT_DIR"] = str(workdir / "aot")
    cases = [c for c in PROCESS_CASES if only is None or c[0] in only]
    data = {}
    for label, tree in trees.items():
        d = workdir / label
        d.mkdir(parents=True, exist_ok=True)
        data[label] = d
        for argv in _setup_for(cases):
            _sarproc(tree, [a.format(d=d) for a in argv] + ["--overwrite", "-q"])
        for _, _, argv in cases:  # once untimed: every kernel in this tree's numba cache
            _sarproc(tree, [a.format(d=d) for a in argv] + ["--overwrite", "-q"])
    _wait_for_aot_builds(Path(os.environ["SARPROC_AOT_DIR"]))
    best: dict[tuple[str, str], list[Any]] = {}  # (stage, tree): best wall, best warm, best printed time
    for r in range(rounds):
        for stage, _detail, argv in cases:
            for label, tree in trees.items():
                args = [a.format(d=data[label]) for a in argv] + ["--overwrite"]
                wall, printed = _sarproc(tree, args)
                _, warm = _sarproc(tree, args, warm=True)
                b = best.setdefault((stage, label), [np.inf, np.inf, None])
                b[0], b[1] = min(b[0], wall), min(b[1], warm)
                if printed is not None:
                    b[2] = printed if b[2] is None else min(b[2], printed)
        print(f"  process overhead: round {r + 1}/{rounds} done", file=sys.stderr)
    rows = []
    for stage, detail, _ in cases:
        for label in trees:
            wall, warm, printed = best[(stage, label)]
            rows.append(
                {
                    "stage": f"process {stage}",
                    "detail": f"{detail}, {label}",
                    "time_s": wall,
                    "compute_s": warm,
                    "printed_s": printed,
                    "overhead_s": wall - warm,
                }
            )
    return rows


def fmt_process_table(rows: list[dict]) -> str:
    lines = [
        "| stage | data, tree | process (s) | compute (s) | printed (s) | overhead (s) |",
        "|---|---|---:|---:|---:|---:|",
    ]
    for r in rows:
        printed = "-" if r["printed_s"] is None else f"{r['printed_s']:.2f}"
        lines.append(
            f"| {r['stage'].removeprefix('process ')} | {r['detail']} | {r['time_s']:.2f} | {r['compute_s']:.2f} | "
            f"{printed} | {r['overhead_s']:.2f} |"
        )
    return "\n".join(lines)


# ---- report -------------------------------------------------------------------------------------------------
def fmt_table(rows: list[dict], previous: dict | None) -> str:
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


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rounds", type=int, default=3, help="rounds of the heavy stages (best of)")
    ap.add_argument("--bp-rounds", type=int, default=5, help="rounds of the backprojection stages (best of)")
    ap.add_argument("--stages", default="bp,gotcha,exp2,array3d,simulate,process")
    ap.add_argument(
        "--baseline",
        type=Path,
        default=None,
        help="an older checkout (git archive COMMIT | tar -x -C DIR): its per-process rows interleaved with this tree's",
    )
    ap.add_argument(
        "--process-stages",
        default=None,
        help="comma-separated stages of the per-process rows (default: all of PROCESS_CASES)",
    )
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
        fast: dict[str, list[Any]] = {
            "linear": [np.inf, None, None],
            "cubic": [np.inf, None, None],
        }  # time, image, info
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
                agreement_db=error_db(st.out, ref) if st is not stages[0] else None,
                truth_db=error_db(st.out, truth),
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
                    # the server's CPU times of its best call (scripts/bench_fastsar.py timed_call)
                    "cpu_per_wall": (info["user_s"] + info["sys_s"]) / info["time_s"],
                    "rate": stages[0].pixel_pulses / t,
                    "agreement_db": error_db(img, ref, fit=True),
                    "truth_db": error_db(img, truth, fit=True),
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

    process = []
    if "process" in want:
        trees = {"this tree": ROOT}
        if args.baseline is not None:
            trees = {"baseline": args.baseline.resolve(), **trees}
        with tempfile.TemporaryDirectory() as tmp:
            only = set(args.process_stages.split(",")) if args.process_stages else None
            process = process_rows(trees, args.rounds, Path(tmp), only)

    stamp = datetime.datetime.now(datetime.UTC).strftime("%Y%m%dT%H%M%SZ")
    tables = [fmt_table(rows, previous), ""] + ([fmt_process_table(process), ""] if process else [])
    text = "\n".join([f"# sarproc bench {stamp}", ""] + tables + [f"- {n}" for n in notes])
    print(text)
    args.out.mkdir(parents=True, exist_ok=True)
    doc = {
        "utc": stamp,
        "rounds": args.rounds,
        "bp_rounds": args.bp_rounds,
        "stages": rows,
        "process": process,
        "notes": notes,
        "peak_rss_process_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
    }
    blob = json.dumps(doc, indent=1, default=lambda o: None if not np.isfinite(o) else float(o))
    (args.out / f"bench-{stamp}.json").write_text(blob)
    (args.out / "latest.json").write_text(blob)
    (args.out / "latest.md").write_text(text + "\n")


# ---- fast factorised backprojection against the exact engine and FastSAR (`bench.py ffbp ...`) ---------------
# (factor, first factor, oversample, interpolation, taps, pulse reads): the first version's default (cubic reads,
# q = 4), then Knab reads (knab 10 at q = 1.75 the default until 2026-12-02, knab 12 at q = 1.5 since); the last
# reads the pulses cubic x8, as the second exact image does
FFBP_SETTINGS = [
    (4, 4, 4.0, "cubic", 4, "linear"),
    (4, 16, 1.5, "knab", 8, "linear"),
    (4, 16, 2.0, "knab", 8, "linear"),
    (4, 16, 1.75, "knab", 10, "linear"),
    (4, 16, 1.5, "knab", 12, "linear"),
    (4, 16, 1.5, "knab", 12, "cubic"),
    # cubic pulse reads past the linear reads' -47 dB floor: against the cubic x8 exact image (the closest to
    # the truth) where FastSAR's factorised former measures -60.7 dB on the 2048^2 grid
    (4, 16, 2.0, "knab", 10, "cubic"),
    (4, 16, 1.75, "knab", 12, "cubic"),
]


def _db(x: float) -> float:
    return 10 * math.log10(max(x, 1e-30))


class FastSARServer:
    """FastSAR's formers in the bench venv, one process serving timed calls (scripts/bench_fastsar.py --serve), so
    that its calls interleave with ours: every former built and called once untimed first, on ``threads`` threads
    (OMP_NUM_THREADS, as many as our kernels use)."""

    def __init__(
        self, python: str, case: dict[str, Any], n: int, spacing: float, threads: int, workdir: Path, lanes: int | None
    ) -> None:
        S, ref, fmin, df = history_from_pulses(
            case["rc"], case["range_time"], case["gate"], case["pos"], case["centre"], case["fc"], case["fs"]
        )
        path, self.out = workdir / f"case{n}.npz", workdir / f"images{n}.npz"
        np.savez(
            path,
            S=S,
            ant=case["pos"] - case["centre"],
            ref=ref,
            fmin=fmin,
            df=df,
            nx=n,
            ny=n,
            spx=spacing,
            spy=spacing,
            e1=case["e1"],
            e2=case["e2"],
            center=np.zeros(3),
        )
        argv = [python, str(ROOT / "scripts" / "bench_fastsar.py"), str(path), str(self.out), "--serve"]
        argv += ["--factorised", "-50"] + (["--lanes", str(lanes)] if lanes else [])
        env = dict(os.environ, OMP_NUM_THREADS=str(threads))
        self.proc = subprocess.Popen(argv, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, env=env)
        self.head = self._answer()
        self.keys = ["linear", "cubic", "imageformer-50"] + ([f"imageformer-50 lanes{lanes}"] if lanes else [])

    def _answer(self) -> dict:
        assert self.proc.stdout is not None
        line = self.proc.stdout.readline()
        if not line:
            raise RuntimeError(f"bench_fastsar.py ended (exit {self.proc.wait()})")
        return json.loads(line)

    def call(self, key: str) -> dict:
        assert self.proc.stdin is not None
        self.proc.stdin.write(key + "\n")
        self.proc.stdin.flush()
        return self._answer()

    def images(self) -> Any:
        self.call("save")
        return np.load(self.out)

    def close(self) -> None:
        if self.proc.stdin is not None:
            self.proc.stdin.write("quit\n")
            self.proc.stdin.close()
        self.proc.wait()


def _cpu_times() -> tuple[float, float]:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime, r.ru_stime


def timed(fn: Callable[[], Any]) -> tuple[Any, dict]:
    """fn()'s result and its wall, user and system seconds (all threads of this process)."""
    u0, s0 = _cpu_times()
    t = time.perf_counter()
    out = fn()
    wall = time.perf_counter() - t
    u1, s1 = _cpu_times()
    return out, {"time_s": wall, "user_s": u1 - u0, "sys_s": s1 - s0}


def ffbp_label(setting: tuple) -> str:
    k, k1, q, interp, taps, pulse = setting
    return f"sarproc ffbp {interp} {taps} q {q:g} (factor {k}, first {k1}), pulses {pulse} x8"


def fmt_ffbp_table(rows: list[dict]) -> str:
    """Markdown: per grid, every former's best time, its ratio to FastSAR's counterpart in the same run (FastSAR's
    time over ours: > 1 means ours is faster) and its errors."""
    lines = []
    for n in sorted({r["n"] for r in rows}):
        grid = [r for r in rows if r["n"] == n]
        fs = {r["engine"]: r for r in grid}
        lines += [
            f"\n{n} x {n} ({grid[0]['spacing']:.3f} m), best of {grid[0]['calls']} interleaved calls\n",
            "| former | time (s) | user + sys (s) | sys (s) | FastSAR's time / this (stock, lanes 8) | vs sarproc exact (dB) "
            "| vs exact cubic x8 (dB) | vs cubic x32 truth (dB) |",
            "|---|---:|---:|---:|---:|---:|---:|---:|",
        ]
        for r in grid:
            ratio = " / ".join(f"{fs[v]['time_s'] / r['time_s']:.2f}x" for v in r.get("versus", []) if v in fs)
            cells = [
                r["engine"],
                f"{r['time_s']:.3f}",
                f"{r['user_s'] + r['sys_s']:.2f}",
                f"{r['sys_s']:.2f}",
                ratio,
                *(
                    f"{r[k]:.1f}" if r.get(k) is not None else ""
                    for k in ("error_db", "error_cubic_db", "error_truth_db")
                ),
            ]
            lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def ffbp_main(argv: list[str] | None = None) -> None:
    """`bench.py ffbp`: fast factorised backprojection and the exact engine against FastSAR's exact and factorised
    formers on the bench scene, grid by grid; every former's calls interleaved round by round (--repeats rounds,
    each former's best), each image's error against our exact image, the cubic x8 exact one and, on grids up to
    --truth-size, a cubic x32 one (the truth)."""
    from sarproc.focus.backprojection import backproject_points
    from sarproc.focus.ffbp import ffbp_points, predicted_image_error, pulse_oversample

    ap = argparse.ArgumentParser(prog="bench.py ffbp", description=ffbp_main.__doc__)
    ap.add_argument("--sizes", type=int, nargs="+", default=[512, 1024, 2048])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--json", help="rows to this file (default OUT/ffbp-latest.json, and a Markdown table beside)")
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "bench")
    ap.add_argument(
        "--fastsar-python",
        help="the bench venv's python (make bench-venv): FastSAR's exact linear and cubic x8 and factorised "
        "ImageFormer (target -50 dB) on the same pulses",
    )
    ap.add_argument(
        "--lanes",
        type=int,
        default=8,
        help="FastSAR's factorised former also rebuilt with this many floats per vector (0: not); 8 is one "
        "AVX2 register, where its stock 16 spill",
    )
    ap.add_argument("--settings", help="indices into FFBP_SETTINGS, comma-separated (default: all)")
    ap.add_argument("--truth-size", type=int, default=512, help="cubic x32 truth on grids up to this size")
    ap.add_argument("--exact-only", action="store_true", help="only the exact engine (and FastSAR's formers)")
    ap.add_argument("--save-exact", help="write the exact images to this .npz (key n<size>), e.g. to compare trees")
    a = ap.parse_args(argv)
    import numba

    threads = numba.get_num_threads()
    settings = FFBP_SETTINGS if a.settings is None else [FFBP_SETTINGS[int(i)] for i in a.settings.split(",")]
    case = bench_scene_case()
    rows: list[dict] = []
    saved: dict[str, Any] = {}  # Any: numpy's savez stub would match an array to allow_pickle
    meta: dict[str, Any] = {"threads": threads, "load_before": os.getloadavg()}
    with tempfile.TemporaryDirectory() as tmp:
        for n in a.sizes:
            spacing = case["spacing"] * 512 / n * 2 if n > 1024 else case["spacing"]  # 2048: 0.15 m, 307 m wide
            pts = plane_grid(case["centre"], case["e1"], case["e2"], n, spacing)
            args = (case["rc"], case["range_time"], case["pos"], case["pos"], pts, case["fc"])
            common: dict[str, Any] = {"gate_offset": case["gate"], "engine": "compiled"}
            formers: dict[str, Callable[[], np.ndarray]] = {
                "sarproc exact linear x8": functools.partial(backproject_points, *args, **common, upsample=8),
                # FastSAR's exact former pads its profiles to a power of two (nfft = 2^ceil(log2(8 K)): 16384 for
                # 1060 samples, x15.5): its "x8" reads a profile as fine as our x16
                "sarproc exact linear x16": functools.partial(backproject_points, *args, **common, upsample=16),
            }
            infos: dict[str, dict] = {}
            for setting in [] if a.exact_only else settings:
                info: dict = {}
                infos[ffbp_label(setting)] = info
                formers[ffbp_label(setting)] = functools.partial(
                    ffbp_points,
                    case["rc"],
                    case["range_time"],
                    case["pos"],
                    pts,
                    case["fc"],
                    case["bandwidth"],
                    factor=setting[0],
                    first_factor=setting[1],
                    oversample=setting[2],
                    ffbp_interpolation=setting[3],
                    ffbp_taps=setting[4],
                    interpolation=setting[5],
                    grid_shape=(n, n),
                    info=info,
                    gate_offset=case["gate"],
                )
            server = None
            if a.fastsar_python:
                server = FastSARServer(a.fastsar_python, case, n, spacing, threads, Path(tmp), a.lanes or None)
                meta[f"fastsar {n}"] = server.head
                print(f"{n}x{n}: FastSAR {json.dumps(server.head)}", flush=True)
            # the untimed first calls of ours (FastSAR's were made by the server)
            images = {label: fn() for label, fn in formers.items()}
            best: dict[str, dict] = {}
            order = list(formers) + ([f"fastsar {key}" for key in server.keys] if server else [])
            for r in range(a.repeats):
                for label in order:
                    if label.startswith("fastsar "):
                        assert server is not None
                        info = server.call(label.removeprefix("fastsar "))
                    else:
                        images[label], info = timed(formers[label])
                    if info["time_s"] < best.get(label, {"time_s": math.inf})["time_s"]:
                        best[label] = info
                    print(f"  round {r} {label}: {info['time_s']:.3f} s (sys {info['sys_s']:.2f})", flush=True)
            if server is not None:
                fs_images = server.images()
                server.close()
                for key in server.keys:
                    images[f"fastsar {key}"] = np.asarray(fs_images[key]).reshape(-1)
            exact = images["sarproc exact linear x8"]
            saved[f"n{n}"] = exact
            exact_cubic = backproject_points(*args, **common, interpolation="cubic")
            truth = (
                backproject_points(*args, **common, interpolation="cubic", upsample=32) if n <= a.truth_size else None
            )
            # the FastSAR formers each of ours is timed against (the factorised one stock, then with --lanes)
            versus = {"sarproc exact linear x8": ["fastsar linear"], "sarproc exact linear x16": ["fastsar linear"]}
            versus.update(dict.fromkeys(infos, [key for key in order if key.startswith("fastsar imageformer")]))
            for label in order:
                fast = label.startswith("fastsar ")
                img = images[label]
                row: dict[str, Any] = {"n": n, "spacing": spacing, "engine": label, "calls": a.repeats, **best[label]}
                row["versus"] = versus.get(label, [])
                row["error_db"] = None if label == "sarproc exact linear x8" else error_db(img, exact, fast)
                row["error_cubic_db"] = error_db(img, exact_cubic, fast)
                row["error_truth_db"] = None if truth is None else error_db(img, truth, fast)
                if label in infos:
                    setting = next(s for s in settings if ffbp_label(s) == label)
                    pred = predicted_image_error(  # as the plan prints it
                        case["pos"],
                        pts,
                        case["fc"],
                        case["bandwidth"],
                        grid_shape=(n, n),
                        factor=setting[0],
                        first_factor=setting[1],
                        oversample=setting[2],
                        ffbp_interpolation=setting[3],
                        ffbp_taps=setting[4],
                        pulse_oversample=pulse_oversample(case["rc"].shape[1], 8, case["fs"], case["bandwidth"]),
                        pulse_interpolation=setting[5],
                    )
                    row["predicted_db"] = _db(pred)
                    row["stage_s"] = [float(x) for x in infos[label].get("seconds", [])]
                rows.append(row)
            print(fmt_ffbp_table([r for r in rows if r["n"] == n]), flush=True)
    meta["load_after"] = os.getloadavg()
    a.out.mkdir(parents=True, exist_ok=True)
    path = Path(a.json) if a.json else a.out / "ffbp-latest.json"
    path.write_text(json.dumps({"meta": meta, "rows": rows}, indent=1))
    table = fmt_ffbp_table(rows)
    path.with_suffix(".md").write_text(f"`bench.py ffbp {' '.join(argv or sys.argv[2:])}`; {json.dumps(meta)}\n{table}")
    print(f"rows: {path}; table: {path.with_suffix('.md')}")
    if a.save_exact:
        np.savez(a.save_exact, **saved)


if __name__ == "__main__":
    if sys.argv[1:2] == ["ffbp"]:
        ffbp_main(sys.argv[2:])
    else:
        main()
