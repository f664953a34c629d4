"""Exact-geometry raw echoes of point targets (stop-and-go, no Taylor expansion).

Baseband model for pulse at azimuth time t, channel n, target T with complex amplitude A:

    s(tau, t) = A g(t) rect((tau - tau_d) / T_p) exp(j pi K (tau - tau_d)^2) exp(-j 2 pi f_c tau_d)
    tau_d     = (|P_tx(t) - T(t)| + |P_rx,n(t) - T(t)|) / c

Delays and phases are float64; blocks are accumulated in complex128 and stored complex64. A
target's echo is evaluated only on the samples its pulse envelope covers (about T_p f_s per
pulse), so the cost is n_pulses x n_targets x T_p f_s, independent of the window length.
"""

from __future__ import annotations

import dataclasses
import functools
import logging
import math
from collections.abc import Iterator
from typing import TYPE_CHECKING

import numpy as np

from sarproc.product.metadata import C, RadarMetadata
from sarproc.product.model import Product
from sarproc.simulation.effects.base import Effect
from sarproc.simulation.scene import Scene

if TYPE_CHECKING:
    from collections.abc import Callable

    from sarproc.product.steps import ProgressFactory

log = logging.getLogger(__name__)


@dataclasses.dataclass
class SimulationPlan:
    """Everything known before the first pulse: axes, channels, metadata, products' kind."""

    kind: str
    dims: tuple[str, ...]
    coords: dict[str, np.ndarray]
    radar: RadarMetadata
    targets: np.ndarray
    aux: dict[str, np.ndarray]
    tx_offset: np.ndarray
    rx_offsets: np.ndarray
    block_pulses: int
    # attributes of the raw data set: the frame, the effects' truth, and fixed_gate_samples, the samples per
    # pulse a fixed receive gate would need for the same echoes (only with a varied gate, effects.range_gate)
    attrs: dict = dataclasses.field(default_factory=dict)

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(len(self.coords[d]) for d in self.dims)


def _positions(scene: Scene, t: np.ndarray) -> np.ndarray:
    r = scene.radar
    pos = np.stack([r.velocity * t, np.zeros_like(t), np.full_like(t, r.altitude)], axis=-1)
    for e in scene.effects:
        pos = e.platform_positions(t, pos)
    return pos


