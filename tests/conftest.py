"""Shared fixtures: small scenes built as mappings, so each test states what it changes."""

from __future__ import annotations

import contextlib
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

# scripts/evaluate_campaign.py's squinted stripmap (2 deg beam, 150 MHz, 1.2 s track), imaged in its zero-Doppler
# frame; a test merges in its squint, antenna pattern and targets.
CAMPAIGN_STRIPMAP = {
    "radar": {
        "carrier_frequency": "10 GHz",
        "bandwidth": "150 MHz",
        "pulse_duration": "2 us",
        "range_sampling_rate": "180 MHz",
        "prf": "1500 Hz",
    },
    "platform": {"velocity": "100 m/s", "altitude": "500 m"},
    "geometry": {"reference_range": "2 km", "squint": "0 deg"},
    "acquisition": {"mode": "stripmap", "aperture_time": "1.2 s"},
    "effects": {"antenna": {"pattern": "sinc", "azimuth_beamwidth": "2 deg"}},
    "targets": {"frame": "zero_doppler", "points": [{"name": "A"}]},
    "simulation": {"waveform": "band_limited"},
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


@pytest.fixture(scope="module")
def fresh_numba(tmp_path_factory):
    """A numba cache that only this module's subprocesses write: their numba kernels are compiled there from the
    sources by a plain process. A cache written by other processes, or kernels a long test process compiled
    earlier, can differ from a fresh compile in the last bits (docs/performance.md, "Traced (session 18)"),
    which a bit-for-bit comparison with a compiled module must not depend on."""
    return tmp_path_factory.mktemp("numba-cache")


def compiled_module_env(directory, numba_cache):
    """The environment of a subprocess that loads the compiled modules in ``directory`` (SARPROC_AOT=1), imports
    this tree and compiles numba's kernels into ``numba_cache`` (a :func:`fresh_numba`)."""
    from pathlib import Path

    root = str(Path(__file__).resolve().parents[1])
    return {
        **os.environ,
        "SARPROC_AOT_DIR": str(directory),
        "SARPROC_AOT": "1",
        "PYTHONPATH": root,
        "NUMBA_CACHE_DIR": str(numba_cache),
    }


@contextlib.contextmanager
def aot_environment(directory):
    """SARPROC_AOT=1 with modules in ``directory`` for the block, both variables as they were after it (a
    module-scoped fixture cannot use monkeypatch)."""
    keys = ("SARPROC_AOT_DIR", "SARPROC_AOT")
    old = [os.environ.get(key) for key in keys]
    os.environ["SARPROC_AOT_DIR"], os.environ["SARPROC_AOT"] = str(directory), "1"
    try:
        yield
    finally:
        for key, value in zip(keys, old, strict=True):
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value


def build_aot_kernels(group, directory):
    """``group``'s (a :class:`sarproc.product.aot.Kernels`) compiled module, built into ``directory`` through the
    background builder's own command and loaded as a process with SARPROC_AOT=1 would; the build writes nothing
    into numba's cache."""
    import subprocess
    import sys
    from pathlib import Path

    from sarproc.product import aot

    directory.chmod(0o700)
    root = str(Path(__file__).resolve().parents[1])
    numba_cache = directory / "numba-cache"  # the user's numba cache as the builder sees it: it must stay empty
    env = {
        **os.environ,
        "SARPROC_AOT_DIR": str(directory),
        "SARPROC_AOT": "1",
        "PYTHONPATH": root,
        "NUMBA_CACHE_DIR": str(numba_cache),
    }
    done = subprocess.run(
        [sys.executable, "-m", "sarproc.product.aot", group.owner, aot.module_key(group.source_paths)],
        capture_output=True,
        text=True,
        check=False,
        env=env,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    # its callees compiled in a build differ in the last bits from a plain process's (aot.private_numba_cache)
    assert not numba_cache.exists() or not any(numba_cache.iterdir())
    aot._LOADED.pop(group.name, None)
    try:
        with aot_environment(directory):
            module = group.load()
    finally:
        aot._LOADED.pop(group.name, None)
    assert module is not None and group.is_compiled(module)
    return module
