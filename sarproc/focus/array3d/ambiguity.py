"""Elevation ambiguities of a linear-array 3D image (Du 2010; issue 9).

A cross-track array of spacing d samples w = sin(theta) every lambda / d: a scatterer at w appears
at every w + m lambda / d, and the processed sector |theta| <= psi = asin(lambda / 2d) holds one copy
(the grating-lobe alias) of everything the elevation beam illuminates. The copy is fully focused
(the cross-track range migration v_n w differs by only (lambda / d) v_n between the two, a fraction
of a range cell for short arrays), so the processor cannot tell it from a real scatterer; what it
can say from the metadata and the data:

* whether the elevation beam recorded in the product (one-way -3 dB width beta, centred on nadir)
  reaches beyond the sector, by more than half an elevation resolution cell (a sliver narrower
  than that images where the scatterer is anyway); with no pattern recorded (beta = 0) there is
  nothing to compare and nothing is said;
* which bins the folded part of the beam lands in (the alias band), and which strong responses of
  the cube lie there: each is named with the true elevation it would have if it is a fold.
"""

from __future__ import annotations

import math

import numpy as np

from sarproc.product.sorted_values import median


def unambiguous_half_sector(wavelength: float, spacing: float) -> float:
    """psi = asin(lambda / 2d), rad (pi/2 when d <= lambda / 2)."""
    return math.asin(min(1.0, wavelength / (2 * spacing)))


def alias_of(theta: float, wavelength: float, spacing: float) -> float:
    """Elevation (rad) where a scatterer at ``theta`` appears inside the sector: w folded by lambda/d."""
    period = wavelength / spacing
    w = math.sin(theta)
    w_alias = (w + period / 2) % period - period / 2
    return math.asin(max(-1.0, min(1.0, w_alias)))


def alias_bands(beamwidth: float, wavelength: float, spacing: float, resolution: float) -> list[tuple]:
    """Folded parts of the beam: [(true lo, true hi, alias lo, alias hi)] in rad, empty when the beam
    stays within the sector (to half a resolution cell) or no pattern is recorded (beamwidth 0)."""
    psi = unambiguous_half_sector(wavelength, spacing)
    if beamwidth <= 0 or beamwidth / 2 <= psi + resolution / 2 or psi >= math.pi / 2:
        return []  # no pattern recorded (nothing to compare), or the beam stays within the sector
    edge = beamwidth / 2
    bands = []
    period = wavelength / spacing
    for sign in (1.0, -1.0):  # the first fold: w - sign lambda/d (a sliver maps monotonically)
        a = math.asin(max(-1.0, min(1.0, sign * (math.sin(psi) - period))))
        b = math.asin(max(-1.0, min(1.0, sign * (math.sin(edge) - period))))
        bands.append((sign * psi, sign * edge, min(a, b), max(a, b)))
    return bands


def _array_factor(offsets: np.ndarray, wavelength: float, dw: float) -> float:
    """|sum_n exp(j 2 pi v_n dw / lambda)| / N: the elevation response dw (in sin theta) off its peak."""
    return float(np.abs(np.mean(np.exp(2j * np.pi * np.asarray(offsets) * dw / wavelength))))


def elevation_ambiguities(
    cube: np.ndarray,
    elevation: np.ndarray,
    azimuth: np.ndarray,
    ranges: np.ndarray,
    beamwidth: float,
    wavelength: float,
    offsets: np.ndarray,
    resolution: float,
    level_db: float = -25.0,
) -> list[str]:
    """Warnings (empty when nothing is ambiguous): the beam against the sector, and every response of
    ``cube`` (elevation, azimuth, range) above ``level_db`` of the strongest that lies in an alias
    band, with its level and the true elevation it would have if it is a fold. A response no stronger
    than twice the array-factor side lobe of the strongest response on its (azimuth, range) line is
    that response's side lobe, not a scatterer, and is not named."""
    offsets = np.asarray(offsets, dtype=float)
    spacing = median(np.diff(np.sort(offsets))) if offsets.size > 1 else float("inf")
    bands = alias_bands(beamwidth, wavelength, spacing, resolution)
    if not bands:
        return []
    psi = unambiguous_half_sector(wavelength, spacing)
    beam = f"the elevation beam +-{math.degrees(beamwidth / 2):.3g} deg"
    lit = ", ".join(f"{math.degrees(lo):+.3g}..{math.degrees(hi):+.3g}" for lo, hi, _, _ in bands)
    msgs = [
        f"{beam} reaches beyond the unambiguous sector +-{math.degrees(psi):.3g} deg = +-asin(lambda/2d) "
        f"(d = {spacing:.4g} m): scatterers at {lit} "
        f"deg fold, fully focused and at full strength, onto "
        f"{', '.join(f'{math.degrees(a):+.3g}..{math.degrees(b):+.3g}' for _, _, a, b in bands)} deg "
        "(narrow the beam or the receiver spacing)"
    ]
    mag = np.abs(cube)
    peak = float(mag.max()) if mag.size else 0.0
    if not peak > 0:
        return msgs
    step = float(abs(elevation[1] - elevation[0])) if len(elevation) > 1 else resolution
    for lo, _hi, a, b in bands:
        sel = np.flatnonzero((elevation >= a - step) & (elevation <= b + step))
        if sel.size == 0:
            continue
        sub = mag[sel]
        k = np.unravel_index(int(np.argmax(sub)), sub.shape)
        level = 20 * math.log10(float(sub[k]) / peak)
        if level < level_db:
            continue
        th = float(elevation[sel[k[0]]])
        # strongest response per elevation near this (azimuth, range): cross-track range migration
        # moves a response's side lobes by a bin or two in range across elevation
        near = mag[:, max(0, k[1] - 1) : k[1] + 2, max(0, k[2] - 2) : k[2] + 3]
        line = near.reshape(len(elevation), -1).max(axis=1)
        top = int(np.argmax(line))
        if elevation[top] != th:
            dw = math.sin(th) - math.sin(float(elevation[top]))
            side = max(_array_factor(offsets, wavelength, dw + e * step / 2) for e in (-1, 0, 1))
            if float(sub[k]) <= 2 * side * float(line[top]):
                continue
        w_true = math.sin(th) + math.copysign(wavelength / spacing, lo)
        true = math.degrees(math.asin(max(-1.0, min(1.0, w_true))))
        msgs.append(
            f"the response at elevation {math.degrees(th):+.3g} deg, azimuth {float(azimuth[k[1]]):.4g} m, "
            f"range {float(ranges[k[2]]):.5g} m ({level:.1f} dB of the strongest) lies where the beam "
            f"beyond the sector folds: it is a scatterer there or the grating-lobe alias of one at "
            f"{true:+.3g} deg, which the data cannot tell apart"
        )
    return msgs
