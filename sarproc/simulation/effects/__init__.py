"""Simulator effects: each module here registers one effect plugin (see base.py).

Modules are imported automatically, so adding an effect means adding a file; no existing
effect or the simulator core changes.
"""

from __future__ import annotations

import importlib
import pkgutil
from typing import TYPE_CHECKING

from sarproc.product.config import build
from sarproc.product.errors import InputError
from sarproc.simulation.effects.base import EFFECTS, Effect, register_effect  # noqa: F401

if TYPE_CHECKING:
    from sarproc.product.metadata import RadarMetadata
    from sarproc.simulation.scene import SceneParams

for _mod in pkgutil.iter_modules(__path__):
    if _mod.name != "base":
        importlib.import_module(f"{__name__}.{_mod.name}")


def build_effects(mapping: dict, scene_params: SceneParams, radar: RadarMetadata, source: str) -> list[Effect]:
    """Instantiate the declared effects, in their fixed application order."""
    effects = []
    for key, cfg in (mapping or {}).items():
        if key not in EFFECTS:
            raise InputError(f"{source}: effects: unknown effect {key!r}; known: {sorted(EFFECTS)}")
        cls = EFFECTS[key]
        params: object = build(cls.Params, cfg if cfg is not None else {}, source=source, section=f"effects.{key}")
        effects.append(cls(params, scene_params, radar))
    return sorted(effects, key=lambda e: e.order)
