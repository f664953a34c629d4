"""The quicklook drawn with numpy: PNG bytes, dB ramp, pixels where their coordinates say, labels, targets."""

from __future__ import annotations

import struct
import zlib

import numpy as np
import pytest

from sarproc.quality.raster import (
    TARGET_RED,
    TEXT_HEIGHT,
    _glyphs,
    encode_png,
    gray_levels,
    nice_ticks,
    render_quicklook,
    text_mask,
    text_width,
)

UNITS = {"azimuth": "m", "range": "m", "elevation": "rad"}


def decode_png(data: bytes) -> np.ndarray:
    """RGB array of an 8-bit RGB PNG without filtering (what encode_png writes), chunk CRCs checked."""
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    pos, chunks = 8, {}
    while pos < len(data):
        (length,) = struct.unpack(">I", data[pos : pos + 4])
        kind, body = data[pos + 4 : pos + 8], data[pos + 8 : pos + 8 + length]
        (crc,) = struct.unpack(">I", data[pos + 8 + length : pos + 12 + length])
        assert crc == zlib.crc32(kind + body) & 0xFFFFFFFF
        chunks[kind] = chunks.get(kind, b"") + body
        pos += 12 + length
    w, h, depth, colour, _, _, interlace = struct.unpack(">IIBBBBB", chunks[b"IHDR"])
    assert (depth, colour, interlace) == (8, 2, 0) and b"IEND" in chunks
    rows = np.frombuffer(zlib.decompress(chunks[b"IDAT"]), np.uint8).reshape(h, 1 + 3 * w)
    assert (rows[:, 0] == 0).all()
    return rows[:, 1:].reshape(h, w, 3)


def spike_image(shape=(200, 300), spike=(120, 40), level_db=0.0):
    """Magnitude: a floor at -80 dB, a -25 dB pixel, a peak of 1 at ``spike``; azimuth 0.5 m, range 0.25 m."""
    mag = np.full(shape, 1e-4, np.float32)
    mag[spike] = 10 ** (level_db / 20)
    mag[10, 250] = 10 ** (-25 / 20)
    coords = {"azimuth": -30.0 + 0.5 * np.arange(shape[0]), "range": 1000.0 + 0.25 * np.arange(shape[1])}
    return mag, coords


def pixel_of(panel, row, col):
    """Canvas (y, x) of the centre of image pixel (row, col): first row at the bottom."""
    y = panel.top + (panel.rows - 1 - row) * panel.row_factor + panel.row_factor // 2
    x = panel.left + col * panel.col_factor + panel.col_factor // 2
    return y, x


def test_png_decodes_to_the_array_with_our_decoder_and_pil():
    rng = np.random.default_rng(0)
    rgb = rng.integers(0, 256, (37, 53, 3), dtype=np.uint8)
    data = encode_png(rgb)
    np.testing.assert_array_equal(decode_png(data), rgb)
    image = pytest.importorskip("PIL.Image")
    import io

    with image.open(io.BytesIO(data)) as im:
        assert im.mode == "RGB" and im.size == (53, 37)
        np.testing.assert_array_equal(np.asarray(im), rgb)
    with pytest.raises(ValueError, match="RGB"):
        encode_png(rgb[..., 0])


def test_font_has_a_distinct_glyph_for_every_printable_character():
    glyphs = _glyphs()
    assert sorted(glyphs) == [chr(c) for c in range(32, 127)]
    shapes = {g.tobytes() for c, g in glyphs.items()}
    assert len(shapes) == 95  # no two characters alike (1, l, I and 0, O, o included)
    assert not glyphs[" "].any() and all(g.any() for c, g in glyphs.items() if c != " ")
    # descenders below the baseline row only for g j p q y (and the comma)
    assert {c for c, g in glyphs.items() if g[7].any()} == set("gjpqy")
    m = text_mask("Ab")
    assert m.shape == (TEXT_HEIGHT, text_width("Ab")) and text_mask("\u00e9").tolist() == text_mask("?").tolist()


