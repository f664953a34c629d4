"""Resource plans (product/budget.py): sizes, and refusals of outputs and memory that cannot fit."""

from __future__ import annotations

import os

import numpy as np
import pytest

from sarproc.product import budget
from sarproc.product.budget import Plan, check_plan, parse_size, stored_bytes
from sarproc.product.errors import InputError


@pytest.mark.parametrize(
    "text,n",
    [
        ("4G", 4_000_000_000),
        ("500 MB", 500_000_000),
        ("2GiB", 2 * 1024**3),
        ("1.5k", 1500),
        ("12345", 12345),
        ("1 KiB", 1024),
        ("3T", 3e12),
    ],
)
def test_parse_size(text, n):
    assert parse_size(text) == n


@pytest.mark.parametrize("text", ["lots", "-1G", "0", "4 GHz", ""])
def test_parse_size_refuses(text):
    with pytest.raises(InputError, match="--max-memory"):
        parse_size(text)


def plan(out=1e6, mem=1e6):
    return Plan("stage", out, mem, 1.0, "n x m")


def test_plan_that_fits_passes(tmp_path):
    check_plan(plan(), [tmp_path / "o.h5"], max_memory=10**9)


def test_max_memory_refusal_names_the_option_and_the_fix(tmp_path):
    with pytest.raises(
        InputError,
        match=r"stage: needs ~2 MB of working memory \(n x m\), above --max-memory 1 MB; "
        "raise --max-memory",
    ):
        check_plan(plan(mem=2e6), [tmp_path / "o.h5"], max_memory=10**6)


def test_available_memory_refusal(tmp_path, monkeypatch):
    monkeypatch.setattr(budget, "available_memory", lambda: 5 * 10**5)
    with pytest.raises(InputError, match="but only 500 kB is available"):
        check_plan(plan(mem=1e6), [tmp_path / "o.h5"])


def test_free_space_refusal_names_the_output(tmp_path, monkeypatch):
    class St:
        f_bavail, f_frsize = 10, 4096

    monkeypatch.setattr(budget.os, "statvfs", lambda p: St)
    with pytest.raises(InputError, match=r"o.h5: the output needs ~1 MB \(n x m\) but .* has only 41 kB free"):
        check_plan(plan(out=1e6), [tmp_path / "o.h5"])


def test_file_size_limit_refusal(tmp_path, monkeypatch):
    monkeypatch.setattr(budget, "file_size_limit", lambda: 1000)
    with pytest.raises(InputError, match=r"ulimit -f"):
        check_plan(plan(out=1e6), [tmp_path / "o.h5"])


def test_available_memory_is_a_positive_number():
    avail = budget.available_memory()
    assert avail is None or avail > 0


@pytest.mark.parametrize("shape", [(590, 612), (3, 100, 50), (7000, 1000), (1, 1)])
def test_stored_bytes_bounds_the_written_data_set(tmp_path, shape):
    """The estimate is the data set's allocated size (whole chunks); the file adds only metadata."""
    import h5py

    from sarproc.product.io import _chunks

    with h5py.File(tmp_path / "d.h5", "w") as f:
        d = f.create_dataset("x", shape=shape, dtype=np.complex64, chunks=_chunks(shape))
        d[...] = 1
        allocated = d.id.get_storage_size()
    assert stored_bytes(*shape) == allocated
    assert os.path.getsize(tmp_path / "d.h5") >= allocated


def test_fft_seconds_is_a_positive_time_and_refuses_no_repeats():
    t = budget.fft_seconds((64, 128))
    assert 0 < t < 5 and np.isfinite(t)
    assert budget.fft_seconds((3, 64, 128), repeats=1) > 0  # a stack: one 2-D FFT per leading index
    with pytest.raises(ValueError, match="repeats"):
        budget.fft_seconds((8, 8), repeats=0)