def _scatterers(scene: Scene) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(xyz (n, 3), velocity (n, 3), amplitude (n,)): the scene's targets, then effects' static clutter."""
    xyz, vel, amp = [scene.target_xyz.reshape(-1, 3)], [scene.target_velocity.reshape(-1, 3)], [scene.target_amplitude]
    for e in scene.effects:
        extra = e.scatterers()
        if extra is not None:
            xyz.append(np.asarray(extra[0], float).reshape(-1, 3))
            vel.append(np.zeros_like(xyz[-1]))
            amp.append(np.asarray(extra[1], complex).reshape(-1))
    if len(xyz) == 1:
        return xyz[0], vel[0], amp[0]
    return np.concatenate(xyz), np.concatenate(vel), np.concatenate(amp)


def _target_positions(scene: Scene, t: np.ndarray) -> np.ndarray:
    xyz, vel, _ = _scatterers(scene)
    pos = np.broadcast_to(xyz[None, :, :], (len(t),) + xyz.shape).copy()
    for e in scene.effects:
        pos = e.target_positions(t, pos, vel)
    return pos


def _gate_offsets(scene: Scene, t: np.ndarray, reference_delay: float) -> np.ndarray:
    off = np.zeros_like(t)
    for e in scene.effects:
        off = e.gate_offsets(t, off, reference_delay)
    return off


def _delays(tx: np.ndarray, rx: np.ndarray, targets: np.ndarray) -> np.ndarray:
    """Two-way delay (n_t, n_tg), s: tx, rx (n_t, 3); targets (n_t, n_tg, 3)."""
    r_tx = np.linalg.norm(targets - tx[:, None, :], axis=-1)
    r_rx = np.linalg.norm(targets - rx[:, None, :], axis=-1)
    return (r_tx + r_rx) / C


def _receive_window(
    scene: Scene, t: np.ndarray, tx_off: np.ndarray, rx_off: np.ndarray, gate: np.ndarray
) -> tuple[int, int]:
    """First range sample and sample count of the receive window that holds every echo, gate offsets
    ``gate`` (s, per pulse) shifting it per pulse."""
    r = scene.radar
    ref_delay = 2 * r.reference_range / C
    acq = scene.params.acquisition
    if acq.range_window is not None:
        start, end = 2 * acq.range_window.start / C, 2 * acq.range_window.end / C
    elif len(_scatterers(scene)[0]):
        # Delays over every pulse, channel and target; gate offsets shift the window per pulse.
        pos = _positions(scene, t)
        tg = _target_positions(scene, t)
        d = np.stack([_delays(pos + tx_off, pos + rx, tg) for rx in rx_off]) - gate[None, :, None]
        margin = 2 * acq.range_margin / C
        if scene.params.simulation.waveform == "band_limited":  # the DAC filter's ringing beyond the pulse
            from sarproc.simulation.echo_aot import kaiser_design

            margin += kaiser_design(r.range_sampling_rate, r.bandwidth)[0] / r.range_sampling_rate
        start = float(d.min()) - r.pulse_duration / 2 - margin
        end = float(d.max()) + r.pulse_duration / 2 + margin
    else:
        start, end = ref_delay - r.pulse_duration, ref_delay + r.pulse_duration
    fs = r.range_sampling_rate
    first = math.floor(start * fs)
    return first, max(1, math.ceil(end * fs) - first + 1)


def plan_simulation(scene: Scene) -> SimulationPlan:
    """Axes, channels and metadata of the raw product ``scene`` will produce."""
    r = scene.radar
    tx_off, rx_off = np.zeros(3), np.zeros((1, 3))
    for e in scene.effects:
        tx_off, rx_off = e.channels(tx_off, rx_off)
    tx_off, rx_off = np.asarray(tx_off, float).reshape(3), np.asarray(rx_off, float).reshape(-1, 3)
    t = scene.azimuth_time()
    ref_delay = 2 * r.reference_range / C
    gate = _gate_offsets(scene, t, ref_delay)
    first, n_range = _receive_window(scene, t, tx_off, rx_off, gate)
    attrs: dict = {"frame": scene.target_frame.spec}
    if np.any(gate != 0):  # what the varied gate saves: the window a fixed gate needs for the same echoes
        attrs["fixed_gate_samples"] = _receive_window(scene, t, tx_off, rx_off, np.zeros_like(gate))[1]
    range_time = (first + np.arange(n_range)) / r.range_sampling_rate
    kinds = {e.product_kind for e in scene.effects if e.product_kind}
    kind = kinds.pop() if kinds else ("raw" if len(rx_off) == 1 else "raw_multichannel")
    radar = r.replace(n_channels=len(rx_off))
    multi = kind != "raw"
    dims = ("channel", "azimuth_time", "range_time") if multi else ("azimuth_time", "range_time")
    coords = {"azimuth_time": t, "range_time": range_time}
    if multi:
        coords["channel"] = np.arange(len(rx_off))
    aux = {"platform_position": _positions(scene, t), "tx_offset": tx_off, "rx_offset": rx_off}
    if np.any(gate != 0):
        aux["range_gate_offset"] = gate
    for e in scene.effects:
        aux.update(e.aux())
    for e in scene.effects:
        attrs.update(e.product_attrs(radar, aux))
    return SimulationPlan(
        kind=kind,
        dims=dims,
        coords=coords,
        radar=radar,
        targets=scene.targets_table(),
        aux=aux,
        tx_offset=tx_off,
        rx_offsets=rx_off,
        block_pulses=scene.params.simulation.block_pulses,
        attrs=attrs,
    )


LIT_FRACTION_MIN = 0.95  # a target lit over less of its full -3 dB aperture than this is warned about


def illumination_warnings(scene: Scene, plan: SimulationPlan) -> list[str]:
    """One line per target outside the antenna's main beam or lit over only part of its aperture: the
    fraction of its full -3 dB aperture the track gives it and the along-track resolution it will have
    (sarproc.product.theory.illumination_survey); empty when every target is fully lit. Logged as warnings."""
    from sarproc.product.theory import illumination_survey, lobe_text

    pos = plan.aux["platform_position"] + plan.tx_offset
    survey = illumination_survey(plan.radar, pos, scene.target_xyz.reshape(-1, 3), LIT_FRACTION_MIN)
    lines = []
    for name, s in zip(scene.target_names, survey):
        if s.lit_fraction >= LIT_FRACTION_MIN:
            continue
        if s.lit_fraction == 0 and s.peak_gain_db < -300:
            what = "outside the beam over the whole aperture (the pattern has no gain there): 0 % of its full aperture"
        elif s.lit_fraction == 0:
            what = (
                f"outside the main beam over the whole aperture (lit by its side lobes only, strongest two-way "
                f"gain {s.peak_gain_db:.1f} dB): 0 % of its full -3 dB aperture"
            )
        else:
            what = f"only partly illuminated: {100 * s.lit_fraction:.0f} % of its full -3 dB aperture lies on the track"
        if s.peak_gain_db < -300 or (s.now is None and s.full is not None):
            loss = "; it is never lit: no response is expected"
        elif s.now is None or s.full is None:
            loss = "; resolution loss not computed (too many such targets)"
        else:
            loss = (
                f"; expected along-track IRW {s.now.irw:.3g} m instead of {s.full.irw:.3g} m ({s.loss:.2f}x), "
                f"PSLR {lobe_text(s.now.pslr_db)} instead of {lobe_text(s.full.pslr_db)} (antenna weighting, no window)"
            )
        lines.append(f"{scene.source}: target {name!r} is {what}{loss}")
    for line in lines:
        log.warning("%s", line)
    return lines


def echo_target_samples(scene: Scene, plan: SimulationPlan, n_pulses: int) -> float:
    """The echo kernel's work for ``n_pulses``: pulses x targets x channels x samples per pulse."""
    r = scene.radar
    per_pulse = r.pulse_duration * r.range_sampling_rate + 2
    return float(n_pulses) * len(_scatterers(scene)[0]) * len(plan.rx_offsets) * per_pulse


