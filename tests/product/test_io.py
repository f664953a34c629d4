import hashlib
import json
import os
import time

import h5py
import numpy as np
import pytest

from sarproc.product.errors import InputError
from sarproc.product.io import ProductWriter, WriteBehind, read_product, write_product
from sarproc.product.metadata import RadarMetadata
from sarproc.product.model import Product, make_targets


def radar(**kw):
    base = dict(
        carrier_frequency=9.65e9,
        bandwidth=1.5e8,
        pulse_duration=1.3e-6,
        chirp_rate=-1.5e8 / 1.3e-6,
        range_sampling_rate=1.8e8,
        prf=1234.5678,
        velocity=7012.25,
        altitude=0.0,
        squint=0.5235987755982988,
        reference_range=300e3,
        scene_center=(1.5e5, 259807.62113533, 0.0),
        mode="spotlight",
        azimuth_beamwidth=0.0123,
        aperture_time=0.2852,
        n_channels=1,
    )
    base.update(kw)
    return RadarMetadata(**base)


def image_product(n_az=8, n_rg=6):
    data = (np.arange(n_az * n_rg).reshape(n_az, n_rg) * (1 + 2j)).astype(np.complex64)
    coords = {"azimuth": np.linspace(-1, 1, n_az), "range": 300e3 + np.arange(n_rg) * 0.5}
    targets = make_targets(
        ["A", "B"], [[0, 1, 2], [3, 4, 5]], [1, 0.5j], frame_coords=([0, 1], [300e3, 300e3 + 1], [0, 0])
    )
    return Product(
        "image",
        data,
        ("azimuth", "range"),
        coords,
        radar(),
        targets,
        attrs={"frame": {"name": "squint", "squint": 0.5, "altitude": 0.0}, "theoretical_irw": [0.9, 0.8]},
        history=[{"command": "test", "parameters": {"a": 1}}],
    )


def test_radar_metadata_roundtrips_exactly(tmp_path):
    p = image_product()
    write_product(tmp_path / "x.h5", p)
    q = read_product(tmp_path / "x.h5")
    assert q.radar == p.radar  # bit-exact floats, tuple scene centre, strings


def test_product_roundtrip_and_contract_layout(tmp_path):
    p = image_product()
    write_product(tmp_path / "x.h5", p)
    q = read_product(tmp_path / "x.h5", kinds=("image",))
    np.testing.assert_array_equal(q.data, p.data)
    assert q.dims == ("azimuth", "range")
    for d in q.dims:
        np.testing.assert_array_equal(q.coords[d], p.coords[d])
    np.testing.assert_array_equal(q.targets, p.targets)
    assert q.attrs["frame"]["name"] == "squint" and q.attrs["theoretical_irw"] == [0.9, 0.8]
    assert q.history == p.history
    with h5py.File(tmp_path / "x.h5") as f:
        assert f.attrs["product"] == "image" and f.attrs["sarproc_format"] == "1"
        assert json.loads(f.attrs["history"])[0]["command"] == "test"
        assert f["image"].dtype == np.complex64
        assert f["range"].attrs["units"] == "m"
        assert "carrier_frequency" in f["radar"].attrs


def test_xarray_reads_labelled_coordinates(tmp_path):
    xr = pytest.importorskip("xarray")
    write_product(tmp_path / "x.h5", image_product())
    with xr.open_dataset(tmp_path / "x.h5", engine="h5netcdf") as ds:
        img = ds["image"]
        assert img.dims == ("azimuth", "range")
        np.testing.assert_allclose(img["range"].values, 300e3 + np.arange(6) * 0.5)
        assert img["azimuth"].attrs["units"] == "m"
        assert complex(img.values[1, 1]) == pytest.approx(7 * (1 + 2j))


def _digest(path):
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_failed_write_leaves_no_file_and_input_untouched(tmp_path):
    inp = tmp_path / "in.h5"
    write_product(inp, image_product())
    before = _digest(inp)
    out = tmp_path / "out.h5"
    p = image_product()
    with (
        pytest.raises(RuntimeError),
        ProductWriter(out, "image", p.dims, p.coords, p.radar, p.targets, inputs=[inp]) as w,
    ):
        w.write((slice(0, 2), slice(None)), p.data[:2])
        raise RuntimeError("interrupted")
    assert not out.exists()
    assert [x.name for x in tmp_path.iterdir()] == ["in.h5"]  # no temporary left behind
    assert _digest(inp) == before


def test_refuses_overwrite_and_writing_over_input(tmp_path):
    inp = tmp_path / "in.h5"
    write_product(inp, image_product())
    with pytest.raises(InputError, match="output exists; pass --overwrite"):
        write_product(inp, image_product())
    with pytest.raises(InputError, match="output is the input file"):
        write_product(inp, image_product(), inputs=[inp], overwrite=True)
    write_product(tmp_path / "other.h5", image_product())
    write_product(tmp_path / "other.h5", image_product(), overwrite=True)


