"""Shared fixtures: small scenes built as mappings, so each test states what it changes."""

from __future__ import annotations

import copy
import os

import pytest

# The backprojection kernels compiled ahead of time (sarproc.product.aot) are off in the tests unless a test
# turns them on: otherwise the first small backprojection would start a background build and later tests would
# run one kernel or the other depending on when it finished. tests/focus/test_backprojection_aot.py builds its
# own module and checks it against numba's.
os.environ.setdefault("SARPROC_AOT", "0")

BASE_SCENE = {
    "radar": {
        "carrier_frequency": "10 GHz",
        "bandwidth": "100 MHz",
        "pulse_duration": "1 us",
        "range_sampling_rate": "120 MHz",
        "prf": "400 Hz",
    },
    "platform": {"velocity": "100 m/s", "altitude": "0 m"},
    "geometry": {"reference_range": "2 km", "squint": "0 deg"},
    "acquisition": {"mode": "spotlight", "aperture_time": "0.5 s"},
    "targets": {"frame": "squint", "points": [{"name": "A"}]},
}


def merge(base: dict, changes: dict) -> dict:
    """Deep-merge ``changes`` into a copy of ``base`` (None deletes a key)."""
    out = copy.deepcopy(base)
    for k, v in changes.items():
        if v is None:
            out.pop(k, None)
        elif isinstance(v, dict) and isinstance(out.get(k), dict):
            out[k] = merge(out[k], v)
        else:
            out[k] = copy.deepcopy(v)
    return out


@pytest.fixture
def scene_mapping():
    """Factory: scene_mapping(**section_changes) -> a small valid scene mapping."""

    def make(**changes):
        return merge(BASE_SCENE, changes)

    return make