def test_gray_ramp_clips_at_the_dynamic_range():
    assert gray_levels(np.array([0.0, 3.0, -25.0, -50.0, -80.0]), 50.0).tolist() == [255, 255, 128, 0, 0]
    assert gray_levels(np.array([-10.0]), 20.0).tolist() == [128]


def test_nice_ticks():
    ticks, dec = nice_ticks(919.9, 1080.1, 60, 460)
    assert dec == 0 and ticks.tolist() == [925.0, 950.0, 975.0, 1000.0, 1025.0, 1050.0, 1075.0]
    ticks, dec = nice_ticks(-0.053, 0.053, 40, 340)
    assert dec == 2 and np.allclose(ticks, [-0.04, -0.02, 0.0, 0.02, 0.04])
    ticks, dec = nice_ticks(-12.6, 12.6, 40, 420)
    assert dec == 1 and np.allclose(ticks, np.arange(-12.5, 12.6, 2.5))


@pytest.mark.parametrize("dynamic_range_db", [50.0, 20.0])
def test_2d_picture_pixels_ramp_and_target(dynamic_range_db):
    mag, coords = spike_image()
    truth = np.array([[coords["azimuth"][120], coords["range"][40]]])
    pic = render_quicklook(
        mag, ("azimuth", "range"), coords, truth, ["T1"], UNITS, dynamic_range_db, title="t", frame="ground"
    )
    (panel,) = pic.panels
    assert (panel.rows, panel.cols, panel.row_factor, panel.col_factor) == (200, 300, 2, 1)
    # the image: every pixel a 2 x 1 block of its gray, first azimuth row at the bottom
    block = pic.rgb[panel.top : panel.top + 400, panel.left : panel.left + 300, 0]
    expected = gray_levels(20 * np.log10(mag[::-1]), dynamic_range_db).repeat(2, axis=0)
    drawn = block.copy()
    ring = np.all(pic.rgb[panel.top : panel.top + 400, panel.left : panel.left + 300] == TARGET_RED, axis=-1)
    inside_names = np.zeros_like(ring)
    for t in pic.texts:
        if t.text == "T1":
            m = text_mask("T1")
            y, x = t.y - panel.top, t.x - panel.left
            inside_names[max(y, 0) : y + m.shape[0], max(x, 0) : x + m.shape[1]] = True
    keep = ~ring & ~inside_names
    np.testing.assert_array_equal(drawn[keep], expected[keep])
    y, x = pixel_of(panel, 120, 40)
    assert pic.rgb[y, x].tolist() == [255, 255, 255]  # the peak: 0 dB
    y, x = pixel_of(panel, 10, 250)  # -25 dB: mid-gray at 50 dB, black at 20 dB
    assert pic.rgb[y, x, 0] == (128 if dynamic_range_db == 50 else 0)
    # the circle: red at 7 px from the target, not on it
    y, x = pixel_of(panel, 120, 40)
    assert (pic.rgb[y, x + 7] == TARGET_RED).all() and (pic.rgb[y - 7, x] == TARGET_RED).all()
    assert ring.sum() > 30
    # and its name, up and right of it, in red
    (name,) = [t for t in pic.texts if t.text == "T1"]
    assert name.x > x and name.y + TEXT_HEIGHT <= y
    assert (
        pic.rgb[name.y : name.y + TEXT_HEIGHT, name.x : name.x + text_width("T1")][text_mask("T1")] == TARGET_RED
    ).all()


