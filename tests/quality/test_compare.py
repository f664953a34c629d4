"""sarproc compare (make compare-products / compare-reproductions): what it reads off two products or folders."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import h5py
import numpy as np

from sarproc.quality import compare as cp
from tests.cli.test_quicklook import image_without_targets


def test_signal_difference_read_in_blocks_matches_the_whole_array(tmp_path, monkeypatch):
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


def test_the_command_tabulates_two_folders_and_two_files(tmp_path):
    base, new = tmp_path / "base", tmp_path / "new"
    for d in (base / "sub", new / "sub"):
        d.mkdir(parents=True)
        image_without_targets(d / "image.h5")
        (d / "notes.md").write_text("| name | irw |\n|---|---:|\n| A | 1.50 |\n")
        (d / "plot.png").write_bytes(b"skipped")
    with h5py.File(new / "sub" / "image.h5", "r+") as f:
        f["image"][5, :] = f["image"][5, :] * np.complex64(2)
    (new / "sub" / "notes.md").write_text("| name | irw |\n|---|---:|\n| A | 1.75 |\n")
    cmd = [sys.executable, "-m", "sarproc", "compare"]
    out = subprocess.run([*cmd, str(base), str(new)], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    rows = {line.split("|")[1].strip(): line for line in out.stdout.splitlines() if line.startswith("| sub/")}
    assert set(rows) == {"sub/image.h5", "sub/notes.md"}  # the figure skipped
    assert " dB |" in rows["sub/image.h5"] and "identical" not in rows["sub/image.h5"]
    assert "irw 0.25" in rows["sub/notes.md"]
    one = str(base / "sub" / "image.h5")
    same = subprocess.run([*cmd, one, one], capture_output=True, text=True)
    assert same.returncode == 0 and "| identical |" in same.stdout
    mixed = subprocess.run([*cmd, str(base), one], capture_output=True, text=True)
    assert mixed.returncode == 2 and "two files or two folders" in mixed.stderr


def test_json_output_gives_the_products_signal_figures_as_numbers(tmp_path):
    """`sarproc compare BASE NEW -o FILE`: the tables as JSON, a product's signal figures as numbers (what
    scripts/range_upsample_effect.py tabulates), equal to difference_db's."""
    from click.testing import CliRunner

    from sarproc.cli.main import cli

    base, new, out = tmp_path / "base.h5", tmp_path / "new.h5", tmp_path / "diff.json"
    image_without_targets(base)
    image_without_targets(new)
    with h5py.File(new, "r+") as f:
        f["image"][5, :] = f["image"][5, :] * np.complex64(1.5)
    with h5py.File(base) as fa, h5py.File(new) as fb:
        db, rel = cp.difference_db(fa["image"][()], fb["image"][()])
    res = CliRunner().invoke(cli, ["compare", str(base), str(new), "-o", str(out)])
    assert res.exit_code == 0, res.output
    (entry,) = json.loads(out.read_text())["files"]
    assert entry["table"] == "h5" and entry["cells"]["signal diff / signal"] == f"{db:.1f} dB"
    assert entry["signal_db"] == db and entry["max_rel"] == rel and -60 < db < 0
    res = CliRunner().invoke(cli, ["compare", str(base), str(base), "-o", str(out), "--overwrite"])
    (entry,) = json.loads(out.read_text())["files"]
    assert res.exit_code == 0 and entry["signal_db"] == -math.inf and entry["max_rel"] == 0
    assert CliRunner().invoke(cli, ["compare", str(base), str(new), "-o", str(out)]).exit_code == 2  # exists


def test_json_output_gives_the_peak_ratio_and_the_norm_ratio(tmp_path, monkeypatch):
    """`sarproc compare BASE NEW -o`: ``peak_db`` is 20 log10(max |new| / max |base|) and 10^(signal_db / 20) is
    ||new - base|| / ||base|| (scripts/reproduce_003.py's static-against-single-channel figures, computed there
    with numpy before), the peak read in blocks as the whole array's."""
    from click.testing import CliRunner

    from sarproc.cli.main import cli

    base, new, out = tmp_path / "base.h5", tmp_path / "new.h5", tmp_path / "diff.json"
    image_without_targets(base)
    image_without_targets(new)
    with h5py.File(new, "r+") as f:
        d = f["image"]
        k = np.unravel_index(np.argmax(np.abs(d[()])), d.shape)
        d[k] = d[k] * np.complex64(1.25)  # the peak up by 1.94 dB
        d[7, :] = d[7, :] * np.complex64(0.5)
    with h5py.File(base) as fa, h5py.File(new) as fb:
        a, b = fa["image"][()].astype(np.complex128), fb["image"][()].astype(np.complex128)
        monkeypatch.setattr(cp, "BLOCK_BYTES", 5 * a.shape[1] * 8)  # 5 rows a block
        assert cp.dataset_peak(fb["image"]) == np.abs(b).max()
    res = CliRunner().invoke(cli, ["compare", str(base), str(new), "-o", str(out)])
    assert res.exit_code == 0, res.output
    (entry,) = json.loads(out.read_text())["files"]
    assert math.isclose(entry["peak_db"], 20 * math.log10(np.abs(b).max() / np.abs(a).max()), rel_tol=1e-12)
    assert math.isclose(entry["peak_db"], 20 * math.log10(1.25), rel_tol=1e-6)
    ratio = np.linalg.norm(b - a) / np.linalg.norm(a)
    assert math.isclose(10 ** (entry["signal_db"] / 20), ratio, rel_tol=1e-12)
    res = CliRunner().invoke(cli, ["compare", str(base), str(base), "-o", str(out), "--overwrite"])
    assert json.loads(out.read_text())["files"][0]["peak_db"] == 0.0
    assert cp.peak_ratio_db(0.0, 0.0) == -math.inf and cp.peak_ratio_db(0.0, 1.0) == math.inf


def test_products_of_different_kinds_are_a_row_not_an_internal_error(tmp_path):
    """Session 42 trial: `compare image.h5 raw.h5` (an image against its raw) ended in "internal error:
    KeyError ... object 'image' doesn't exist", exit 1; two folders holding them likewise. Now the row says
    the kinds differ, as it says shapes differ."""
    from click.testing import CliRunner

    from sarproc.cli.main import cli
    from sarproc.product.io import read_product, write_product

    image, _ = image_without_targets(tmp_path / "image.h5")
    product = read_product(image)
    raw = tmp_path / "raw.h5"
    coords = {"azimuth_time": np.arange(300) * 1e-3, "range_time": 2e-6 + np.arange(170) * 1e-8}
    write_product(raw, type(product)(**{**vars(product), "kind": "raw", "dims": tuple(coords), "coords": coords}))
    res = CliRunner().invoke(cli, ["compare", str(image), str(raw), "-o", str(tmp_path / "d.json")])
    assert res.exit_code == 0, res.output
    (entry,) = json.loads((tmp_path / "d.json").read_text())["files"]
    assert entry["cells"]["signal diff / signal"] == "kinds differ: image vs raw"
    assert entry["signal_db"] is None and entry["peak_db"] is None
