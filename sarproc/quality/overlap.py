"""Overlap of targets that one 2D image cannot separate (paper 004, Fig. 5).

Before elevation compression each receiver of a cross-track array forms a 2D (azimuth, range) image in
which targets at the same azimuth and slant range but different elevations fall into one resolution cell
and add coherently. The measure: per image, the energy of such a cell over the mean energy of the
targets that are alone in theirs; the prediction: the coherent sum of the cell's targets, each with the
carrier phase of its own two-way path to that receiver, |sum_k a_k exp(-j 2 pi R_nk / lambda)|^2 over the
mean |a|^2 of the lone targets (three unit targets at 0 and +-theta: |1 + 2 cos(2 pi v_n sin(theta) /
lambda)|^2, about 3 on average over many receivers).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np


def coincident_groups(positions: np.ndarray, cell: Sequence[float]) -> list[list[int]]:
    """Indices of the targets at (azimuth, range) ``positions`` (n, 2) grouped when two lie within half a
    ``cell`` (per-axis resolution width) of each other on both axes, transitively; every target is in
    exactly one group (alone: a group of one), groups in order of their first member."""
    pos = np.asarray(positions, float).reshape(-1, 2)
    half = 0.5 * np.asarray(cell, float)
    label = list(range(len(pos)))

    def root(i: int) -> int:
        while label[i] != i:
            i = label[i]
        return i

    for i in range(len(pos)):
        for j in range(i + 1, len(pos)):
            if np.all(np.abs(pos[i] - pos[j]) <= half):
                label[root(j)] = root(i)
    groups: dict[int, list[int]] = {}
    for i in range(len(pos)):
        groups.setdefault(root(i), []).append(i)
    return sorted(groups.values(), key=lambda g: g[0])


def cell_energy(
    images: np.ndarray, azimuth: np.ndarray, range_: np.ndarray, position: Sequence[float], half_width: int = 1
) -> np.ndarray:
    """Per image of ``images`` (n, n_az, n_rg): the largest |pixel|^2 on the azimuth row nearest
    ``position[0]`` over the 2 half_width + 1 range samples nearest ``position[1]`` (a response's peak, to
    within the range sampling)."""
    ia = int(np.argmin(np.abs(np.asarray(azimuth) - position[0])))
    ir = int(np.argmin(np.abs(np.asarray(range_) - position[1])))
    lo, hi = max(ir - half_width, 0), ir + half_width + 1
    return np.abs(np.asarray(images)[:, ia, lo:hi]).max(axis=1) ** 2


def overlap_ratios(
    images: np.ndarray,
    azimuth: np.ndarray,
    range_: np.ndarray,
    position: Sequence[float],
    references: Sequence[Sequence[float]],
    half_width: int = 1,
) -> np.ndarray:
    """Per image: :func:`cell_energy` at ``position`` over its mean at the ``references`` positions."""
    if not len(references):
        raise ValueError("overlap_ratios: no reference positions (targets alone in their cells)")
    ref = np.mean([cell_energy(images, azimuth, range_, p, half_width) for p in references], axis=0)
    return cell_energy(images, azimuth, range_, position, half_width) / ref


def coherent_overlap(
    paths: np.ndarray, wavelength: float, amplitudes: np.ndarray, reference_power: float
) -> np.ndarray:
    """Predicted cell energy over ``reference_power``: |sum_k a_k exp(-j 2 pi R_nk / lambda)|^2 per image n,
    ``paths`` (n, k) the two-way paths R_nk (m) of the cell's k targets, ``amplitudes`` (k,) theirs."""
    cyc = np.asarray(paths, float) / wavelength
    cyc = cyc - np.floor(cyc)  # float64 path in wavelengths, reduced before the exponential
    s = np.exp(-2j * np.pi * cyc) @ np.asarray(amplitudes, complex)
    return np.abs(s) ** 2 / reference_power


@dataclasses.dataclass(frozen=True)
class OverlapGroup:
    """Targets sharing one 2D cell: measured and predicted energy ratio per image."""

    targets: list[str]
    azimuth: float
    range: float
    ratio: np.ndarray  # (n_images,)
    predicted: np.ndarray  # (n_images,)

    def to_dict(self) -> dict:
        return {
            "targets": list(self.targets),
            "azimuth": self.azimuth,
            "range": self.range,
            "per_image_ratio": [float(x) for x in self.ratio],
            "per_image_predicted": [float(x) for x in self.predicted],
            "mean_ratio": float(np.mean(self.ratio)),
            "mean_predicted": float(np.mean(self.predicted)),
        }


def image_overlap(
    images: np.ndarray,
    azimuth: np.ndarray,
    range_: np.ndarray,
    names: Sequence[str],
    positions: np.ndarray,
    cell: Sequence[float],
    paths: np.ndarray,
    amplitudes: np.ndarray,
    wavelength: float,
) -> tuple[list[OverlapGroup], list[str]]:
    """Every group of targets sharing a cell of the 2D ``images`` (n, n_az, n_rg), measured against the targets
    alone in theirs: (groups, names of the lone reference targets). ``positions`` (k, 2): the targets'
    (azimuth, range) in the images' frame; ``cell``: the images' resolution per axis; ``paths`` (n, k): each
    target's two-way path to each image's receiver (m); ``amplitudes`` (k,) complex. No lone target or no
    shared cell: no groups."""
    groups = coincident_groups(positions, cell)
    lone = [g[0] for g in groups if len(g) == 1]
    shared = [g for g in groups if len(g) > 1]
    if not lone or not shared:
        return [], [names[i] for i in lone]
    amplitudes = np.asarray(amplitudes, complex)
    ref_power = float(np.mean(np.abs(amplitudes[lone]) ** 2))
    refs = [positions[i] for i in lone]
    out = []
    for g in shared:
        centre = np.mean(np.asarray(positions, float)[g], axis=0)
        out.append(
            OverlapGroup(
                targets=[names[i] for i in g],
                azimuth=float(centre[0]),
                range=float(centre[1]),
                ratio=overlap_ratios(images, azimuth, range_, centre, refs),
                predicted=coherent_overlap(np.asarray(paths)[:, g], wavelength, amplitudes[g], ref_power),
            )
        )
    return out, [names[i] for i in lone]