def echo_block(
    scene: Scene,
    plan: SimulationPlan,
    t: np.ndarray,
    chirp: np.ndarray | None = None,
    dtype: type = np.complex128,
) -> np.ndarray:
    """Echoes of pulses at times ``t`` for every channel: (n_ch, n_t, n_range) of ``dtype``.

    The kernels run compiled ahead of time where the block is small (:mod:`sarproc.simulation.echo_aot`), else
    in numba; the echoes are the same either way.

    Geometry, gate offsets and the effects' gains are evaluated here per (pulse, target); the
    samples themselves in the compiled :func:`echo_kernel.accumulate_echoes`, which sums in complex128
    and rounds each sample once into a complex64 block (bit for bit the cast of the complex128 one).
    """
    from sarproc.simulation import echo_aot

    r = scene.radar
    fs = r.range_sampling_rate
    t0 = float(plan.coords["range_time"][0])
    n_rg = len(plan.coords["range_time"])
    pos = _positions(scene, t)
    tg = _target_positions(scene, t)
    amplitude = _scatterers(scene)[2]
    gate = np.ascontiguousarray(_gate_offsets(scene, t, 2 * r.reference_range / C), dtype=float)
    band_limited = scene.params.simulation.waveform == "band_limited"
    if not band_limited:  # the continuous chirp's kernels (a band-limited block never loads them)
        k = echo_aot.kernels(echo_target_samples(scene, plan, len(t)))
        if chirp is None:  # the window's chirp is the same for every block: simulate_blocks passes it once
            chirp = echo_aot.window_chirp(k, n_rg, fs, r.chirp_rate)
    out: np.ndarray = np.zeros((len(plan.rx_offsets), len(t), n_rg), dtype=dtype)
    for ch, rx in enumerate(plan.rx_offsets):
        tau = _delays(pos + plan.tx_offset, pos + rx, tg)  # (n_t, n_tg)
        gains = np.broadcast_to(amplitude[None, :], tau.shape).astype(complex)
        for e in scene.effects:
            gains = e.gains(t, pos, tg, ch, gains)
        if band_limited:
            out[ch] = band_limited_echoes(r, tau, gains, gate, t0, n_rg)
            continue
        echo_aot.accumulate_echoes(
            k,
            out[ch],
            np.ascontiguousarray(tau),
            np.ascontiguousarray(gains, dtype=np.complex128),
            gate,
            t0,
            fs,
            r.pulse_duration,
            r.chirp_rate,
            r.carrier_frequency,
            chirp,
        )
    return out


def band_limited_echoes(
    radar: RadarMetadata,
    tau: np.ndarray,
    gains: np.ndarray,
    gate: np.ndarray,
    t0: float,
    n_range: int,
) -> np.ndarray:
    """Echoes (n_t, n_range) complex128 of a band-limited transmitter (simulation.waveform: band_limited):
    per pulse, every target's fractional-delay kernel (echo_kernel.accumulate_impulses, compiled ahead of time
    where the work is small: echo_aot.impulse_kernels) convolved with the processor's chirp replica
    (sarproc.dsp.rangecomp.chirp_replica), by FFT. Delays on a sample give the replica itself; in between, the
    echo's spectrum over |f| <= B/2 is the replica's times exp(-j 2 pi f tau) (to the filter's 120 dB), so
    range compression leaves no aliasing pedestal."""
    from sarproc.dsp.rangecomp import chirp_replica
    from sarproc.product import fft as sfft
    from sarproc.simulation import echo_aot

    fs = radar.range_sampling_rate
    replica, half = chirp_replica(radar)
    half_taps, beta = echo_aot.kaiser_design(fs, radar.bandwidth)
    k = echo_aot.impulse_kernels(tau.size * 2.0 * half_taps)
    offset = half + half_taps  # impulse row sample i is window sample i - offset
    impulses = np.zeros((tau.shape[0], n_range + 2 * offset), dtype=np.complex128)
    echo_aot.accumulate_impulses(
        k,
        impulses,
        np.ascontiguousarray(tau),
        np.ascontiguousarray(gains, dtype=np.complex128),
        np.ascontiguousarray(gate, dtype=float),
        float(t0),
        float(fs),
        float(radar.carrier_frequency),
        int(half_taps),
        _kaiser_table(half_taps, beta),
        float(echo_aot.KAISER_PER_SAMPLE),
        float(offset),
    )
    n_fft = sfft.next_fast_len(impulses.shape[1] + len(replica) - 1)
    spec = sfft.fft(impulses, n_fft, axis=-1, workers=-1)
    spec *= _replica_fft(radar, n_fft)
    full = sfft.ifft(spec, axis=-1, workers=-1, overwrite_x=True)
    return full[:, offset + half : offset + half + n_range]


