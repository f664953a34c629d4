"""`sarproc quicklook`: pictures of any image product, truth or not, big images in blocks."""

from __future__ import annotations

import numpy as np
import pytest
from click.testing import CliRunner

from sarproc.cli.main import cli
from sarproc.product.io import read_magnitude_preview, write_product
from sarproc.product.model import Product, make_targets
from tests.cli.test_evaluate_cli import make_image, radar

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def run(*args):
    return CliRunner().invoke(cli, ["quicklook", *map(str, args)])


def image_without_targets(path, shape=(300, 170), spikes=((123, 45, 3.0), (7, 160, 2.0))):
    """Low noise with a few one-pixel spikes, and an empty targets table (as real data has)."""
    rng = np.random.default_rng(1)
    data = (1e-3 * (rng.standard_normal(shape) + 1j * rng.standard_normal(shape))).astype(np.complex64)
    for i, j, a in spikes:
        data[i, j] = a
    coords = {"azimuth": np.arange(shape[0]) * 0.5 - 40.0, "range": 1000.0 + np.arange(shape[1]) * 0.25}
    empty = make_targets([], np.zeros((0, 3)), np.zeros(0))
    write_product(
        path,
        Product(
            kind="image",
            data=data,
            dims=("azimuth", "range"),
            coords=coords,
            radar=radar(),
            targets=empty,
            attrs={"frame": {"name": "ground"}},
        ),
    )
    return path, data