def test_read_errors_name_file_and_item(tmp_path):
    with pytest.raises(InputError, match="missing.h5: file not found"):
        read_product(tmp_path / "missing.h5")
    (tmp_path / "text.h5").write_text("not hdf5")
    with pytest.raises(InputError, match="text.h5: not an HDF5 file"):
        read_product(tmp_path / "text.h5")
    write_product(tmp_path / "img.h5", image_product())
    with pytest.raises(InputError, match="img.h5: product type is 'image'; this stage needs 'raw'"):
        read_product(tmp_path / "img.h5", kinds=("raw",))
    with h5py.File(tmp_path / "img.h5", "a") as f:
        del f["radar"].attrs["prf"]
    with pytest.raises(InputError, match="img.h5: radar: missing attribute 'prf'"):
        read_product(tmp_path / "img.h5")


def test_nan_in_data_is_refused(tmp_path):
    p = image_product()
    p.data[2, 3] = np.nan
    write_product(tmp_path / "nan.h5", p)
    with pytest.raises(InputError, match="nan.h5: dataset 'image' contains 1 NaN or Inf"):
        read_product(tmp_path / "nan.h5")


def test_missing_dataset_is_named(tmp_path):
    write_product(tmp_path / "x.h5", image_product())
    with h5py.File(tmp_path / "x.h5", "a") as f:
        del f["targets"]
    with pytest.raises(InputError, match="x.h5: missing dataset 'targets'"):
        read_product(tmp_path / "x.h5")


def test_write_behind_stores_every_block_in_order(tmp_path):
    p = image_product(n_az=40)
    out = tmp_path / "out.h5"
    with (
        ProductWriter(out, "image", p.dims, p.coords, p.radar, p.targets, attrs=p.attrs) as w,
        WriteBehind(w) as behind,
    ):
        for s in range(0, 40, 3):  # overlapping blocks: a later one must land after an earlier one
            behind.write((slice(s, s + 5), slice(None)), p.data[s : s + 5] + (s + 1))
    want = p.data.copy()
    for s in range(0, 40, 3):
        want[s : s + 5] = p.data[s : s + 5] + (s + 1)
    np.testing.assert_array_equal(read_product(out).data, want)


def test_write_behind_raises_the_writers_error_and_publishes_nothing(tmp_path):
    p = image_product()
    out = tmp_path / "out.h5"
    with (
        pytest.raises(ValueError),
        ProductWriter(out, "image", p.dims, p.coords, p.radar, p.targets, attrs=p.attrs) as w,
        WriteBehind(w) as behind,
    ):
        for _ in range(20):  # the failed write is reported by a later call or on leaving
            behind.write((slice(0, 2), slice(None)), "not an array")
    assert not out.exists() and list(tmp_path.iterdir()) == []


def test_write_behind_drops_queued_blocks_when_the_caller_fails(tmp_path):
    p = image_product()
    out = tmp_path / "out.h5"
    with (
        pytest.raises(RuntimeError, match="caller"),
        ProductWriter(out, "image", p.dims, p.coords, p.radar, p.targets, attrs=p.attrs) as w,
        WriteBehind(w) as behind,
    ):
        behind.write((slice(0, 2), slice(None)), p.data[:2])
        raise RuntimeError("caller")
    assert not out.exists() and list(tmp_path.iterdir()) == []


def test_a_stop_signal_never_cuts_the_write_behind_queue(tmp_path, monkeypatch):
    """A signal while the caller waits for a queue slot is acted on once the block is queued: raised inside
    Queue.put it can leave a stale waiter, and the writer thread then never sees the end marker (simulate hung
    2 times in 25 SIGINTs that way)."""
    import signal
    import threading

    from sarproc.product import run

    p = image_product(n_az=40)
    real_write = ProductWriter.write

    def slow_write(self, index, block):
        time.sleep(0.3)
        return real_write(self, index, block)

    monkeypatch.setattr(ProductWriter, "write", slow_write)
    previous = {s: signal.getsignal(s) for s in run.STOP_SIGNALS}
    run.begin()
    run.install_handlers()
    try:
        started = time.monotonic()
        with (
            pytest.raises(run.Interrupted),
            ProductWriter(tmp_path / "out.h5", "image", p.dims, p.coords, p.radar, p.targets, attrs=p.attrs) as w,
            WriteBehind(w) as behind,
        ):
            behind.write((slice(0, 2), slice(None)), p.data[:2])  # taken by the writer at once
            behind.write((slice(2, 4), slice(None)), p.data[2:4])  # fills the queue
            threading.Timer(0.1, os.kill, (os.getpid(), signal.SIGINT)).start()
            try:
                behind.write((slice(4, 6), slice(None)), p.data[4:6])  # waits for a slot; the signal lands here
            finally:
                raised = time.monotonic() - started
            pytest.fail("the signal was not acted on")
        waited = time.monotonic() - started
    finally:
        run.end()
        for s, h in previous.items():
            signal.signal(s, h)
    assert raised > 0.25, raised  # acted on once the writer freed the slot (0.3 s), not inside Queue.put
    assert waited < 5, waited  # and the writer thread was joined
    assert not behind._thread.is_alive()
    assert list(tmp_path.iterdir()) == []
