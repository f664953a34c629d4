"""The order every processing subcommand follows, and each stage's resource estimate.

1. parameters (``--config`` section), 2. the input's header (every layout check, no data read),
3. the output location (exists? writable?), 4. the plan (output size, working memory, run time;
printed with -v, refused when it cannot fit), 5. the data, 6. the work, 7. the atomic write.
So a bad scene or config is reported before "output exists", and nothing is computed for an
output that cannot be written. Errors from the core that name no file get the input's name.

Estimates are array sizes times the copies a stage holds, and run times from per-sample costs
measured on one core of a 2020s laptop; they aim at the right order of magnitude, not at 10 %.
"""

from __future__ import annotations

import contextlib
import math
from pathlib import Path

from sarproc.cli.options import info, load_config, max_memory
from sarproc.product.budget import Plan, check_plan, complex_bytes, stored_bytes
from sarproc.product.errors import InputError

C = 299_792_458.0


@contextlib.contextmanager
def naming(input_path, config_path=None, section: str | None = None):
    """Give a core InputError the file it is about: the config for ``section.key`` messages, else the input."""
    try:
        yield
    except InputError as exc:
        msg = str(exc)
        if str(input_path) in msg or (config_path is not None and str(config_path) in msg):
            raise
        if config_path is not None and section and msg.startswith((section + ".", section + ":")):
            raise InputError(f"{config_path}: {msg}") from None
        raise InputError(f"{input_path}: {msg}") from None


def prepare(stage: str, input_path: Path, outputs, config_path, overwrite: bool, kinds, params_cls,
            section: str, estimate=None):
    """Steps 1-5 above; returns (params, product) ready for the work."""
    from sarproc.product.io import read_product

    params = load_config(params_cls, config_path, section=section)
    header = read_product(input_path, kinds=kinds, load=False)
    plan_outputs(input_path, outputs, overwrite, lambda: (estimate or generic_estimate)(stage, header, params),
                  config_path=config_path, section=section)
    product = read_product(input_path, kinds=kinds)
    return params, product


def plan_outputs(input_path, outputs, overwrite: bool, estimate, inputs=None, config_path=None,
                 section: str | None = None):
    """Steps 3-4 above for a checked input: every output writable, then ``estimate()``'s plan printed
    with -v and refused when it cannot fit. ``inputs``: the files the outputs must not replace
    (default ``[input_path]``). Returns the plan."""
    from sarproc.product.io import check_output_path

    outputs = [Path(o) for o in outputs if o is not None]
    for out in outputs:
        check_output_path(out, [input_path] if inputs is None else inputs, overwrite)
    with naming(input_path, config_path, section):
        plan = estimate()
    info(plan.describe())
    with naming(input_path):
        check_plan(plan, outputs, max_memory())
    return plan


def _shape(header) -> tuple[int, ...]:
    return tuple(int(n) for n in header.attrs["shape"])


def generic_estimate(stage: str, header, params) -> Plan:
    """Output as large as the input, four input-sized arrays in memory, FFT-like cost."""
    n = math.prod(_shape(header))
    b = complex_bytes(n)
    return Plan(stage, b, 4 * b, n * 60e-9 * max(1.0, math.log2(max(n, 2)) / 10))


def preprocess_estimate(stage, header, params) -> Plan:
    n_az, n_rg = _shape(header)
    b = complex_bytes(n_az, n_rg)
    block = complex_bytes(min(params.block_pulses, n_az), n_rg, itemsize=16) * 4
    return Plan(stage, stored_bytes(n_az, n_rg), 2 * b + block, n_az * n_rg * 40e-9, f"{n_az} x {n_rg} samples")


def coarse_focus_estimate(stage, header, params) -> Plan:
    n_az, n_rg = _shape(header)
    n_out = params.azimuth_samples or 2 * n_az   # the default M is the PRF-limited length, at most about 2x
    out = complex_bytes(n_out, n_rg)
    block = complex_bytes(n_out, min(params.block_range, n_rg), itemsize=16) * 3
    return Plan(stage, stored_bytes(n_out, n_rg), complex_bytes(n_az, n_rg) + out + block, n_out * n_rg * 60e-9,
                f"{n_az} pulses -> ~{n_out} azimuth samples x {n_rg}")


