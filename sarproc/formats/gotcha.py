"""AFRL Gotcha volumetric phase history (.mat, ../shared/data/gotcha/README.md) as a raw product.

Each file holds the dechirped phase history fp (frequency samples x pulses), already motion-
compensated to the scene centre, S(t, f) = exp{-j 4 pi f [R_p(t) - r_0(t)] / c}: the form of
Nie 2016 eq. (4). A raw product stores pulses in fast time at their absolute delays, so the
samples are turned back into the range-compressed echo of a unit-impulse "chirp" (pulse
duration 1 / f_s: range compression is then the identity) recorded in a window that follows the
scene centre: the window start is the varied gate 2 [r_0(t) - r_0(mid)] / c (aux
``range_gate_offset``, the same mechanism as paper 002's varied gate), and inside it

    x(t, n) = (1/N) exp{-j 4 pi f_c r_0 / c} sum_k S(t, f_k) exp{j 2 pi (f_k - f_c)(n - N/2) / f_s},

with f_s = N df (N frequency samples df apart, ascending), B = f_s and f_c = f_{N//2}, the sample the DFT of
a pulse puts on its zero bin: every f_k - f_c is then a whole multiple of df, so x is periodic in n and its
DFT holds exactly the N samples S(t, f_k) (times the carrier and delay factors), which is what a processor
assumes when it FFT-upsamples or range-transforms a pulse. (With f_c the mean of an even number of samples
the offsets fall half a bin off that grid: the pulse's DFT leaks, FFT interpolation of it is wrong between
samples, and a backprojected Gotcha image came out 29 dB from FastSAR's image of the .mat, see
docs/performance.md.) Any processor of raw products (pfa2, backproject) then sees the standard model at
absolute delays 2 R_p / c.
There is no time axis in the files: the PRF is nominal (``NOMINAL_PRF``) and the velocity the
mean distance between pulses times it; antenna positions are stored per pulse. The polarisation is
read from the AFRL file names (``..._HH.mat``: radar.polarization "H:H") when every file names the same.
"""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from sarproc.product.errors import InputError
from sarproc.product.frames import GroundLosFrame
from sarproc.product.metadata import C, RadarMetadata
from sarproc.product.model import Product, make_targets

NOMINAL_PRF = 100.0  # Hz; the files carry no pulse times


@dataclasses.dataclass
class GotchaPass:
    """A dechirped phase history compensated to the scene centre (the model of the module docstring)."""

    phase_history: np.ndarray  # (pulses, frequencies) complex
    freq: np.ndarray  # (frequencies,) Hz, uniformly spaced, ascending or descending
    positions: np.ndarray  # (pulses, 3) antenna phase centres in the scene frame, m
    r0: np.ndarray  # (pulses,) distance from each antenna position to the scene centre, m
    files: list[str]  # where it came from (history)
    polarization: str | None = None  # "H:V" etc.; None: from the file names when they say


def read_gotcha(files: list[Path], autofocus: bool = False) -> GotchaPass:
    """Concatenate Gotcha .mat files (consecutive azimuths of one pass) into plain arrays."""
    import scipy.io

    fp, pos, r0, freq = [], [], [], None
    for f in files:
        path = Path(f)
        if not path.exists():
            raise InputError(f"{path}: file not found")
        try:
            d = scipy.io.loadmat(path, squeeze_me=True, struct_as_record=False)["data"]
        except (OSError, ValueError, KeyError, TypeError) as exc:
            raise InputError(f"{path}: not a Gotcha phase-history .mat with a 'data' struct: {exc}") from None
        for name in ("fp", "freq", "x", "y", "z", "r0"):
            if not hasattr(d, name):
                raise InputError(f"{path}: data.{name} is missing")
        f_here = np.asarray(d.freq, float).ravel()
        if freq is None:
            freq = f_here
        elif f_here.shape != freq.shape or np.max(np.abs(f_here - freq)) > 1e-3 * abs(freq[1] - freq[0]):
            raise InputError(f"{path}: data.freq differs from the first file's; files must share one frequency plan")
        ph = np.asarray(d.fp).T.astype(np.complex128)  # (pulses, freq)
        r = np.asarray(d.r0, float).ravel()
        if autofocus and hasattr(d, "af"):
            # af.r_correct refines r0 and af.ph_correct is a per-pulse phase (Gotcha's autofocus solution)
            r = r + np.asarray(d.af.r_correct, float).ravel()
            ph *= np.exp(1j * np.asarray(d.af.ph_correct, float).ravel())[:, None]
        fp.append(ph)
        pos.append(np.stack([np.ravel(d.x), np.ravel(d.y), np.ravel(d.z)], axis=1).astype(float))
        r0.append(r)
    if freq is None:
        raise InputError("import-gotcha: no input files")
    df = np.diff(freq)
    if np.max(np.abs(df - df.mean())) > 2e-3 * abs(df.mean()):  # stored as float32: steps jitter by ~1e-3
        raise InputError(f"{files[0]}: data.freq is not uniformly spaced")
    freq = np.polyval(np.polyfit(np.arange(len(freq)), freq, 1), np.arange(len(freq)))
    return GotchaPass(
        phase_history=np.concatenate(fp),
        freq=freq,
        positions=np.concatenate(pos),
        r0=np.concatenate(r0),
        files=[str(f) for f in files],
    )


