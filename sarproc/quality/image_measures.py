"""Measures of a focused image that need no truth table: bright points, their sub-pixel peaks, entropy, NCC.

For images of real data (Gotcha) or of foreign files (SICD read by other readers) there is no targets
table to evaluate against; two focusers or two readers are compared on the image itself: where its
brightest points lie (to a fraction of a pixel), how sharp it is (entropy of the normalised intensity)
and how alike two images are (normalised cross-correlation of the magnitudes).
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy.ndimage import maximum_filter


def bright_points(mag: np.ndarray, n: int, separation: int, edge: int, floor: float = 0.0) -> np.ndarray:
    """(row, col) of the ``n`` brightest local maxima of ``mag`` (2-D, >= 0), brightest first: maxima of their
    own ``(2 separation + 1)``-pixel square, at least ``edge`` pixels from every border, above ``floor`` times
    the brightest pixel (``floor`` 0.1: within 20 dB of it, so a point target's far side lobes are no points).
    Returns an (k, 2) integer array, k <= n."""
    mag = np.asarray(mag)
    if mag.ndim != 2:
        raise ValueError(f"bright_points needs a 2-D magnitude image, got shape {mag.shape}")
    peaks = (mag == maximum_filter(mag, size=2 * separation + 1)) & (mag > floor * mag.max())
    if edge > 0:
        peaks[:edge], peaks[-edge:], peaks[:, :edge], peaks[:, -edge:] = False, False, False, False
    idx = np.argwhere(peaks)
    return idx[np.argsort(mag[peaks])[::-1][:n]]


def subpixel_peak(mag: np.ndarray, i: int, j: int) -> tuple[float, float]:
    """Parabolic vertex through pixel (i, j) and its neighbours along each axis, pixels (the pixel is moved
    one in from the border first)."""

    def vertex(m: float, c: float, p: float) -> float:
        den = m - 2 * c + p
        return 0.0 if den == 0 else 0.5 * (m - p) / den

    i = min(max(i, 1), mag.shape[0] - 2)
    j = min(max(j, 1), mag.shape[1] - 2)
    return (i + vertex(mag[i - 1, j], mag[i, j], mag[i + 1, j]), j + vertex(mag[i, j - 1], mag[i, j], mag[i, j + 1]))


def entropy(mag: np.ndarray) -> float:
    """Image entropy -sum p ln p of the normalised intensity p = |I|^2 / sum |I|^2, nats (lower: sharper)."""
    p = np.asarray(mag, float) ** 2
    p = p[p > 0] / p.sum()
    return float(-(p * np.log(p)).sum())


def magnitude_ncc(a: np.ndarray, b: np.ndarray) -> float:
    """Normalised cross-correlation of two magnitude images on the same grid (1: identical up to a gain and an
    offset), summed in the images' own precision."""
    a = a - a.mean()
    b = b - b.mean()
    return float((a * b).sum() / np.sqrt((a**2).sum() * (b**2).sum()))


def deviation_db(image: np.ndarray, reference: np.ndarray) -> float:
    """Largest deviation of ``image`` from ``reference`` relative to the reference's peak, dB:
    20 log10(max |image - reference| / max |reference|), floored at -600 dB (identical images)."""
    if image.shape != reference.shape:
        raise ValueError(f"deviation_db: image {image.shape} and reference {reference.shape} differ in shape")
    return float(20 * np.log10(max(np.abs(image - reference).max() / np.abs(reference).max(), 1e-30)))


@dataclasses.dataclass(frozen=True)
class BrightPoint:
    pixel: tuple[int, int]  # the point's brightest pixel (row, column)
    peak: tuple[float, float]  # its sub-pixel peak (subpixel_peak), pixels
    level_db: float  # the pixel against the image's brightest, dB
    reference_peak: tuple[float, float] | None = None  # the reference's sub-pixel peak within +-3 pixels
    offset: tuple[float, float] | None = None  # peak - reference_peak, pixels (row, column)


@dataclasses.dataclass(frozen=True)
class ImageMeasures:
    """What :func:`measure_image` finds: the image's entropy and brightest points, and with a reference image on
    the same pixels the NCC of the magnitudes, the reference's entropy and each point's offset from it."""

    shape: tuple[int, ...]
    entropy: float
    points: tuple[BrightPoint, ...]
    ncc: float | None = None
    reference_entropy: float | None = None

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)


def measure_image(
    data: np.ndarray,
    reference: np.ndarray | None = None,
    n: int = 10,
    separation: int = 10,
    edge: int = 10,
    window: int = 3,
) -> ImageMeasures:
    """Truth-free measures of a complex 2-D image (``sarproc evaluate`` on an image without a targets table):
    its entropy and ``n`` brightest points (:func:`bright_points` with ``separation``, ``edge``; sub-pixel
    peaks). With ``reference`` (same shape): the NCC of the magnitudes, the reference's entropy, and per point
    the reference's sub-pixel peak at its strongest pixel within +-``window`` pixels, and the offset."""
    A = np.abs(data)
    B = None if reference is None else np.abs(reference)
    if B is not None and B.shape != A.shape:
        raise ValueError(f"measure_image: image {A.shape} and reference {B.shape} differ in shape")
    points = []
    for i, j in bright_points(A, n=n, separation=separation, edge=edge):
        pa = subpixel_peak(A, i, j)
        level = float(20 * np.log10(A[i, j] / A.max()))
        if B is None:
            points.append(BrightPoint((int(i), int(j)), _floats(pa), level))
            continue
        w = B[i - window : i + window + 1, j - window : j + window + 1]
        k = np.unravel_index(np.argmax(w), w.shape)
        pb = subpixel_peak(B, i - window + k[0], j - window + k[1])
        offset = (pa[0] - pb[0], pa[1] - pb[1])
        points.append(BrightPoint((int(i), int(j)), _floats(pa), level, _floats(pb), _floats(offset)))
    return ImageMeasures(
        shape=tuple(A.shape),
        entropy=entropy(A),
        points=tuple(points),
        ncc=None if B is None else magnitude_ncc(A, B),
        reference_entropy=None if B is None else entropy(B),
    )


def _floats(p: tuple) -> tuple[float, float]:
    return (float(p[0]), float(p[1]))
