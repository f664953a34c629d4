"""Resource plan of simulate, from the scene alone (sarproc.product.budget has the Plan and the process around it)."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from sarproc.product.budget import Plan, complex_bytes, stored_bytes
from sarproc.product.metadata import C

if TYPE_CHECKING:
    from sarproc.simulation.scene import Scene


def simulate_estimate(scene: Scene) -> Plan:
    """Raw product size, memory and time of ``scene`` before planning it (cheap: three pulses)."""
    import numpy as np

    r = scene.radar
    n_p = scene.n_pulses
    n_tg = len(scene.target_xyz)
    acq = scene.params.acquisition
    fs = r.range_sampling_rate
    n_ch = max(1, int(r.n_channels))
    for e in scene.effects:  # receive channels of array effects
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
    mem = (
        complex_bytes(n_ch, block, n_rg + 2 * n_env, itemsize=16)
        + complex_bytes(block, n_env, itemsize=16) * 6
        + block * n_tg * 8 * 8.0
        + max(window_plan, complex_bytes(n_ch, block, n_rg))
    )
    # compiled echo accumulation: ~0.8 ns per echo sample (one complex multiply-add, eight SLP-packed lanes,
    # 2 threads, shared machine), ~0.1 us per (pulse, target) pair, ~10 ns per stored sample (zeroing, chirp,
    # write); measured: nie2016 (1.1e10 echo samples) 7.8-13 s wall, 12 s of CPU of which ~5 s the kernel
    # (was 1.5 ns, 17 s of CPU, before the vectorised kernel), demo 0.9-1.2 s with the process
    seconds = n_ch * n_p * n_tg * (n_env * 0.8e-9 + 0.1e-6) + n_ch * n_p * n_rg * 10e-9
    from sarproc.simulation.effects.clutter import Clutter, clutter_cost

    for e in scene.effects:  # clutter scatterers: the same ~0.8 ns per echo sample (xu_clutter: 4.9e8)
        if isinstance(e, Clutter):
            seconds += 0.8e-9 * clutter_cost(n_p, n_ch, e.params.n_scatterers, n_env)
    window = (
        "acquisition.range_window"
        if acq.range_window is not None
        else f"the targets' delays + radar.pulse_duration {r.pulse_duration:g} s"
    )
    detail = (
        f"{n_ch} x {n_p} pulses x {n_rg} samples, {n_tg} targets; samples = {window} "
        f"x radar.range_sampling_rate {fs:g} Hz"
    )
    return Plan("simulate", out, mem, seconds, detail)