def fine_focus_estimate(stage, header, params) -> Plan:
    M, n_r = _shape(header)
    r = header.radar
    N = n_r + int(math.ceil(r.pulse_duration * r.range_sampling_rate))
    if M * N > params.max_samples:
        raise InputError(f"fine_focus.max_samples: the working array {M} x {N} exceeds {params.max_samples}; "
                         "raise it or shrink the scene")
    work = complex_bytes(M, N, itemsize=8 if params.precision == "float32" else 16)
    # spectra, Stolt output, azimuth blocks and kernel tables: about ten working arrays (measured)
    return Plan(stage, stored_bytes(M, N), complex_bytes(M, n_r) + 10 * work, M * N * params.stolt_length * 25e-9,
                f"working array {M} x {N}")


def backproject_estimate(stage, header, params) -> Plan:
    n_az, n_rg = _shape(header)[-2:]
    n_ch = _shape(header)[0] if len(_shape(header)) == 3 else 1
    r = header.radar
    t_ap = max(n_az / r.prf, 1e-9)
    irw_rg = r.range_resolution
    irw_az = 0.886 * r.wavelength * r.reference_range / (2 * r.velocity * t_ap * max(math.cos(r.squint) ** 2, 1e-6))
    n = []
    for ax, irw in (("azimuth", irw_az), ("range", irw_rg)):
        spacing = getattr(params, f"{ax}_spacing") or irw / params.oversample
        extent = getattr(params, f"{ax}_extent")
        if extent is None:
            t = header.targets[ax] if len(header.targets) else [0.0]
            extent = (max(t) - min(t)) + 2 * params.margin_cells * irw
        n.append(max(1, int(extent / spacing) + 1))
    n_pix = n[0] * n[1]
    if n_pix > params.max_pixels:
        raise InputError(f"backproject.max_pixels: the grid of ~{n[0]} x {n[1]} pixels exceeds {params.max_pixels}; "
                         "set backproject azimuth/range extents or spacings, or raise max_pixels")
    raw = complex_bytes(n_ch, n_az, n_rg)
    up = complex_bytes(n_az, n_rg * params.upsample)
    per = 4e-9 if params.engine == "compiled" else 25e-9
    jit = 60e6 if params.engine == "compiled" else 0.0   # numba's compiler, measured once per process
    return Plan(stage, stored_bytes(*n), raw + 2 * up + complex_bytes(n_pix, itemsize=16) + jit,
                n_ch * n_az * n_pix * per, f"~{n[0]} x {n[1]} pixels from {n_ch * n_az} pulses")


def array3d_estimate(stage, header, params) -> Plan:
    n_ch, n_az, n_rg = _shape(header)
    n_el = int(params.elevation_zero_padding * n_ch)
    raw = complex_bytes(n_ch, n_az, n_rg)
    cube = complex_bytes(n_el, n_az, n_rg)
    item = 8 if params.precision == "float32" else 16
    return Plan(stage, stored_bytes(n_el, n_az, n_rg), raw + 2 * complex_bytes(n_ch, n_az, n_rg, itemsize=item) + 2 * cube,
                n_ch * n_az * n_rg * 80e-9 + n_el * n_az * n_rg * 20e-9,
                f"{n_ch} channels -> ~{n_el} elevation bins x {n_az} x {n_rg}")


def evaluate_estimate(stage, header, params) -> Plan:
    n = math.prod(_shape(header))
    # the JSON report: about 3 kB per target (figures are not counted)
    return Plan(stage, 1e3 + 3.5e3 * len(header.targets), 4 * complex_bytes(n), 0.5 + n * 20e-9 + len(header.targets) * 0.3,
                f"{len(header.targets)} targets on {n} pixels")