def test_2d_picture_labels_ticks_and_colour_bar():
    mag, coords = spike_image()
    pic = render_quicklook(mag, ("azimuth", "range"), coords, units=UNITS, title="img.h5: image, 50 dB", frame="ground")
    (panel,) = pic.panels
    texts = {t.text: t for t in pic.texts}
    for label in ("img.h5: image, 50 dB", "range (m, ground frame)", "azimuth (m, ground frame)", "dB", "0", "-50"):
        assert label in texts
    assert texts["azimuth (m, ground frame)"].vertical and texts["dB"].vertical
    for t in pic.texts:  # every string is drawn: black (or red) where its mask is set
        m = np.rot90(text_mask(t.text)) if t.vertical else text_mask(t.text)
        region = pic.rgb[t.y : t.y + m.shape[0], t.x : t.x + m.shape[1]]
        assert (region[m] == 0).all(), t
    # range ticks under the image, each label centred on the column of its coordinate
    below = [t for t in pic.texts if t.y > panel.top + 400 and not t.vertical and t.text[0].isdigit()]
    assert [t.text for t in below] == ["1000", "1020", "1040", "1060"]
    for t in below:
        col = (float(t.text) - coords["range"][0]) / 0.25 + 0.5  # screen columns from the image's left edge
        assert abs(t.x + text_width(t.text) / 2 - (panel.left + col)) <= 1.0
    # azimuth ticks left of it: label centred on the row of its coordinate (first row at the bottom)
    left = [t for t in pic.texts if t.x < panel.left - 5 and t.y < panel.top + 400 and not t.vertical]
    values = [float(t.text) for t in left]
    assert values == [-30.0, -20.0, -10.0, 0.0, 10.0, 20.0, 30.0, 40.0, 50.0, 60.0]
    for t, v in zip(left, values):
        row = (v - coords["azimuth"][0]) / 0.5 + 0.5
        assert abs(t.y + TEXT_HEIGHT / 2 - (panel.top + 400 - 2 * row)) <= 1.0
    # the colour bar: white at the top, black at the bottom, the same ramp
    bar = pic.rgb[panel.top : panel.top + 400, panel.left + 300 + 16 + 5, 0]
    assert bar[0] == 255 and bar[-1] == 0 and (np.diff(bar.astype(int)) <= 0).all()


def test_cube_is_three_maximum_projections_with_targets():
    shape = (20, 60, 90)
    mag = np.full(shape, 1e-4, np.float32)
    mag[5, 30, 70] = 1.0
    coords = {
        "elevation": -0.05 + 0.005 * np.arange(20),
        "azimuth": -15 + 0.5 * np.arange(60),
        "range": 480.0 + 0.25 * np.arange(90),
    }
    dims = ("elevation", "azimuth", "range")
    truth = np.array([[coords[d][i] for d, i in zip(dims, (5, 30, 70))]])
    pic = render_quicklook(mag, dims, coords, truth, ["7"], UNITS, 50.0, "cube", "elevation")
    titles = [t.text for t in pic.texts if t.text.startswith("max over")]
    assert titles == ["max over elevation", "max over azimuth", "max over range"]
    assert len(pic.panels) == 3 and sum(t.text == "7" for t in pic.texts) == 3
    for panel, (r, c) in zip(pic.panels, [(30, 70), (5, 70), (5, 30)]):
        y, x = pixel_of(panel, r, c)
        assert pic.rgb[y, x].tolist() == [255, 255, 255]
        assert (pic.rgb[y, x + 7] == TARGET_RED).all()
        # small axes are drawn with whole screen pixels per image pixel, towards 240 px
        assert panel.rows * panel.row_factor >= 240 and panel.cols * panel.col_factor >= 240


def test_refuses_what_it_cannot_draw():
    with pytest.raises(ValueError, match="positive"):
        render_quicklook(
            np.ones((4, 4)), ("azimuth", "range"), {"azimuth": np.arange(4), "range": np.arange(4)}, dynamic_range_db=0
        )
    with pytest.raises(ValueError, match="2D images and 3D cubes"):
        render_quicklook(np.ones(4), ("range",), {"range": np.arange(4)})


def test_a_constant_or_one_pixel_image_still_draws():
    pic = render_quicklook(
        np.zeros((1, 5)), ("azimuth", "range"), {"azimuth": np.array([3.0]), "range": np.arange(5.0)}
    )
    assert pic.rgb.shape[2] == 3 and (pic.rgb[pic.panels[0].top, pic.panels[0].left] == 0).all()
    assert decode_png(encode_png(pic.rgb)).shape == pic.rgb.shape
