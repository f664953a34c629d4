"""Exact time-domain backprojection: the reference every fast focuser is checked against.

For each pixel P and pulse p, the two-way path R = |P_tx - P| + |P_rx - P| is computed in
float64, the range-compressed pulse is read at delay R / c (FFT upsampling followed by linear
interpolation) and multiplied by exp(+j 2 pi f_c R / c). Two engines compute this sum:

- ``reference``: numpy, float64 ranges for every pixel and pulse, pulses in blocks on threads (memory
  bounded by ``block_elements``); the float64 reference the compiled engine is tested against.
- ``compiled`` (the processor's default): the tiled numba kernel of
  :mod:`sarproc.focus.backprojection_kernel` (float64 per tile and pulse, float32 per pixel offset);
  it also reads the pulses through a short windowed-sinc / Knab kernel on the original samples.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import logging
import math
import os
import sys
from typing import TYPE_CHECKING, Any

import numpy as np

from sarproc.dsp.rangecomp import FILTERS, range_compress
from sarproc.product import beam, fft as sfft, moving, theory
from sarproc.product.config import as_dict, param
from sarproc.product.errors import IMAGE_DEFECT, InputError
from sarproc.product.frames import Frame, image_axis, make_frame, targets_in_frame
from sarproc.product.metadata import SINC_IRW_FACTOR, C
from sarproc.product.model import Product, target_names
from sarproc.product.theory import WINDOWS

log = logging.getLogger(__name__)

if TYPE_CHECKING:
    from collections.abc import Callable, Iterable, Iterator, Sequence
    from concurrent.futures import Executor
    from types import ModuleType

    from sarproc.product.steps import ProgressFactory


def upsample_range(
    rc: np.ndarray,
    factor: int,
    workers: int = -1,
    pad: int = 0,
    length: int | None = None,
    emphasis: np.ndarray | None = None,
) -> np.ndarray:
    """FFT zero-padding upsampling along the last axis of a baseband signal (band centred at 0).

    Returns complex64 (..., m + pad), m = n * factor or ``length`` (any m >= n: sample spacing n / m of the
    input's); the ``pad`` trailing samples are zero. ``emphasis``: weights of the n input bins (FFT order), e.g.
    :func:`read_emphasis`.
    """
    n = rc.shape[-1]
    m = n * factor if length is None else int(length)
    out: np.ndarray = np.zeros(rc.shape[:-1] + (m + pad,), np.complex64)
    if m == n:
        out[..., :n] = rc
        return out
    # Pulse by pulse in blocks, so the complex128 spectra never exceed a few tens of MB; the transforms run in
    # the input's precision (complex64 at least), the result is stored as complex64.
    rows = max(1, (32 << 20) // (16 * m))
    flat_in = rc.reshape(-1, n)
    flat_out = out.reshape(-1, out.shape[-1])
    work = np.result_type(rc.dtype, np.complex64)
    for s in range(0, flat_in.shape[0], rows):
        block = flat_in[s : s + rows]
        flat_out[s : s + rows, :m] = upsample_into(block, np.empty((len(block), m), work), workers, emphasis)
    return out


def upsample_into(rc: np.ndarray, buf: np.ndarray, workers: int = -1, emphasis: np.ndarray | None = None) -> np.ndarray:
    """upsample_range(rc, length=buf.shape[-1], emphasis=emphasis) of a (rows, n) block written into the reused
    buffer ``buf`` (rows, m), in its precision and in place (no zero-filled output, no copy of the inverse
    transform); returns buf."""
    n, m = rc.shape[-1], buf.shape[-1]
    if m == n:
        buf[...] = rc
        return buf
    pos = (n + 1) // 2
    spec = sfft.fft(rc, axis=-1, workers=workers)
    if emphasis is None:
        spec *= spec.real.dtype.type(m / n)  # the scale in the spectrum's own precision
    else:
        spec *= (emphasis * (m / n)).astype(spec.real.dtype)
    buf[:, :pos] = spec[:, :pos]
    buf[:, pos : m - (n - pos)] = 0
    buf[:, m - (n - pos) :] = spec[:, pos:]
    out = sfft.ifft(buf, axis=-1, workers=workers, overwrite_x=True)
    if out is not buf and not np.shares_memory(out, buf):
        buf[...] = out
    return buf


def read_emphasis(n: int, m: int, interpolation: str) -> np.ndarray | None:
    """Weights of an n-sample pulse's bins (FFT order) that undo the mean gain of ``interpolation``'s reads once
    upsampled to m samples: linear reads give a tone of f cycles per sample sinc^2(f) on average over the read
    fractions, a taper of the range spectrum (-0.08 dB at the band edge at x8 and 1.2x sampling) that left the
    image -48 dB from the truth; undone, -63 dB (the reads' artefacts; the bench scene against cubic x32, the
    commit adding this). None for other reads (cubic's loss is below -80 dB at x8) and without upsampling."""
    if interpolation != "linear" or m == n:
        return None
    f = sfft.fftfreq(n) * (n / m)  # each bin's frequency in cycles per upsampled sample
    return 1.0 / np.sinc(f) ** 2


def upsampled_length(n: int, factor: int) -> int:
    """Samples of a pulse of n upsampled about ``factor`` times: next_fast_len(n x factor) (1060 x 8 = 8480
    has the prime 53; 8505 transforms 2.5x faster), so the sample spacing is n / length of the input's."""
    return n if factor <= 1 else sfft.next_fast_len(n * factor)


def _ranges(platform: np.ndarray, points_c: np.ndarray, points_sq: np.ndarray) -> np.ndarray:
    """|platform - point| (n_b, n_points) via |p|^2 + |t|^2 - 2 t.p.

    Both sets are relative to the points' centroid, so the squared norms stay near r^2 and
    the float64 cancellation error is ~1e-16 r^2 / r, far below a millimetre even at 800 km.
    The three-term dot product is written out elementwise: a (n_b x 3) @ (3 x n) BLAS call gains
    nothing and, from the pool threads, each call started its own BLAS threads (oversubscription).
    """
    r2 = np.multiply.outer(platform[:, 0], -2.0 * points_c[:, 0])
    for i in (1, 2):
        r2 -= np.multiply.outer(2.0 * platform[:, i], points_c[:, i])
    r2 += points_sq[None, :]
    r2 += np.einsum("ij,ij->i", platform, platform)[:, None]
    return np.sqrt(r2, out=r2)


def _backproject_block(s: int, e: int, c: _ReferenceChunk) -> np.ndarray:
    """Sum over pulses s .. e of chunk ``c`` at every point (reference engine, float64 ranges)."""
    r = _ranges(c.tx_c[s:e], c.points.points_c, c.points.points_sq)
    if c.monostatic:
        r *= 2.0
    else:
        r += _ranges(c.rx_c[s:e], c.points.points_c, c.points.points_sq)
    # Fractional sample of the upsampled pulse: (R / c - t0 - gate) * f_s * upsample.
    pos = r * (c.scale / C)
    pos -= ((c.t0 + c.gate[s:e]) * c.scale)[:, None]
    rows = (np.arange(s, e) * c.stride)[:, None]
    val = _read_nearest(c.flat, pos, rows, c.n_up) if c.interpolation == "nearest" else _read_linear(c, pos, rows)
    # Carrier phase in float64 cycles, reduced to [0, 1) before the complex64 exponential.
    cyc = r * (c.carrier_frequency / C)
    cyc -= np.floor(cyc)
    from sarproc.dsp.phasor import unit_phasor  # numba: imported where the reference engine runs

    val *= unit_phasor(cyc)
    return val.sum(axis=0, dtype=np.complex128)


def _read_nearest(flat: np.ndarray, pos: np.ndarray, rows: np.ndarray, n_up: int) -> np.ndarray:
    idx = np.rint(pos).astype(np.int64)
    idx[(idx < 0) | (idx >= n_up)] = n_up  # the zero sample
    return flat[idx + rows]


def _read_linear(c: _ReferenceChunk, pos: np.ndarray, rows: np.ndarray) -> np.ndarray:
    i0 = np.floor(pos)
    w = (pos - i0).astype(np.float32)
    i0 = i0.astype(np.int64)
    # Samples outside the pulse are zero on both sides: i0 = -1 pairs the previous row's zero sample (the
    # last row's for the first pulse, by wrap-around) with sample 0, i0 = n_up - 1 the last sample with
    # this row's zero sample; further out, weight 1 on the zero sample gives exactly 0.
    outside = (i0 < -1) | (i0 >= c.n_up)
    i0[outside] = c.n_up - 1
    w[outside] = 1.0
    i0 += rows
    lo = c.flat[i0]
    return lo + (c.flat[i0 + 1] - lo) * w


ENGINES = ("compiled", "reference", "ffbp")
INTERPOLATIONS = ("linear", "nearest", "cubic", "knab", "sinc", "lanczos")


@dataclasses.dataclass(frozen=True)
class _Pulses:
    """Range-compressed pulses and where they were sent and received: what both engines read."""

    rc: np.ndarray  # (n_az, n_rg) complex
    t0: float  # delay of the first range sample, s
    dt: float  # range sample spacing, s
    gate: np.ndarray  # (n_az,) each pulse's range-window offset, s
    tx_pos: np.ndarray  # (n_az, 3) m
    rx_pos: np.ndarray  # (n_az, 3) m
    monostatic: bool
    carrier_frequency: float


def _pulses(
    rc: np.ndarray,
    range_time: np.ndarray,
    tx_pos: np.ndarray,
    rx_pos: np.ndarray,
    carrier_frequency: float,
    gate_offset: np.ndarray | None,
) -> _Pulses:
    rc = np.asarray(rc)
    n_az, n_rg = rc.shape
    if n_az == 0:  # the sum over pulses divided by n_az would be 0 / 0
        raise ValueError("backproject_points: no pulses (rc has 0 rows)")
    tx_pos, rx_pos = np.asarray(tx_pos, float), np.asarray(rx_pos, float)
    return _Pulses(
        rc=rc,
        t0=range_time[0],
        dt=(range_time[-1] - range_time[0]) / (n_rg - 1) if n_rg > 1 else 1.0,
        gate=np.zeros(n_az) if gate_offset is None else np.asarray(gate_offset, float),
        tx_pos=tx_pos,
        rx_pos=rx_pos,
        monostatic=np.array_equal(tx_pos, rx_pos),
        carrier_frequency=carrier_frequency,
    )


@dataclasses.dataclass(frozen=True)
class _Reads:
    """How the compiled engine reads a pulse: on the signal upsampled ``upsample`` times, by ``interpolation``
    (a tap kernel of ``kernel_length`` taps, Knab designed for ``oversampling``, where it is one)."""

    upsample: int
    interpolation: str
    kernel_length: int
    oversampling: float


# Pixels per tile of the compiled engine unless the carrier-cycle cap (MAX_TILE_RADIUS_CYCLES) makes them fewer.
DEFAULT_TILE_POINTS = 1024

# Range upsampling of the pulses by default: linear reads at x8 leave -55 dB of error on the bp scenes, enough to
# misread a weak target's side lobes by ~1 dB; x16 costs the same per pixel-pulse (docs/performance.md). ffbp
# holds every upsampled pulse at once, so it keeps x8 (its own reads' error dominates).
EXACT_UPSAMPLE = 16
FFBP_UPSAMPLE = 8


def backproject_points(
    rc: np.ndarray,
    range_time: np.ndarray,
    tx_pos: np.ndarray,
    rx_pos: np.ndarray,
    points: np.ndarray,
    carrier_frequency: float,
    *,
    upsample: int = EXACT_UPSAMPLE,
    interpolation: str = "linear",
    gate_offset: np.ndarray | None = None,
    block_elements: int = 131_072,
    progress: ProgressFactory | None = None,
    workers: int | None = None,
    engine: str = "reference",
    kernel_length: int = 8,
    oversampling: float | None = None,
    tile_points: int = DEFAULT_TILE_POINTS,
) -> np.ndarray:
    """Backproject range-compressed pulses onto arbitrary points.

    rc: (n_az, n_range) complex range-compressed data; range_time: (n_range,) s, uniform;
    tx_pos, rx_pos: (n_az, 3) m; points: (n_points, 3) m; gate_offset: (n_az,) s or None;
    interpolation: 'linear' or 'nearest' on the range signal upsampled ``upsample`` times, or (compiled
    engine only) 'cubic' (four-sample Lagrange) on it, or 'knab' / 'sinc' / 'lanczos' with ``kernel_length``
    taps on the (upsampled) samples,
    Knab designed for ``oversampling`` (default 1.25 x upsample).
    engine: 'reference' (numpy, float64 per pixel, pulse blocks on ``workers`` threads) or 'compiled'
    (numba, tiles of about ``tile_points`` pixels on ``workers`` threads; default: all cores).
    Returns (n_points,) complex128: the sum over pulses divided by n_az.
    """
    pulses = _pulses(rc, range_time, tx_pos, rx_pos, carrier_frequency, gate_offset)
    points = np.asarray(points, float).reshape(-1, 3)
    if interpolation not in INTERPOLATIONS:
        raise ValueError(f"unknown interpolation {interpolation!r}; known: {INTERPOLATIONS}")
    if engine == "compiled":
        reads = _Reads(upsample, interpolation, kernel_length, oversampling or 1.25 * upsample)
        return _backproject_compiled(pulses, points, reads, tile_points, progress, workers)
    if engine != "reference":
        raise ValueError(f"unknown backprojection engine {engine!r}; known: {ENGINES}")
    if interpolation not in ("linear", "nearest"):
        raise ValueError(f"the reference engine interpolates 'linear' or 'nearest', not {interpolation!r}")
    return _backproject_reference(pulses, points, upsample, interpolation, block_elements, progress, workers)


@dataclasses.dataclass(frozen=True)
class _CentredPoints:
    """The points relative to their centroid ``origin`` and their squared norms (see :func:`_ranges`)."""

    origin: np.ndarray
    points_c: np.ndarray
    points_sq: np.ndarray


def _centred(points: np.ndarray) -> _CentredPoints:
    origin = points.mean(axis=0) if len(points) else np.zeros(3)
    points_c = points - origin
    return _CentredPoints(origin, points_c, np.einsum("ij,ij->i", points_c, points_c))


@dataclasses.dataclass(frozen=True)
class _ReferenceChunk:
    """A chunk of pulses upsampled for the reference engine, with what its blocks read beside them."""

    flat: np.ndarray  # the upsampled pulses, each followed by one zero sample, flattened
    stride: int  # samples per pulse in flat (n_up + 1)
    n_up: int  # upsampled samples per pulse
    scale: float  # upsampled samples per second
    t0: float
    gate: np.ndarray  # the chunk's pulses'
    tx_c: np.ndarray  # the chunk's positions relative to the points' centroid
    rx_c: np.ndarray
    monostatic: bool
    points: _CentredPoints
    carrier_frequency: float
    interpolation: str


def _reference_spans(
    n_az: int, n_points: int, block_elements: int
) -> tuple[list[tuple[int, int]], list[list[tuple[int, int]]]]:
    """Chunks of pulses upsampled at a time (at most 64 pulses, whole blocks) and, per chunk, its blocks of pulses
    (``block_elements`` pixel-pulses each) relative to the chunk's start."""
    block = max(1, min(64, int(block_elements // max(n_points, 1))))
    chunk = block * max(1, 64 // block)
    chunks = [(c, min(c + chunk, n_az)) for c in range(0, n_az, chunk)]
    spans = [[(s - c0, min(s + block, c1) - c0) for s in range(c0, c1, block)] for c0, c1 in chunks]
    return chunks, spans


def _backproject_reference(
    pulses: _Pulses,
    points: np.ndarray,
    upsample: int,
    interpolation: str,
    block_elements: int,
    progress: ProgressFactory | None,
    workers: int | None,
) -> np.ndarray:
    """The reference engine: numpy, float64 ranges, blocks of pulses summed on ``workers`` threads."""
    from concurrent.futures import ThreadPoolExecutor

    p = pulses
    n_az, n_rg = p.rc.shape
    # One zero sample past each pulse: reads outside the window land on it and add nothing. Pulses are upsampled
    # a chunk at a time (the whole upsampled history was 3x the input and output together).
    n_up = upsampled_length(n_rg, upsample)
    emphasis = read_emphasis(n_rg, n_up, interpolation)
    centred = _centred(points)
    chunks, spans = _reference_spans(n_az, len(points), block_elements)
    tx_c, rx_c = p.tx_pos - centred.origin, p.rx_pos - centred.origin

    def parts(pool: Executor) -> Iterator[np.ndarray]:
        for (c0, c1), local in zip(chunks, spans):
            chunk = _ReferenceChunk(
                flat=upsample_range(p.rc[c0:c1], upsample, pad=1, length=n_up, emphasis=emphasis).ravel(),
                stride=n_up + 1,
                n_up=n_up,
                scale=n_up / (n_rg * p.dt),
                t0=p.t0,
                gate=p.gate[c0:c1],
                tx_c=tx_c[c0:c1],
                rx_c=rx_c[c0:c1],
                monostatic=p.monostatic,
                points=centred,
                carrier_frequency=p.carrier_frequency,
                interpolation=interpolation,
            )
            yield from pool.map(lambda span, c=chunk: _backproject_block(span[0], span[1], c), local)

    acc = np.zeros(len(points), np.complex128)
    with ThreadPoolExecutor(max_workers=workers or os.cpu_count() or 1) as pool:
        results: Iterable[np.ndarray] = parts(pool)
        if progress is not None:
            results = progress(results, total=sum(len(x) for x in spans))
        for part in results:
            acc += part
    return acc / n_az


# Largest tile radius in carrier cycles of one leg's path: a pixel's float32 offset of up to 2 x this many cycles
# (monostatic) carries a rounding error of ~2^-24 of it, 3e-5 cycles (2e-4 rad) at 256.
MAX_TILE_RADIUS_CYCLES = 256.0


# Pulses per chunk of the compiled engine, and the most bytes its upsampled pulses and tables may take (at least
# 64 pulses whatever that takes).
CHUNK_PULSES = 256
CHUNK_BYTES = 64 << 20


def _tile_size(
    points: np.ndarray,
    tile_points: int,
    max_radius: float = np.inf,
    bounds: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]] | None = None,
) -> float:
    """Edge (m) of a square/cubic tile holding about ``tile_points`` points of a regular grid, capped so that a
    tile's half-diagonal stays within ``max_radius`` (m): sparse points would otherwise make huge tiles.

    A dimension thinner than the edge the others give (a flat grid with micrometres of height noise, a narrow
    strip) does not count: counted, it would shrink the tiles to single points. ``bounds``: the points'
    per-axis min and max (default: the numba kernel's)."""
    if bounds is None:
        from sarproc.focus.backprojection_kernel import bounds as numba_bounds

        bounds = numba_bounds
    lo, hi = bounds(np.ascontiguousarray(points, dtype=float))
    return tile_edge(hi - lo, len(points), tile_points, max_radius)


def tile_edge(extents: np.ndarray, n_points: int, tile_points: int, max_radius: float = np.inf) -> float:
    """:func:`_tile_size`'s rule from the points' extents (m, per axis) and their number."""
    ext = np.sort(np.asarray(extents, float))[::-1]
    ext = ext[ext > 1e-9 * max(float(ext[0]), 1.0)]
    if len(ext) == 0:
        return 1.0
    while True:
        cell = (float(np.prod(ext)) / n_points) ** (1.0 / len(ext))
        edge = cell * tile_points ** (1.0 / len(ext))
        if len(ext) == 1 or ext[-1] >= edge:
            break
        ext = ext[:-1]  # the thinnest dimension fits inside one tile: drop it
    return min(edge, 2 * max_radius / math.sqrt(len(ext)))


def grid_tile_count(shape: tuple[int, ...], spacings: tuple[float, ...], carrier_frequency: float) -> int:
    """About how many tiles the compiled engine makes of a regular grid (``shape`` pixels ``spacings`` m apart
    per axis), for its time estimate: pixels coarse against the wavelength make tiles of tens of pixels under the
    carrier-cycle cap, and each tile costs the same per pulse whatever it holds."""
    edge, _ = _grid_tile_edges(shape, spacings, carrier_frequency)
    return _squares(shape, spacings, edge)


def grid_block_count(shape: tuple[int, ...], spacings: tuple[float, ...], carrier_frequency: float) -> int:
    """About how many blocks of tiles (:func:`tile_block`) the compiled engine runs a regular grid's tiles in on
    linear monostatic reads: :func:`grid_tile_count` where the tiles are not capped, fewer where they are."""
    edge, uncapped = _grid_tile_edges(shape, spacings, carrier_frequency)
    if edge == 0:
        return 0
    # per axis, as make_tiles lays them: whole blocks of g cells over the grid's span (the partial blocks at the
    # edges count, a large share where a block is ~45 m and the grid only a few blocks wide)
    g = tile_block(edge, uncapped, True)
    count = 1
    for k, d in zip(shape, spacings, strict=True):
        count *= -(-(math.floor((k - 1) * d / edge) + 1) // g)
    return count


def _grid_tile_edges(
    shape: tuple[int, ...], spacings: tuple[float, ...], carrier_frequency: float
) -> tuple[float, float]:
    """(capped, uncapped) tile edges (m) of :func:`_tiles` for a regular grid (0, 0 for an empty one)."""
    n = int(np.prod(shape))
    if n == 0:
        return 0.0, 0.0
    ext = np.array([k * d for k, d in zip(shape, spacings, strict=True)], float)
    capped = tile_edge(ext, n, DEFAULT_TILE_POINTS, MAX_TILE_RADIUS_CYCLES * C / carrier_frequency)
    return capped, tile_edge(ext, n, DEFAULT_TILE_POINTS)


def _squares(shape: tuple[int, ...], spacings: tuple[float, ...], side: float) -> int:
    """How many squares (cubes) of edge ``side`` (m) cover a regular grid: 0 for an empty grid."""
    n = int(np.prod(shape))
    if n == 0:
        return 0
    per_square = 1.0
    for k, d in zip(shape, spacings, strict=True):
        per_square *= min(float(k), max(1.0, side / d)) if d > 0 else 1.0
    return max(1, math.ceil(n / per_square))


@contextlib.contextmanager
def numba_threads(workers: int | None) -> Iterator[None]:
    """numba's parallel kernels on ``workers`` threads (None or 0: as set) inside the block, restored after."""
    import numba

    old = numba.get_num_threads()
    if workers:
        numba.set_num_threads(max(1, min(int(workers), numba.config.NUMBA_NUM_THREADS)))
    try:
        yield
    finally:
        numba.set_num_threads(old)


def _run_all(fn: Callable[[Any], Any], items: Iterable[Any]) -> None:
    for item in items:
        fn(item)


@contextlib.contextmanager
def _thread_map(threads: int) -> Iterator[Callable[[Callable[[Any], Any], Iterable[Any]], None]]:
    """A function calling fn(item) for each item on ``threads`` threads and returning when all are done (in turn
    on one thread); the calls must release the GIL to run side by side."""
    if threads <= 1:
        yield _run_all
        return
    from concurrent.futures import ThreadPoolExecutor

    with ThreadPoolExecutor(max_workers=threads) as pool:

        def run(fn: Callable[[Any], Any], items: Iterable[Any]) -> None:
            for _ in pool.map(fn, items):  # re-raises a call's exception
                pass

        yield run


def _table_rows(kernel: Any, pulses: np.ndarray, lo: np.ndarray, out: np.ndarray, rows: tuple[int, int]) -> None:
    """The read tables (pair_table / cubic_table) of pulses rows[0] .. rows[1]."""
    r0, r1 = rows
    kernel(pulses[r0:r1], lo[r0:r1], out[r0:r1])


def _tile_sums(kernel: Any, head: tuple, tiles: _Tiles, tail: tuple, group: tuple[int, int]) -> None:
    """backproject_tiles(*head, tiles' centres and starts, offsets, *tail) over the blocks of tiles of ``group``:
    each tile adds into its own pixels of the sum (tail[-1]), so groups may run side by side."""
    b0, b1 = group
    kernel(*head, tiles.centres, tiles.start, tiles.blocks[b0 : b1 + 1], tiles.d, *tail)


def _even_spans(n: int, parts: int) -> list[tuple[int, int]]:
    """0 .. n in at most ``parts`` contiguous spans of near-equal length, none empty."""
    cuts = sorted({n * i // parts for i in range(parts + 1)})
    return list(zip(cuts[:-1], cuts[1:]))


def _tile_groups(start: np.ndarray, parts: int) -> list[tuple[int, int]]:
    """Tiles 0 .. len(start) - 1 in at most ``parts`` contiguous groups of near-equal pixel counts (start: each
    tile's first pixel, then the pixel count), none empty."""
    n_tiles = len(start) - 1
    cuts = np.searchsorted(start, np.arange(1, parts) * (start[-1] / parts))
    edges = sorted({0, n_tiles, *(int(c) for c in cuts if 0 < c < n_tiles)})
    return list(zip(edges[:-1], edges[1:]))


# The compiled kernels' read modes: 2 is a tap kernel (knab, sinc, lanczos) on the upsampled samples.
_READ_MODES = {"nearest": 0, "linear": 1, "cubic": 3}


def _tap_table(reads: _Reads) -> tuple[int, np.ndarray]:
    """Taps and weight table of a tap-kernel read; (0, a dummy table) for the other modes."""
    if _READ_MODES.get(reads.interpolation, 2) != 2:
        return 0, np.zeros((2, 1), np.float32)
    from sarproc.dsp.interp import kernel_length as taps_of, tap_table
    from sarproc.focus import backprojection_kernel as bk

    taps = taps_of(reads.interpolation, reads.kernel_length)
    return taps, tap_table(reads.interpolation, taps, reads.oversampling, np.float32, steps=bk._TABLE_STEPS)


@dataclasses.dataclass(frozen=True)
class _Tiles:
    """The points sorted into tiles (the kernels' make_tiles): ``order`` the sorted points' original indices,
    tile t's points ``start[t] .. start[t + 1]``, its centre ``centres[t]`` relative to ``origin``, and ``d``
    the points' float32 offsets from their tile's centre (row 3: squared distance); tiles ``blocks[b] ..
    blocks[b + 1]`` the kernel runs together."""

    order: np.ndarray
    start: np.ndarray
    centres: np.ndarray
    origin: np.ndarray
    d: np.ndarray
    blocks: np.ndarray


# A block's edge over that of an uncapped tile: the block pass does nothing per tile, so a block is bounded by its
# scratch (L2) and its expansion; blocks of ~2 tile_points pixels halve the per-block-pulse cost (~0.1 us) against
# blocks of one tile's edge: scripts/tile_cost.py's 1.4 x 2.2 m grid 0.81 -> 0.73 s (one thread).
BLOCK_EDGE_FACTOR = 1.5


def tile_block(edge: float, uncapped: float, blocks: bool) -> int:
    """Tiles a side of the compiled engine's blocks: as many as fit BLOCK_EDGE_FACTOR x the edge ``uncapped`` (m)
    a tile of ``tile_points`` would have where the carrier-cycle cap cut the tiles to ``edge`` (m), on linear
    monostatic reads (``blocks``); else 1."""
    return max(1, int(BLOCK_EDGE_FACTOR * uncapped / edge)) if blocks and edge > 0 else 1


def _tiles(
    points: np.ndarray, tile_points: int, carrier_frequency: float, aot: ModuleType | None, blocks: bool = False
) -> _Tiles:
    """Tiles of about ``tile_points`` points, small enough in carrier cycles for the float32 offsets; where that
    makes them smaller, blocks of them of about ``tile_points`` points (on linear monostatic reads, ``blocks``)."""
    from sarproc.focus import backprojection_aot

    if aot is None:
        from sarproc.focus import backprojection_kernel as bk

        lo, hi = bk.bounds(np.ascontiguousarray(points, dtype=float))
    else:
        lo, hi = aot.bounds(np.ascontiguousarray(points, dtype=float))
    edge = tile_edge(hi - lo, len(points), tile_points, MAX_TILE_RADIUS_CYCLES * C / carrier_frequency)
    block = tile_block(edge, tile_edge(hi - lo, len(points), tile_points), blocks)
    if aot is None:
        return _Tiles(*bk.make_tiles(points, edge, max_tile=4 * tile_points, block=block))
    return _Tiles(*backprojection_aot.make_tiles(points, edge, aot, max_tile=4 * tile_points, block=block))


@dataclasses.dataclass(frozen=True)
class _Windows:
    """Where each pulse is read: ``first`` the fractional position of the pulse's start (upsampled samples; with
    table reads, table entries of the window starting at ``lo``, n_w samples wide), ``entry`` the bytes per
    pulse of those tables (0 without)."""

    first: np.ndarray
    lo: np.ndarray | None = None
    n_w: int = 0
    entry: int = 0


def _pulse_windows(
    k: Any, mode: int, pulses: _Pulses, tiles: _Tiles, tx_c: np.ndarray, rx_c: np.ndarray, n_up: int, fs_up: float
) -> _Windows:
    """Each pulse's window of samples the pixels can reach, for the linear and cubic reads' tables."""
    first = -(pulses.t0 + pulses.gate) * fs_up
    if mode not in (1, 3):
        return _Windows(first)
    radius = np.sqrt(np.maximum.reduceat(tiles.d[3], tiles.start[:-1])).astype(float)
    lo, hi = k.pulse_windows(
        first, fs_up / C, tx_c, rx_c, pulses.monostatic, tiles.centres, radius, n_up, 1 if mode == 1 else 2
    )
    n_w = int((hi - lo).max()) + 3
    # positions counted in table entries
    return _Windows(first - lo + 1, lo, n_w, (n_w + 1) * (16 if mode == 1 else 32))


def _chunk_pulses(n_az: int, n_up: int, entry: int) -> int:
    """Pulses upsampled and backprojected at a time: up to CHUNK_PULSES (each tile's pixels and sums are read once
    per chunk, so fewer chunks move less memory on big grids), the chunk's samples and tables within CHUNK_BYTES;
    chunks of even sizes."""
    chunk = max(1, min(n_az, CHUNK_PULSES, max(64, CHUNK_BYTES // (8 * n_up + entry))))
    return -(-n_az // -(-n_az // chunk))


def _backproject_compiled(
    pulses: _Pulses,
    points: np.ndarray,
    reads: _Reads,
    tile_points: int,
    progress: ProgressFactory | None,
    workers: int | None,
) -> np.ndarray:
    """The compiled engine: tiles of points on numba's threads (or, small images on linear reads, on Python
    threads in the kernels compiled ahead of time), chunks of pulses upsampled and read through the mode's
    tables."""
    from sarproc.focus import backprojection_aot

    p = pulses
    n_az, n_rg = p.rc.shape
    if len(points) == 0:
        return np.zeros(0, np.complex128)
    mode = _READ_MODES.get(reads.interpolation, 2)
    # a small image on linear reads: the kernels compiled ahead of time, on threads, without numba's start-up
    # (sarproc.focus.backprojection_aot); otherwise, or while that module is not built, or where numba's kernels
    # are loaded already (their threads cost no start-up: sarproc.product.aot.Kernels.pick), the numba kernels
    small = mode == 1 and backprojection_aot.compiled_pays(len(points) * n_az, workers)
    numba_loaded = "sarproc.focus.backprojection_kernel" in sys.modules
    aot = backprojection_aot.load() if small and not numba_loaded else None
    if aot is None:
        from sarproc.focus import backprojection_kernel as bk
    k = bk if aot is None else aot
    taps, table = _tap_table(reads)
    tiles = _tiles(points, tile_points, p.carrier_frequency, aot, mode == 1 and p.monostatic)
    n_up = upsampled_length(n_rg, reads.upsample)
    emphasis = read_emphasis(n_rg, n_up, reads.interpolation)
    fs_up = n_up / (n_rg * p.dt)
    tx_c = np.ascontiguousarray(p.tx_pos - tiles.origin)
    rx_c = np.ascontiguousarray(p.rx_pos - tiles.origin)
    win = _pulse_windows(k, mode, p, tiles, tx_c, rx_c, n_up, fs_up)
    chunk = _chunk_pulses(n_az, n_up, win.entry)
    spans = [(s, min(s + chunk, n_az)) for s in range(0, n_az, chunk)]
    if mode in (1, 3):
        pairs = np.empty((chunk, win.n_w + 1, 4 if mode == 1 else 8), np.float32)
    else:
        pairs = np.zeros((1, 1, 4), np.float32)
    acc = np.zeros(len(points), np.complex128)
    # the compiled module's kernels are serial and release the GIL: its calls go to threads, each on a share of
    # the pulses (tables) or of the tiles (sums: each tile adds into its own pixels, so the sums are the same)
    threads = 1 if aot is None else int(workers or backprojection_aot.available_threads())
    n_blocks = len(tiles.blocks) - 1
    groups = _tile_groups(tiles.start[tiles.blocks], 4 * threads) if threads > 1 else [(0, n_blocks)]
    with numba_threads(workers) if aot is None else contextlib.nullcontext(), _thread_map(threads) as run:
        buf = np.empty((chunk, n_up), np.complex64)
        for s, e in progress(spans) if progress is not None else spans:
            chunk_pulses = upsample_into(np.asarray(p.rc[s:e], np.complex64), buf[: e - s], emphasis=emphasis)
            if mode in (1, 3):
                assert win.lo is not None
                tables = k.pair_table if mode == 1 else k.cubic_table
                rows = _even_spans(e - s, threads)
                run(functools.partial(_table_rows, tables, chunk_pulses, win.lo[s:e], pairs), rows)
            head: tuple = (chunk_pulses, pairs[: e - s], win.first[s:e], fs_up / C, p.carrier_frequency / C)
            head += (tx_c[s:e], rx_c[s:e], p.monostatic)
            run(functools.partial(_tile_sums, k.backproject_tiles, head, tiles, (mode, table, taps, acc)), groups)
    if aot is None and small:
        # for the next small image (once; in the background); also where numba's kernels were loaded already:
        # the plan's cache check (product.budget.kernels_cached) loads them while the module is not built
        backprojection_aot.request_build()
    out = np.empty_like(acc)
    k.scatter_scaled(acc, tiles.order, float(n_az), out)
    return out


@dataclasses.dataclass(frozen=True)
class BackprojectParams:
    frame: str = param(
        default="product",
        doc="image frame: product (the raw product's target frame), squint, zero_doppler, ground or los",
    )
    azimuth_extent: float | None = param(
        "length",
        default=None,
        gt=0,
        doc="grid size along azimuth; "
        "default: the targets' span plus 2 x margin_cells (moving targets: where they "
        "appear, sarproc.product.moving)",
    )
    range_extent: float | None = param("length", default=None, gt=0, doc="grid size along range; default as azimuth")
    azimuth_spacing: float | None = param("length", default=None, gt=0, doc="default: theoretical IRW / oversample")
    range_spacing: float | None = param("length", default=None, gt=0, doc="default: theoretical IRW / oversample")
    azimuth_center: float | None = param(
        "length",
        default=None,
        doc="grid centre (frame coordinate); default: middle of the targets, else the scene centre",
    )
    range_center: float | None = param("length", default=None, doc="grid centre along range (frame coordinate)")
    elevation_extent: float | None = param(
        "angle",
        default=None,
        gt=0,
        doc="3D frames only (frame elevation, raw_array products): grid size along elevation; default as azimuth",
    )
    elevation_spacing: float | None = param(
        "angle", default=None, gt=0, doc="3D frames only: default theoretical IRW / oversample"
    )
    elevation_center: float | None = param(
        "angle", default=None, doc="3D frames only: grid centre along elevation (from nadir, towards +y)"
    )
    oversample: float = param(default=2.0, ge=1.0, doc="pixels per theoretical IRW for default spacings")
    margin_cells: float = param(default=24.0, ge=0, doc="resolution cells around the targets for default extents")
    upsample: int | None = param(
        default=None,
        ge=1,
        le=64,
        doc="range FFT upsampling before interpolation (the length is rounded up to a fast FFT length); "
        "default 16 for the exact engines (linear reads at 8 misread a weak target's side lobes by up to "
        "1.2 dB, docs/performance.md), 8 for ffbp (it holds every upsampled pulse at once)",
    )
    interpolation: str = param(
        default="linear",
        choices=INTERPOLATIONS,
        doc="range interpolation: linear / nearest on the upsampled pulse, or (compiled "
        "engine) cubic (four-sample Lagrange) on it or a kernel_length-tap knab / sinc / "
        "lanczos kernel on its samples",
    )
    kernel_length: int = param(default=8, ge=2, le=32, doc="taps of the knab / sinc / lanczos range kernel")
    engine: str = param(
        default="compiled",
        choices=ENGINES,
        doc="compiled (tiled numba kernel, float32 per-pixel offsets), reference (float64 numpy) or "
        "ffbp (fast factorised backprojection, O(N^2 log N), error predicted in the plan)",
    )
    ffbp_factor: int = param(default=4, ge=2, le=64, doc="ffbp: subapertures merged per level")
    ffbp_first_factor: int = param(
        default=16,
        ge=2,
        le=256,
        doc="ffbp: pulses merged by the first level (cheap 1D reads of the pulses; larger saves a level)",
    )
    ffbp_oversample: float = param(
        default=1.5,
        ge=1.0,
        le=16.0,
        doc="ffbp: polar grid sampling over Nyquist "
        "(range by the bandwidth, angle by the subaperture length); the error knob",
    )
    ffbp_interpolation: str = param(
        default="knab",
        choices=("knab", "cubic", "linear"),
        doc="ffbp: reads of the polar subimages (ffbp_taps-tap Knab for the oversampling, 4-sample Lagrange or linear)",
    )
    ffbp_taps: int = param(default=12, ge=2, le=16, doc="ffbp: taps per axis of the knab reads (even)")
    range_window: str = param(default="none", choices=WINDOWS, doc="range spectral taper (README: Windows)")
    range_filter: str = param(
        default="flat",
        choices=FILTERS,
        doc="range compression: flat (divide by the chirp spectrum in the band: an exact rect spectrum) or "
        "matched (conjugate chirp spectrum, array3d's default)",
    )
    azimuth_window: str = param(default="none", choices=WINDOWS, doc="taper over the pulses (README: Windows)")
    max_pixels: int = param(default=16_000_000, ge=1, doc="refuse grids larger than this")
    block_pixels: int = param(
        default=4_194_304,
        ge=1,
        doc="pixels summed per output block (whole rows); the command line writes block by block and "
        "spreads blocks over --scheduler workers, and shrinks blocks to fit --max-memory",
    )

    @property
    def range_upsample(self) -> int:
        """``upsample``, or the engine's default where the config leaves it out."""
        if self.upsample is not None:
            return self.upsample
        return FFBP_UPSAMPLE if self.engine == "ffbp" else EXACT_UPSAMPLE


def _unit_los(tx: np.ndarray, points: np.ndarray) -> np.ndarray:
    d = points[None, :, :] - tx[:, None, :]
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def theoretical_irw(product: Product, frame: Frame, centre_coords: Sequence[float]) -> list[float]:
    """Theoretical -3 dB widths along each frame axis at ``centre_coords``, axis units.

    Range axis: 0.886 / ((2B/c) |u . e_range|) with u the line of sight at the aperture
    centre; azimuth axis: 0.886 / ((2/lambda) span_t(u(t) . e_azimuth)) over the pulses whose
    -3 dB beam contains the point (all pulses without an antenna pattern). This is the width of
    uniform weighting over that span; a tapered antenna pattern widens the real response.
    """
    r = product.radar
    pos = product.aux["platform_position"]
    p0 = frame.to_xyz(*centre_coords)
    lit = beam.illuminated(r, pos, p0)
    if np.any(lit):
        pos = pos[lit]
    eps = 1e-3
    widths = []
    u = _unit_los(pos, p0.reshape(1, 3))[:, 0, :]
    u_mid = u[len(u) // 2]
    for i, ax in enumerate(frame.axes):
        shifted = list(centre_coords)
        shifted[i] = shifted[i] + eps
        e = (frame.to_xyz(*shifted) - p0) / eps  # derivative of position along the axis
        if ax == "range":
            widths.append(SINC_IRW_FACTOR / ((2 * r.bandwidth / C) * abs(float(u_mid @ e))))
        else:
            proj = u @ e
            widths.append(SINC_IRW_FACTOR / ((2 / r.wavelength) * float(proj.max() - proj.min())))
    return widths


def _default_grid(
    params: BackprojectParams,
    product: Product,
    frame: Frame,
    irw_guess: Sequence[float],
    finest: Sequence[float] | None = None,
    grid_targets: Sequence[str] | None = None,
) -> dict[str, np.ndarray]:
    """Grid axes: spacing the finest theory (``finest``: a target's own, else ``irw_guess``) / oversample,
    extent the targets' span (moving targets where they appear; ``grid_targets``: these names only) plus
    margin_cells of ``irw_guess``."""
    finest = irw_guess if finest is None else finest
    t = product.targets
    if grid_targets is not None:
        names = target_names(t)
        unknown = [n for n in grid_targets if n not in names]
        if unknown:
            raise InputError(
                f"--targets: no target(s) {', '.join(map(repr, unknown))} in the targets table "
                f"(targets: {', '.join(names)})"
            )
        t = t[np.array([n in grid_targets for n in names], bool)]
    # Moving targets appear at their static-equivalent positions: the grid covers those.
    t = (
        moving.apparent_targets(t, product.radar, moving.pulse_times(product), frame, moving.phase_centres(product))
        if len(t) and np.any(moving.is_moving(t))
        else targets_in_frame(t, frame)
    )
    coords = {ax: t[ax] for ax in frame.axes}
    centre_scene = [float(c) for c in frame.from_xyz(np.asarray(product.radar.scene_center))]
    axes = {}
    for i, ax in enumerate(frame.axes):
        centre, spacing, n = image_axis(
            coords[ax],
            irw_guess[i],
            params.oversample,
            params.margin_cells,
            getattr(params, f"{ax}_spacing"),
            getattr(params, f"{ax}_center"),
            getattr(params, f"{ax}_extent"),
            default_centre=centre_scene[i],
            finest=finest[i],
        )
        axes[ax] = centre + (np.arange(n) - n // 2) * spacing
    return axes


@dataclasses.dataclass(frozen=True)
class PulseSet:
    """What every output block needs from a raw product: its range-compressed, tapered pulses per channel
    (complex64) and their geometry; picklable, so a Dask cluster receives it once (scattered)."""

    channels: tuple  # (n_az, n_rg) complex64 per receive channel
    range_time: np.ndarray
    tx: np.ndarray  # (n_az, 3) transmit phase centre, m
    rx: tuple  # (n_az, 3) receive phase centre per channel, m
    gate_offset: np.ndarray | None
    carrier_frequency: float
    bandwidth: float
    range_sampling_rate: float


@dataclasses.dataclass(frozen=True)
class BackprojectionPlan:
    """The output grid and everything written beside the image, decided before any pixel is summed.
    ``elevation``: the third axis of a 3D (elevation-frame) grid, first in the image's dims; None in 2D."""

    frame: Frame
    azimuth: np.ndarray
    range: np.ndarray
    targets: object
    attrs: dict
    elevation: np.ndarray | None = None

    @property
    def shape(self) -> tuple[int, ...]:
        head = () if self.elevation is None else (len(self.elevation),)
        return head + (len(self.azimuth), len(self.range))

    @property
    def dims(self) -> tuple[str, ...]:
        return (() if self.elevation is None else ("elevation",)) + ("azimuth", "range")

    @property
    def coords(self) -> dict[str, np.ndarray]:
        axes = {"azimuth": self.azimuth, "range": self.range}
        return axes if self.elevation is None else {"elevation": self.elevation, **axes}

    def points(self, rows: slice) -> tuple[np.ndarray, tuple[int, ...]]:
        """Scene positions (n, 3) of the grid's rows ``rows`` (indices along its first axis) and their shape."""
        axes = [self.coords[d] for d in self.dims]
        grid = np.meshgrid(axes[0][rows], *axes[1:], indexing="ij")
        return self.frame.to_xyz(*(g.ravel() for g in grid)), grid[0].shape


def check_params(params: BackprojectParams) -> None:
    """Refuse combinations the declarations cannot (the plan estimate runs this first)."""
    if params.interpolation in ("knab", "sinc", "lanczos") and params.kernel_length % 2:
        raise InputError(
            f"backproject.kernel_length: {params.kernel_length} taps; the {params.interpolation} "
            "kernel needs an even number"
        )
    if params.engine == "ffbp" and params.ffbp_interpolation == "knab" and params.ffbp_taps % 2:
        raise InputError(f"backproject.ffbp_taps: {params.ffbp_taps}; the knab reads need an even number")
    if params.engine == "ffbp" and params.interpolation not in ("linear", "cubic"):
        raise InputError(
            f"backproject.interpolation: {params.interpolation!r} with engine: ffbp; it reads the "
            "pulses linear or cubic"
        )
    if params.engine == "reference" and params.interpolation not in ("linear", "nearest"):
        raise InputError(
            f"backproject.interpolation: {params.interpolation!r} needs backproject.engine: compiled "
            "(the reference engine interpolates linear or nearest)"
        )


# Default spacings sample each axis at least this much faster than the widest target support's extent along it
# (theory.support_extent): the ridge IRW / oversample alone let a sheared support wrap (45 deg squint at 800 m
# over 1.2 km in ground_los: range extent 2.83 cycles/m, sampled at 2.37 by 0.42 m), and evaluate's band-limited
# chips then misread it (Session 41 new-user trial). Unsheared supports are sampled 2.26x faster already.
SUPPORT_WRAP_MARGIN = 1.1


def plan_backprojection(
    raw: Product, params: BackprojectParams, grid_targets: Sequence[str] | None = None
) -> BackprojectionPlan:
    """The frame, the grid (covering the targets, moving ones where they appear; ``grid_targets``: only
    these names), every target's own theory and the image attributes: all but the pixel sums."""
    if raw.kind not in ("raw", "raw_multichannel", "raw_array"):
        raise InputError(f"backproject needs a raw product, got {raw.kind!r}")
    check_params(params)
    radar = raw.radar
    if params.frame == "product":
        spec = raw.attrs.get("frame") or {"name": "squint"}
        frame = make_frame(spec["name"], radar, **{k: v for k, v in spec.items() if k != "name"})
    else:
        frame = make_frame(params.frame, radar)
    elevation_keys = [k for k in ("elevation_extent", "elevation_spacing", "elevation_center") if getattr(params, k)]
    if len(frame.axes) == 2 and elevation_keys:
        raise InputError(
            f"backproject.{elevation_keys[0]}: the elevation grid needs a 3D frame (frame: elevation, on a "
            f"raw_array product); frame {frame.name!r} is 2D"
        )
    three_d = len(frame.axes) == 3
    if three_d:
        _check_3d(raw, frame, params)
    centre_scene = [float(c) for c in frame.from_xyz(np.asarray(radar.scene_center))]
    irw0 = _centre_theory(raw, frame, centre_scene)
    pos = raw.aux["platform_position"]
    tx_off = raw.aux.get("tx_offset", np.zeros(3))
    rx_offs = raw.aux.get("rx_offset", np.zeros((1, 3)))
    n_pulses = len(pos)  # (the data itself is not read: the plan runs on a header too)
    taper = theory.sample_taper(params.azimuth_window, n_pulses)
    targets = targets_in_frame(raw.targets, frame)
    # Every target's own theory at its true position (the table's): a moving target's support follows its
    # true track (its illumination), not the static-equivalent position where the image focuses it. In 3D:
    # the array factor in elevation, the pulses' supports in the (azimuth, range) plane at its elevation.
    rows = list(range(len(targets)))
    if three_d:
        own = [
            [theory.array_elevation_theory(rx_offs[:, 1], radar.wavelength, targets["elevation"][i])]
            + theory.target_theory(
                radar,
                pos + tx_off,
                pos + rx_offs[0],
                _ElevationPlane(frame, targets["elevation"][i]),
                (targets["azimuth"][i], targets["range"][i]),
                range_window=params.range_window,
                taper=taper,
            )
            for i in rows
        ]
    else:  # the theory, the support's extent and the ridge angle evaluate reads from one sighting of the pulses
        metric = frame.metric()
        shapes = [
            theory.target_shape(
                radar,
                pos + tx_off,
                pos + rx_offs[0],
                frame,
                (targets["azimuth"][i], targets["range"][i]),
                range_window=params.range_window,
                taper=taper,
                metric=metric,
            )
            for i in rows
        ]
        own = [s.theory for s in shapes]
        if "ridge_angle" in (targets.dtype.names or ()):  # evaluate reads it rather than sighting the pulses again
            targets["ridge_angle"] = [0.0 if math.isnan(s.ridge_angle) else s.ridge_angle for s in shapes]
    theory.fill_target_theory(targets, frame.axes, own, rows=rows)
    # Default spacing from the finest own theory: a target lit by the pattern's skirts or side lobes has a
    # finer response than the -3 dB beam's (sampled at the centre theory, its IRW read 10 % short).
    finest = [min([t[a].irw for t in own] + [irw0[a]]) for a in range(len(frame.axes))]
    if not three_d and rows:  # and fine enough that no target's support wraps (a sheared one reaches further)
        extent = np.max([s.extent for s in shapes], axis=0)
        finest = [min(f, params.oversample / (SUPPORT_WRAP_MARGIN * e)) if e > 0 else f for f, e in zip(finest, extent)]
    grid = _default_grid(params, raw, frame, irw0, finest, grid_targets)
    n_pix = math.prod(len(v) for v in grid.values())
    if n_pix > params.max_pixels:
        raise InputError(
            f"backproject.max_pixels: the grid of {n_pix} pixels exceeds {params.max_pixels}; "
            f"set {'/'.join(frame.axes)} extents or spacings"
        )
    if params.engine == "ffbp" and any(not np.array_equal(tx_off, rx) for rx in rx_offs):
        raise InputError(
            "backproject.engine: ffbp needs a monostatic product (transmit and receive phase centres "
            "equal); use engine: compiled"
        )
    centre_img = [float(np.mean(grid[ax])) for ax in frame.axes]
    # The image's theory: its targets' typical (unweighted) one, not that of the grid centre, which a target
    # at the edge of the beam drags off the lit aperture (the centre theory is kept for scenes without targets).
    attrs: dict = {
        "frame": frame.spec,
        "theoretical_irw": theory.unweighted_irw(own, _centre_theory(raw, frame, centre_img)),
    }
    if three_d:  # the responses of a cross-track array, as array3d records them for evaluate's neighbour models
        from sarproc.focus.array_response import chirp_attrs, period_attrs, range_response_attrs

        attrs["axis_units"] = ["rad", "m", "m"]
        attrs.update(chirp_attrs(radar))
        attrs.update(period_attrs(radar, rx_offs))
        if params.range_window == "none":
            attrs.update(range_response_attrs(radar, len(raw.coords["range_time"]), params.range_filter))
    for key in ("reconstruct", "channel_errors"):  # velocity estimates per moving-target window, the simulated
        if key in raw.attrs:  # channel imbalance and its predicted ghost level: evaluate reads them
            attrs[key] = raw.attrs[key]
    return BackprojectionPlan(
        frame, grid["azimuth"], grid["range"], targets, attrs, grid["elevation"] if three_d else None
    )


def _check_3d(raw: Product, frame: Frame, params: BackprojectParams) -> None:
    """A 3D grid needs the elevation frame and a cross-track receiver array (the elevation aperture)."""
    if tuple(frame.axes) != ("elevation", "azimuth", "range"):
        raise InputError(f"backproject: 3D frame {frame.name!r} is not supported (only elevation)")
    if raw.kind != "raw_array":
        raise InputError(
            f"backproject: a 3D grid (frame {frame.name!r}) needs a raw_array product (a cross-track receiver "
            f"array resolves elevation), got {raw.kind!r}"
        )
    rx = np.asarray(raw.aux.get("rx_offset", np.zeros((1, 3))), float).reshape(-1, 3)
    if len(rx) < 2 or np.any(np.abs(rx[:, [0, 2]]) > 1e-9) or np.ptp(rx[:, 1]) <= 0:
        raise InputError("aux rx_offset: a 3D grid needs two or more receivers spread across track (y) only")
    if params.engine == "ffbp":
        raise InputError("backproject.engine: ffbp forms 2D images only; a 3D grid needs compiled or reference")


class _ElevationPlane(Frame):
    """The (azimuth, range) plane of a 3D elevation frame at one elevation: the 2D frame whose pulse supports
    give a 3D grid's azimuth and range theory (the receivers' array gives its elevation theory)."""

    axes = ("azimuth", "range")

    def __init__(self, frame: Frame, elevation: float) -> None:
        self.frame, self.elevation = frame, float(elevation)

    def to_xyz(self, azimuth: object, range_: object) -> np.ndarray:
        return self.frame.to_xyz(self.elevation, azimuth, range_)

    def from_xyz(self, xyz: np.ndarray) -> tuple[np.ndarray, ...]:
        return self.frame.from_xyz(xyz)[1:]


def _centre_theory(raw: Product, frame: Frame, centre: Sequence[float]) -> list[float]:
    """:func:`theoretical_irw` at ``centre``; in the elevation frame the array factor's IRW first, then the
    azimuth and range widths in the plane of the centre's elevation."""
    if len(frame.axes) == 2:
        return theoretical_irw(raw, frame, centre)
    el = theory.array_elevation_theory(raw.aux["rx_offset"][:, 1], raw.radar.wavelength, centre[0])
    return [SINC_IRW_FACTOR * el.null] + theoretical_irw(raw, _ElevationPlane(frame, centre[0]), centre[1:])


def pulse_set(raw: Product, params: BackprojectParams) -> PulseSet:
    """Range-compress and taper every channel of ``raw`` once, for all output blocks."""
    radar = raw.radar
    pos = raw.aux["platform_position"]
    tx_off = raw.aux.get("tx_offset", np.zeros(3))
    rx_offs = raw.aux.get("rx_offset", np.zeros((1, 3)))
    data = raw.data if raw.data.ndim == 3 else raw.data[None]
    taper = theory.sample_taper(params.azimuth_window, data.shape[1])[:, None].astype(np.float32)
    gate = raw.aux.get("range_gate_offset")
    return PulseSet(
        channels=tuple(
            range_compress(data[ch], radar, params.range_window, filter=params.range_filter) * taper
            for ch in range(data.shape[0])
        ),
        range_time=raw.coords["range_time"],
        tx=pos + tx_off,
        rx=tuple(pos + rx_offs[ch] for ch in range(data.shape[0])),
        gate_offset=None if gate is None else np.asarray(gate, float),
        carrier_frequency=float(radar.carrier_frequency),
        bandwidth=float(radar.bandwidth),
        range_sampling_rate=float(radar.range_sampling_rate),
    )


def backproject_rows(
    pulses: PulseSet,
    plan: BackprojectionPlan,
    params: BackprojectParams,
    rows: slice,
    progress: ProgressFactory | None = None,
    workers: int | None = None,
) -> np.ndarray:
    """The image rows ``rows`` (indices along the grid's first axis: azimuth, or elevation in 3D): (n_rows,
    ...) complex64, every channel summed coherently. Pure: the same rows give the same block wherever they
    are computed."""
    points, shape = plan.points(rows)
    img = np.zeros(len(points), np.complex128)
    for ch, rc in enumerate(pulses.channels):
        if params.engine == "ffbp":
            from sarproc.focus.ffbp import ffbp_points

            img += ffbp_points(
                rc,
                pulses.range_time,
                pulses.tx,
                points,
                pulses.carrier_frequency,
                pulses.bandwidth,
                upsample=params.range_upsample,
                interpolation=params.interpolation,
                gate_offset=pulses.gate_offset,
                factor=params.ffbp_factor,
                first_factor=params.ffbp_first_factor,
                oversample=params.ffbp_oversample,
                ffbp_interpolation=params.ffbp_interpolation,
                ffbp_taps=params.ffbp_taps,
                grid_shape=(shape[0], shape[1]),  # ffbp grids are 2D (a 3D plan refuses engine ffbp)
                workers=workers,
            )
            continue
        img += backproject_points(
            rc,
            pulses.range_time,
            pulses.tx,
            pulses.rx[ch],
            points,
            pulses.carrier_frequency,
            upsample=params.range_upsample,
            interpolation=params.interpolation,
            gate_offset=pulses.gate_offset,
            progress=progress,
            engine=params.engine,
            kernel_length=params.kernel_length,
            oversampling=params.range_upsample * pulses.range_sampling_rate / pulses.bandwidth,
            workers=workers,
        )
    img /= len(pulses.channels)
    return img.reshape(shape).astype(np.complex64)


def row_blocks(shape: tuple[int, ...], block_pixels: int) -> list[slice]:
    """Whole rows of an (n_az, n_rg) grid (whole elevation planes of an (n_el, n_az, n_rg) one) in blocks of
    at most ``block_pixels`` (at least one row each); the decomposition depends on the grid and
    ``block_pixels`` only, so a local and a distributed run sum the same pixels together (the compiled
    kernel's float32 offsets are relative to its tiles)."""
    n_rows, row = shape[0], math.prod(shape[1:])
    step = max(1, min(n_rows, int(block_pixels) // max(1, row)))
    return [slice(s, min(s + step, n_rows)) for s in range(0, n_rows, step)]


def backproject_blocks(
    pulses: PulseSet,
    plan: BackprojectionPlan,
    params: BackprojectParams,
    blocks: Sequence[slice],
    mapper: Callable | None = None,
    progress: ProgressFactory | None = None,
    workers: int | None = None,
) -> Iterator[tuple[slice, np.ndarray]]:
    """Yield (rows, block) over ``blocks`` in order. ``mapper`` (a map-like yielding in input order, e.g. one
    over Dask workers; the builtin map by default) computes them; ``pulses`` may be a Dask future of a
    PulseSet, resolved on the workers."""
    if mapper is None:
        one = len(blocks) == 1  # a single block reports the pulses' progress, several the blocks'
        for rows in blocks if one or progress is None else progress(blocks):
            yield rows, backproject_rows(pulses, plan, params, rows, progress if one else None, workers)
        return
    results = mapper(_block_task, ((pulses, plan, params, rows, workers) for rows in blocks))
    for rows, block in zip(blocks, progress(results, total=len(blocks)) if progress is not None else results):
        yield rows, block


def _block_task(item: tuple) -> np.ndarray:
    pulses, plan, params, rows, workers = item
    return backproject_rows(pulses, plan, params, rows, workers=workers)


def backproject(
    raw: Product,
    params: BackprojectParams = BackprojectParams(),
    progress: ProgressFactory | None = None,
    grid_targets: Sequence[str] | None = None,
) -> Product:
    """Focus a raw product (one or several channels, summed coherently) onto a frame grid, in memory.

    The default grid covers the targets (moving ones where they appear); ``grid_targets``: only these
    names (every target stays in the image's table). The command line streams the same blocks to disk
    (:func:`backproject_blocks`) so an image need not fit in memory.
    """
    plan = plan_backprojection(raw, params, grid_targets)
    pulses = pulse_set(raw, params)
    edge_aliases = warn_ambiguities(raw, plan, pulses)
    img = np.empty(plan.shape, np.complex64)
    for rows, block in backproject_blocks(
        pulses, plan, params, row_blocks(plan.shape, params.block_pixels), progress=progress
    ):
        img[rows] = block
    return image_product(raw, plan, params, img, edge_aliases)


def warn_ambiguities(raw: Product, plan: BackprojectionPlan, pulses: PulseSet) -> list[dict]:
    """Warn where the pulses undersample the grid's Doppler, naming the targets whose ghosts land in it, and of
    the targets' aliases beyond the grid's azimuth edge whose side lobes enter it (a grid as wide as the PRF's
    unambiguous extent: paper 000's small scene) (:mod:`sarproc.focus.backprojection_alias`); silent where
    neither reaches the image. Returns the edge aliases for the image's history, as fine-focus records them."""
    from sarproc.focus import backprojection_alias

    times = np.asarray(raw.coords["azimuth_time"], float)
    ambiguity = backprojection_alias.grid_ambiguity(plan, pulses, times, raw.radar)
    for message in backprojection_alias.messages(ambiguity):
        log.warning("backproject: %s", message, extra=IMAGE_DEFECT)
    # a grid wider than the PRF's extent holds the ghosts themselves (warned of above), whose lobes at its edge
    # cannot be told from an entering alias's
    ambiguous = ambiguity is not None and ambiguity.ambiguous
    edge = [] if ambiguous else backprojection_alias.grid_edge_aliases(plan, pulses, times, raw.radar)
    if edge:
        message = backprojection_alias.edge_alias_message(edge, float(raw.radar.prf))
        log.warning("backproject: %s", message, extra=IMAGE_DEFECT)
    return backprojection_alias.edge_alias_records(edge)


def image_product(
    raw: Product,
    plan: BackprojectionPlan,
    params: BackprojectParams,
    img: np.ndarray,
    edge_aliases: list[dict] | None = None,
) -> Product:
    """The image product of ``plan`` around ``img`` (the full image, or any placeholder of its shape when the
    data are streamed to disk block by block); ``edge_aliases``: :func:`warn_ambiguities`' return, for the
    history."""
    from sarproc.product.io import history_entry

    out = raw.derive(
        "image" if plan.elevation is None else "image3d",
        img,
        plan.dims,
        plan.coords,
        targets=plan.targets,
        attrs=plan.attrs,
    )
    # the history records the upsampling used, the engine's default included
    entry = as_dict(params) | {"upsample": params.range_upsample}
    if edge_aliases is not None:
        entry["azimuth_edge_aliases"] = edge_aliases
    out.history.append(history_entry("backproject", entry))
    return out