def polarization_from_names(files: Sequence[str | Path]) -> str | None:
    """'H:V' when every file name ends in _HV.mat (the AFRL naming), else None (not recorded)."""
    pols = set()
    for f in files:
        m = re.search(r"_([HV])([HV])\.mat$", Path(str(f)).name, re.IGNORECASE)
        pols.add(f"{m.group(1).upper()}:{m.group(2).upper()}" if m else None)
    return pols.pop() if len(pols) == 1 and None not in pols else None


def gotcha_product(g: GotchaPass) -> Product:
    """The raw product (see the module docstring) of :func:`read_gotcha`'s arrays."""
    from sarproc.product.io import history_entry

    s = g.phase_history
    freq, pos, r0 = g.freq, g.positions, g.r0
    n_az, n = s.shape
    df = float(freq[1] - freq[0])
    fs = n * abs(df)
    if df < 0:  # descending frequencies: flip to ascending
        s, freq = s[:, ::-1], freq[::-1]
    fc = float(freq[n // 2])  # the zero bin of a pulse's DFT (module docstring)
    fr = freq - fc
    mid = n_az // 2
    r_ref = float(r0[mid])
    k = np.arange(n)
    kernel = np.exp(2j * math.pi * np.outer(fr, k - n / 2) / fs) / n  # (freq, samples)
    carrier = np.exp(-2j * math.pi * ((2 * fc * r0 / C) % 1.0))  # exp(-j 4 pi f_c r_0 / c)
    signal = ((s @ kernel) * carrier[:, None]).astype(np.complex64)
    gate = 2 * (r0 - r_ref) / C
    range_time = 2 * r_ref / C + (k - n / 2) / fs
    steps = np.linalg.norm(np.diff(pos, axis=0), axis=1)
    velocity = float(steps.mean() * NOMINAL_PRF) if len(steps) else 1.0
    p_mid = pos[mid]
    vel_dir = pos[min(mid + 1, n_az - 1)] - pos[max(mid - 1, 0)]
    los = -p_mid / np.linalg.norm(p_mid)
    squint = float(math.asin(np.clip(los @ vel_dir / max(np.linalg.norm(vel_dir), 1e-12), -1, 1)))
    radar = RadarMetadata(
        carrier_frequency=fc,
        bandwidth=fs,
        pulse_duration=1.0 / fs,
        chirp_rate=fs * fs,
        range_sampling_rate=fs,
        prf=NOMINAL_PRF,
        velocity=velocity,
        altitude=float(p_mid[2]),
        squint=squint,
        reference_range=r_ref,
        scene_center=(0.0, 0.0, 0.0),
        mode="spotlight",
        aperture_time=n_az / NOMINAL_PRF,
        polarization=g.polarization or polarization_from_names(g.files),
    )
    radar.validate()
    frame = GroundLosFrame((0.0, 0.0, 0.0), p_mid)
    times = (np.arange(n_az) - (n_az - 1) / 2) / NOMINAL_PRF
    return Product(
        kind="raw",
        data=signal,
        dims=("azimuth_time", "range_time"),
        coords={"azimuth_time": times, "range_time": range_time},
        radar=radar,
        targets=make_targets([], np.zeros((0, 3)), np.zeros(0)),
        attrs={"frame": frame.spec},
        aux={
            "platform_position": pos,
            "range_gate_offset": gate,
            "tx_offset": np.zeros(3),
            "rx_offset": np.zeros((1, 3)),
        },
        history=[history_entry("import-gotcha", {"files": g.files, "nominal_prf": NOMINAL_PRF})],
    )


def gotcha_files(inputs: tuple[Path, ...] | list[Path]) -> list[Path]:
    """The .mat files named by ``inputs`` (files, or folders searched for *.mat), checked without reading data.

    Each must exist and hold a MATLAB variable 'data'; raises InputError naming the file.
    """
    import scipy.io

    files = []
    for p in map(Path, inputs):
        if p.is_dir():
            found = sorted(p.glob("*.mat"))
            if not found:
                raise InputError(f"{p}: folder holds no .mat files")
            files.extend(found)
        else:
            files.append(p)
    for path in files:
        if not path.is_file():
            raise InputError(f"{path}: file not found")
        try:
            names = [v[0] for v in scipy.io.whosmat(path, appendmat=False)]
        # scipy raises NotImplementedError for MATLAB v7.3 (HDF5-based) files, which it cannot read
        except (OSError, ValueError, TypeError, NotImplementedError, scipy.io.matlab.MatReadError) as exc:
            raise InputError(f"{path}: not a MATLAB .mat file: {exc}") from None
        if "data" not in names:
            raise InputError(f"{path}: not a Gotcha phase-history .mat: no variable 'data' (has {names})")
    return files