def simulate_estimate(scene) -> Plan:
    """Raw product size, memory and time of ``scene`` before planning it (cheap: three pulses)."""
    import numpy as np

    r = scene.radar
    n_p = scene.n_pulses
    n_tg = len(scene.target_xyz)
    acq = scene.params.acquisition
    fs = r.range_sampling_rate
    n_ch = max(1, int(r.n_channels))
    for e in scene.effects:   # receive channels of array effects
        tx, rx = e.channels(np.zeros(3), np.zeros((1, 3)))
        n_ch = max(n_ch, len(np.asarray(rx).reshape(-1, 3)))
    if acq.range_window is not None:
        span = 2 * (acq.range_window.end - acq.range_window.start) / C
    elif n_tg:
        t = scene.azimuth_time()[[0, n_p // 2, -1]]
        pos = np.stack([r.velocity * t, np.zeros(3), np.full(3, r.altitude)], axis=1)
        d = 2 * np.linalg.norm(scene.target_xyz[None, :, :] - pos[:, None, :], axis=-1) / C
        span = float(d.max() - d.min()) + r.pulse_duration + 4 * acq.range_margin / C
    else:
        span = 2 * r.pulse_duration
    n_rg = int(math.ceil(span * fs)) + 1
    n_env = min(int(math.ceil(r.pulse_duration * fs)) + 2, n_rg)
    block = min(scene.params.simulation.block_pulses, n_p)
    out = stored_bytes(*((n_ch,) if n_ch > 1 else ()), n_p, n_rg)
    # The automatic window takes delays of every pulse, channel and target at once (plan_simulation).
    window_plan = 0.0 if acq.range_window is not None else n_p * n_tg * 8.0 * (n_ch + 7)
    mem = (complex_bytes(n_ch, block, n_rg + 2 * n_env, itemsize=16) + complex_bytes(block, n_env, itemsize=16) * 6
           + block * n_tg * 8 * 8.0 + max(window_plan, complex_bytes(n_ch, block, n_rg)))
    seconds = n_ch * n_p * n_tg * (n_env * 15e-9 + 2e-6) + n_ch * n_p * n_rg * 10e-9
    window = ("acquisition.range_window" if acq.range_window is not None
              else f"the targets' delays + radar.pulse_duration {r.pulse_duration:g} s")
    detail = (f"{n_ch} x {n_p} pulses x {n_rg} samples, {n_tg} targets; samples = {window} "
              f"x radar.range_sampling_rate {fs:g} Hz")
    return Plan("simulate", out, mem, seconds, detail)


def export_sicd_estimate(stage, header, params) -> Plan:
    """SICD holds complex64 pixels; the image, its reordered copy and the read-back are in memory."""
    n = math.prod(_shape(header))
    return Plan(stage, complex_bytes(n) + 1e5, 3 * complex_bytes(n), 2.0 + n * 50e-9, f"{n} pixels")


def export_cphd_estimate(stage, header, params) -> Plan:
    """CPHD holds the FX-domain signal (complex64) and 200 bytes of per-vector parameters per pulse."""
    n_az, n_rg = _shape(header)[-2:]
    n = n_az * n_rg
    return Plan(stage, complex_bytes(n) + 200.0 * n_az + 1e5, complex_bytes(n) + 3 * complex_bytes(n, itemsize=16),
                2.0 + n * 80e-9, f"{n_az} vectors x {n_rg} samples")


def import_cphd_estimate(stage, cphd: dict) -> Plan:
    n_v, n_s = cphd["vectors"], cphd["samples"]
    n = n_v * n_s
    return Plan(stage, stored_bytes(n_v, n_s), complex_bytes(n) + 3 * complex_bytes(n, itemsize=16), 1.0 + n * 80e-9,
                f"{n_v} vectors x {n_s} samples")


def import_gotcha_estimate(stage, files) -> Plan:
    """Gotcha files store complex64 samples: the product is about their size; read as complex128, twice."""
    size = float(sum(Path(f).stat().st_size for f in files))
    return Plan(stage, size, 5 * size, 0.5 + size * 10e-9, f"{len(files)} file(s), {size / 1e6:.3g} MB")
