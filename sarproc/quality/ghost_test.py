"""Injected-ghost test of the residual false-target search (issue 20 item 1): ``sarproc ghost-test``.

Two images of one scene on one grid, made the same way: CLEAN, and GHOSTED with one more target G that
CLEAN's targets table does not hold. By linearity G's own response is GHOSTED - CLEAN; it is added to CLEAN
scaled so that its strongest pixel lies ``level`` dB below the strongest truth target's refined peak, and the
sum is evaluated with CLEAN's targets table (G unknown to it): the false target found should be G, at its
level and place. Pure: products in, figures out (the command prints and writes them).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterable, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from sarproc.product.errors import InputError

if TYPE_CHECKING:
    from sarproc.product.model import Product
    from sarproc.quality.metrics import EvaluateParams, QualityReport

LEVELS_DB = (-40.0, -45.0, -50.0)


@dataclasses.dataclass(frozen=True)
class GhostRow:
    injected_db: float  # G's strongest pixel against the strongest truth target's refined peak
    found_db: float  # the residual false target's pixel level (what the injection sets)
    found_position: dict[str, float]  # its refined position, axis units
    error_cells: dict[str, float]  # found - G's strongest pixel, in theoretical resolution cells per axis
    guard_db: float  # the guard-window false-target figure of the ghosted image
    floor_db: float  # the ghosted image's residual floor

    @property
    def error_db(self) -> float:
        return self.found_db - self.injected_db


@dataclasses.dataclass(frozen=True)
class GhostTest:
    dims: tuple[str, ...]
    ghost_position: dict[str, float]  # G's strongest pixel (of its response alone), axis units
    ghost_peak: float  # |response| there, image units
    reference_peak: float  # the strongest truth target's refined peak amplitude in CLEAN
    floor_db: float  # CLEAN's residual floor
    false_target_db: float  # CLEAN's residual false target
    guard_db: float  # CLEAN's guard-window figure
    rows: tuple[GhostRow, ...]

    def to_dict(self) -> dict:
        """JSON-able dict: non-finite floats become None (JSON has no NaN/inf), as evaluate's report."""
        from sarproc.quality.metrics import jsonable

        return jsonable(
            dataclasses.asdict(self) | {"rows": [dataclasses.asdict(r) | {"error_db": r.error_db} for r in self.rows]}
        )


def _residual_figures(report: QualityReport) -> tuple[float, float, float]:
    """(residual floor, residual false target, guard-window figure) of a report, dB."""
    ft, floor, guard = report.false_target, report.residual, report.false_target_guard
    if floor is None or ft is None or guard is None:
        why = report.residual_note or "no false target"
        raise InputError(f"ghost-test: the residual false-target search gave no figures ({why})")
    return floor.floor_db, ft.level_db, guard.level_db


def injected_ghosts(
    clean: Product,
    ghosted: Product,
    params: EvaluateParams,
    levels: Sequence[float] = LEVELS_DB,
    progress: Callable[[Iterable[Any]], Iterable[Any]] | None = None,
) -> GhostTest:
    """G's response (GHOSTED - CLEAN) injected into CLEAN at each of ``levels`` and evaluated with ``params``
    (its residual search turned on) and CLEAN's targets table; ``progress`` wraps each evaluation's targets."""
    from sarproc.quality.metrics import evaluate_product

    if clean.data.ndim != 2:
        raise InputError("ghost-test: the residual false-target search is taken on 2D images only")
    if clean.data.shape != ghosted.data.shape or any(
        not np.allclose(clean.coords[d], ghosted.coords[d]) for d in clean.dims
    ):
        raise InputError("ghost-test: the ghost changed the image grid: put it inside the targets' extent")
    params = dataclasses.replace(params, residual=True)
    response = ghosted.data.astype(np.complex128) - clean.data
    base = evaluate_product(clean, params, progress=progress)
    floor_db, ft_db, guard_db = _residual_figures(base)
    ref = max(t.peak_amplitude for t in base.targets)
    g_index = np.unravel_index(np.argmax(np.abs(response)), response.shape)
    g_pos = {d: float(clean.coords[d][i]) for d, i in zip(clean.dims, g_index)}
    g_peak = float(np.abs(response[g_index]))
    cells = dict(zip(clean.dims, clean.attrs["theoretical_irw"]))
    rows = []
    for level in levels:
        a = 10 ** (level / 20) * ref / g_peak  # G's strongest pixel at `level` below the strongest target's peak
        product = dataclasses.replace(clean, data=(clean.data + a * response).astype(np.complex64))
        rep = evaluate_product(product, params, progress=progress)
        floor, _, guard = _residual_figures(rep)
        ft = rep.false_target
        assert ft is not None
        rows.append(
            GhostRow(
                injected_db=float(level),
                found_db=ft.pixel_level_db,
                found_position=dict(ft.position),
                error_cells={d: (ft.position[d] - g_pos[d]) / cells[d] for d in clean.dims},
                guard_db=guard,
                floor_db=floor,
            )
        )
    return GhostTest(
        dims=tuple(clean.dims),
        ghost_position=g_pos,
        ghost_peak=g_peak,
        reference_peak=ref,
        floor_db=floor_db,
        false_target_db=ft_db,
        guard_db=guard_db,
        rows=tuple(rows),
    )