def test_preview_blocks_equal_whole_image_block_maxima(tmp_path):
    path, data = image_without_targets(tmp_path / "img.h5")
    # 300 x 170 to at most 64 per axis: factors 5 and 3; tiny blocks force many reads and a ragged last one.
    preview, dims, coords, factors = read_magnitude_preview(path, max_side=64, block_bytes=7 * 170 * 8)
    assert factors == (5, 3) and preview.shape == (60, 57) and dims == ("azimuth", "range")
    mag = np.abs(data)
    padded = np.pad(mag, ((0, 0), (0, 1)))  # 170 -> 171 = 57 x 3
    expected = padded.reshape(60, 5, 57, 3).max(axis=(1, 3))
    np.testing.assert_array_equal(preview, expected.astype(np.float32))
    # a one-pixel spike keeps its full level and lands in the block that holds it
    assert preview[123 // 5, 45 // 3] == pytest.approx(3.0) and preview[7 // 5, 160 // 3] == pytest.approx(2.0)
    # coordinates are block centres; the ragged last range block holds samples 168 and 169 only
    assert coords["azimuth"][123 // 5] == pytest.approx(-40.0 + 122 * 0.5)
    assert coords["range"][-1] == pytest.approx(1000.0 + 168.5 * 0.25)


def test_preview_of_small_image_is_the_magnitude(tmp_path):
    path, data = image_without_targets(tmp_path / "img.h5", shape=(40, 30), spikes=((3, 4, 1.0),))
    preview, _, coords, factors = read_magnitude_preview(path)
    assert factors == (1, 1)
    np.testing.assert_array_equal(preview, np.abs(data))
    assert coords["range"][0] == 1000.0


def test_picture_of_image_without_targets(tmp_path):
    path, _ = image_without_targets(tmp_path / "img.h5")
    out = tmp_path / "ql.png"
    res = run(path, "-o", out, "--dynamic-range", 40)
    assert res.exit_code == 0, res.output
    assert out.read_bytes()[:8] == PNG_SIGNATURE and "300 x 170 pixels drawn" in res.output
    assert not list(tmp_path.glob("*.tmp*")) and not list(tmp_path.glob(".*sarproc-tmp*"))
    # an existing picture is kept unless --overwrite
    before = out.read_bytes()
    res = run(path, "-o", out)
    assert res.exit_code == 2 and "--overwrite" in res.output and out.read_bytes() == before
    res = run(path, "-o", out, "--overwrite", "--max-pixels", 32, "--no-targets")
    assert res.exit_code == 0 and "30 x 29 pixels drawn" in res.output and out.read_bytes() != before


@pytest.mark.parametrize("three_d", [False, True])
def test_picture_with_targets_2d_and_cube(tmp_path, three_d):
    path = make_image(tmp_path / "img.h5", three_d=three_d)
    out = tmp_path / "ql.png"
    res = run(path, "-o", out)
    assert res.exit_code == 0, res.output
    assert out.read_bytes()[:8] == PNG_SIGNATURE


def test_refuses_raw_products_and_bad_knobs(tmp_path):
    path, _ = image_without_targets(tmp_path / "img.h5")
    res = run(path, "-o", tmp_path / "ql.png", "--dynamic-range", 0)
    assert res.exit_code == 2
    assert not (tmp_path / "ql.png").exists()
    raw = tmp_path / "raw.h5"
    data = np.ones((4, 8), np.complex64)
    write_product(
        raw,
        Product(
            kind="raw",
            data=data,
            dims=("azimuth_time", "range_time"),
            coords={"azimuth_time": np.arange(4) / 500.0, "range_time": 6.6e-5 + np.arange(8) / 180e6},
            radar=radar(),
            targets=make_targets([], np.zeros((0, 3)), np.zeros(0)),
        ),
    )
    res = run(raw, "-o", tmp_path / "ql.png")
    assert res.exit_code == 2 and "raw" in res.output and not (tmp_path / "ql.png").exists()


LEAN_RUN = """
import sys
{before}
from sarproc.cli.main import run_cli
assert run_cli(["-q", "quicklook", "--renderer", "matplotlib", *sys.argv[1:]]) == 0
import matplotlib.artist, matplotlib.lines
from sarproc.cli.quicklook import ARTIST_DOC_STUB
print("STUBBED" if ARTIST_DOC_STUB in matplotlib.lines.Line2D.set.__doc__ else "FULL")
print("RESTORED" if ARTIST_DOC_STUB not in matplotlib.artist.kwdoc(matplotlib.lines.Line2D) else "STILL STUBBED")
import inspect
print("SIGNED" if "linewidth" in str(inspect.signature(matplotlib.lines.Line2D.set)) else "UNSIGNED")
class Later(matplotlib.lines.Line2D):  # defined after the import: matplotlib's own set() again
    pass
print("RESTORED" if "linewidth" in str(inspect.signature(Later.set)) else "STILL LEAN")
"""


@pytest.mark.parametrize("kind", ["targets", "no targets", "cube"])
def test_lean_matplotlib_import_draws_the_same_picture(tmp_path, kind):
    # a fresh process, as a user runs it: matplotlib imported without its property docstrings and set()
    # signatures, the PNG byte-identical to the one drawn with matplotlib imported in full first, and kwdoc
    # and the signatures of classes defined later working again after
    import subprocess
    import sys

    if kind == "no targets":
        path, _ = image_without_targets(tmp_path / "img.h5")
    else:
        path = make_image(tmp_path / "img.h5", three_d=kind == "cube")
    outputs = {}
    for mode, before in (("lean", ""), ("full", "import matplotlib.figure")):
        out = tmp_path / f"{mode}.png"
        done = subprocess.run(
            [sys.executable, "-c", LEAN_RUN.format(before=before), str(path), "-o", str(out)],
            capture_output=True,
            text=True,
            check=True,
        )
        outputs[mode] = (out.read_bytes(), done.stdout.split())
    assert outputs["lean"][1] == ["STUBBED", "RESTORED", "UNSIGNED", "RESTORED"]
    assert outputs["full"][1] == ["FULL", "RESTORED", "SIGNED", "RESTORED"]
    assert outputs["lean"][0][:8] == PNG_SIGNATURE and outputs["lean"][0] == outputs["full"][0]


BUILTIN_RUN = """
import sys
from sarproc.cli.main import run_cli
assert run_cli(["-q", "quicklook", *sys.argv[1:]]) == 0
print(sorted(m for m in sys.modules if m.split(".")[0] in ("matplotlib", "PIL", "pyparsing")))
"""


@pytest.mark.parametrize("three_d", [False, True])
def test_default_picture_is_drawn_without_matplotlib(tmp_path, three_d):
    # a fresh process, as a user runs it: no matplotlib imported (0.42-0.48 s of the process, docs/performance.md
    # twelfth round); the PNG holds the peak where the target is, circled in red
    import subprocess
    import sys

    from tests.quality.test_raster import decode_png

    path = make_image(tmp_path / "img.h5", three_d=three_d)
    out = tmp_path / "ql.png"
    done = subprocess.run(
        [sys.executable, "-c", BUILTIN_RUN, str(path), "-o", str(out)], capture_output=True, text=True, check=True
    )
    assert done.stdout.split()[-1] == "[]"
    rgb = decode_png(out.read_bytes())
    red = np.all(rgb == (214, 39, 40), axis=-1)
    assert rgb.shape[1] > (900 if three_d else 300) and red.sum() > (150 if three_d else 50)
    assert (rgb == 255).all(axis=-1).sum() > 0  # the peaks: 0 dB white
    res = run(path, "-o", tmp_path / "mpl.png", "--renderer", "matplotlib")
    assert res.exit_code == 0, res.output
    assert (tmp_path / "mpl.png").read_bytes()[:8] == PNG_SIGNATURE


@pytest.mark.parametrize("name", ["pic.jpg", "pic.JPEG", "pic.tif"])
def test_an_output_named_for_another_format_is_refused(tmp_path, name):
    """Session 41 new-user trial, row 3b: `quicklook -o pic.jpg` wrote PNG bytes into pic.jpg, silently."""
    path, _ = image_without_targets(tmp_path / "img.h5")
    res = run(path, "-o", tmp_path / name)
    assert res.exit_code == 2, res.output
    assert "'-o'" in res.output and "writes PNG only" in res.output and "pic.png" in res.output
    assert not (tmp_path / name).exists()
    assert run(path, "-o", tmp_path / "pic.PNG").exit_code == 0  # the suffix in any case
    assert run(path, "-o", tmp_path / "picture").exit_code == 0  # none (a FIFO, /dev/null) is taken
    assert (tmp_path / "picture").read_bytes().startswith(PNG_SIGNATURE)
