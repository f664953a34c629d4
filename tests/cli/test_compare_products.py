"""scripts/compare_products.py (make compare-products / compare-reproductions): what it reads off two folders."""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import h5py
import numpy as np

from tests.cli.test_quicklook import image_without_targets

SCRIPT = Path(__file__).resolve().parents[2] / "scripts" / "compare_products.py"


def load_script():
    spec = importlib.util.spec_from_file_location("compare_products", SCRIPT)
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_signal_difference_read_in_blocks_matches_the_whole_array(tmp_path, monkeypatch):
    cp = load_script()
    base, new = tmp_path / "base" / "sub", tmp_path / "new" / "sub"
    base.mkdir(parents=True)
    new.mkdir(parents=True)
    image_without_targets(base / "image.h5")
    image_without_targets(new / "image.h5")
    with h5py.File(new / "image.h5", "r+") as f:
        d = f["image"]
        d[5, :] = d[5, :] * np.complex64(1 + 1e-6)
        d[250, 3] = d[250, 3] + np.complex64(2e-7)
    with h5py.File(base / "image.h5") as fa, h5py.File(new / "image.h5") as fb:
        a, b = fa["image"][()], fb["image"][()]
        whole = cp.difference_db(a, b)
        monkeypatch.setattr(cp, "BLOCK_BYTES", 7 * a.shape[1] * 8)  # 7 rows a block, the last one short
        blocks = cp.dataset_difference_db(fa["image"], fb["image"])
    assert np.isfinite(whole[0]) and whole[0] < -100
    assert math.isclose(blocks[0], whole[0], rel_tol=1e-12) and blocks[1] == whole[1]
    row = cp.compare_hdf5(base / "image.h5", new / "image.h5")
    assert row["signal"] == f"{whole[0]:.1f} dB" and row["attrs"] == "none"
    assert cp.compare_hdf5(base / "image.h5", base / "image.h5")["signal"] == "identical"


def test_markdown_tables_paired_by_header_and_first_cell(tmp_path):
    cp = load_script()
    base, new = tmp_path / "a.md", tmp_path / "b.md"
    base.write_text("# T\n\n| name | irw | note |\n|---|---:|---|\n| A | 1.50 | ok |\n| B | -13.2 dB | x |\n")
    new.write_text(
        "# T\n\n| name | irw | note |\n|---|---:|---|\n| B | -13.5 dB | y |\n| A | 1.50 | ok |\n| C | 2 | z |\n"
    )
    r = cp.compare_markdown(base, new)
    assert r["tables"] == "1 paired, 0 unpaired, 1 unpaired rows"
    assert r["cells"] == "2 of 6"
    assert r["moved"] == "irw 0.3"
    assert r["text"] == "B / note: 'x' -> 'y'"