@functools.lru_cache(maxsize=4)
def _replica_fft(radar: RadarMetadata, n_fft: int) -> np.ndarray:
    """FFT of the chirp replica zero-padded to ``n_fft`` (its first sample first), made once per simulation:
    every block and channel shares it (read only)."""
    from sarproc.dsp.rangecomp import chirp_replica
    from sarproc.product import fft as sfft

    spectrum: np.ndarray = sfft.fft(chirp_replica(radar)[0], n_fft)
    spectrum.flags.writeable = False
    return spectrum


@functools.lru_cache(maxsize=4)
def _kaiser_table(half_taps: int, beta: float) -> np.ndarray:
    """echo_aot.kaiser_table, made once per design (every block of a simulation shares it)."""
    from sarproc.simulation import echo_aot

    return echo_aot.kaiser_table(half_taps, beta)  # never written to (the kernels only read it)


def simulate_blocks(
    scene: Scene,
    plan: SimulationPlan | None = None,
    progress: ProgressFactory | None = None,
    mapper: Callable | None = None,
) -> Iterator[tuple[slice, np.ndarray]]:
    """Yield (pulse slice, (n_ch, n_t, n_range) complex64 block) over the whole acquisition.

    ``mapper`` (any map-like yielding in input order, e.g. one over Dask workers) computes the blocks'
    echoes elsewhere; the effects' finalize steps (noise from one seeded generator) run here, in
    order, so the data are the same with or without it.
    """
    import functools

    plan = plan or plan_simulation(scene)
    t_all = plan.coords["azimuth_time"]
    rng = np.random.default_rng(scene.params.simulation.seed)
    power = float(np.max(np.abs(scene.target_amplitude)) ** 2) if len(scene.target_amplitude) else 0.0
    step = plan.block_pulses
    slices = [slice(s, min(s + step, len(t_all))) for s in range(0, len(t_all), step)]
    from sarproc.simulation import echo_aot

    n_rg = len(plan.coords["range_time"])
    chirp = None  # band-limited blocks convolve the replica instead
    if scene.params.simulation.waveform != "band_limited":
        k = echo_aot.kernels(n_rg)
        chirp = echo_aot.window_chirp(k, n_rg, scene.radar.range_sampling_rate, scene.radar.chirp_rate)
    # A finalize step (noise) adds to the complex128 echoes before the one rounding; without one the
    # kernel rounds into complex64 itself, in parallel, instead of a serial cast here.
    finalizing = [e for e in scene.effects if type(e).finalize is not Effect.finalize]
    dtype = np.complex128 if finalizing else np.complex64
    block_echoes = functools.partial(echo_block, scene, plan, chirp=chirp, dtype=dtype)
    echoes = (mapper or map)(block_echoes, (t_all[sl] for sl in slices))
    for sl, block in zip(progress(slices) if progress is not None else slices, echoes):
        for e in finalizing:
            block = e.finalize(block, rng, power)
        yield sl, block.astype(np.complex64, copy=False)


def simulate(scene: Scene, progress: ProgressFactory | None = None) -> Product:
    """Simulate the whole scene in memory and return the raw product."""

    plan = plan_simulation(scene)
    illumination_warnings(scene, plan)
    data = np.zeros((len(plan.rx_offsets),) + plan.shape[-2:], dtype=np.complex64)
    for sl, block in simulate_blocks(scene, plan, progress):
        data[:, sl, :] = block
    if plan.kind == "raw":
        data = data[0]
    return Product(
        kind=plan.kind,
        data=data,
        dims=plan.dims,
        coords=plan.coords,
        radar=plan.radar,
        targets=plan.targets,
        attrs=plan.attrs,
        aux=plan.aux,
        history=[scene.history_entry("simulate")],
    )
