"""Resource plans of export-sicd, export-cphd, import-cphd and import-gotcha (sarproc.product.budget has the
Plan and the process around it)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

from sarproc.product.budget import Plan, complex_bytes, header_shape, stored_bytes

if TYPE_CHECKING:
    from collections.abc import Sequence
    from typing import Any

    from sarproc.product.model import Product


def export_sicd_estimate(stage: str, header: Product, params: Any) -> Plan:
    """SICD holds complex64 pixels; the image, its reordered copy and the read-back are in memory."""
    n = math.prod(header_shape(header))
    return Plan(stage, complex_bytes(n) + 1e5, 3 * complex_bytes(n), n * 50e-9, f"{n} pixels")


def export_cphd_estimate(stage: str, header: Product, params: Any) -> Plan:
    """CPHD holds the FX-domain signal (complex64) and 200 bytes of per-vector parameters per pulse."""
    n_az, n_rg = header_shape(header)[-2:]
    n = n_az * n_rg
    return Plan(
        stage,
        complex_bytes(n) + 200.0 * n_az + 1e5,
        complex_bytes(n) + 3 * complex_bytes(n, itemsize=16),
        n * 80e-9,
        f"{n_az} vectors x {n_rg} samples",
    )


def import_cphd_estimate(stage: str, cphd: dict) -> Plan:
    n_v, n_s = cphd["vectors"], cphd["samples"]
    n = n_v * n_s
    return Plan(
        stage,
        stored_bytes(n_v, n_s),
        complex_bytes(n) + 3 * complex_bytes(n, itemsize=16),
        n * 80e-9,
        f"{n_v} vectors x {n_s} samples",
    )


def import_gotcha_estimate(stage: str, files: Sequence[Path]) -> Plan:
    """Gotcha files store complex64 samples: the product is about their size; read as complex128, twice."""
    size = float(sum(Path(f).stat().st_size for f in files))
    return Plan(stage, size, 5 * size, size * 10e-9, f"{len(files)} file(s), {size / 1e6:.3g} MB")
