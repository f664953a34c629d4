"""Independent tasks on Dask: the mapper keeps input order; simulate's blocks on workers give the same product."""

from __future__ import annotations

import numpy as np
import pytest
import yaml

distributed = pytest.importorskip("dask.distributed", reason="Dask tasks need sarproc[distributed]")

from sarproc.cli.dask_map import dask_mapper  # noqa: E402


@pytest.fixture(scope="module")
def cluster():
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False, dashboard_address=":0") as c:
        yield c


def _slow_square(x):
    import time

    time.sleep(0.01 * (x % 3))  # later tasks finish first
    return x * x


def test_mapper_yields_in_input_order_with_a_bounded_window(cluster):
    with distributed.Client(cluster) as client:
        mapper = dask_mapper(client, "sq", window=3)
        assert list(mapper(_slow_square, iter(range(20)))) == [x * x for x in range(20)]
        assert list(mapper(_slow_square, [])) == []


def test_simulate_blocks_on_workers_write_the_serial_product(cluster, tmp_path, scene_mapping):
    from click.testing import CliRunner

    from sarproc.cli.main import cli
    from sarproc.product.io import read_product

    # several pulse blocks, and noise drawn from the seeded generator in block order
    scene = scene_mapping(
        acquisition={"mode": "spotlight", "aperture_time": "2 s"},
        simulation={"block_pulses": 64, "seed": 3},
        effects={"noise": {"snr": "10 dB"}},
    )
    (tmp_path / "scene.yaml").write_text(yaml.safe_dump(scene))
    run = CliRunner().invoke
    res = run(cli, ["simulate", str(tmp_path / "scene.yaml"), "-o", str(tmp_path / "serial.h5")])
    assert res.exit_code == 0, res.output
    res = run(
        cli,
        [
            "simulate",
            str(tmp_path / "scene.yaml"),
            "-o",
            str(tmp_path / "dask.h5"),
            "--scheduler",
            cluster.scheduler_address,
        ],
    )
    assert res.exit_code == 0, res.output
    a, b = read_product(tmp_path / "serial.h5"), read_product(tmp_path / "dask.h5")
    assert a.data.shape[0] == 800 and np.array_equal(a.data, b.data)


def test_pfa2_subimages_on_workers_give_the_serial_mosaic(cluster, tmp_path, scene_mapping):
    from click.testing import CliRunner

    from sarproc.cli.main import cli
    from sarproc.product.io import read_product

    grid = {"azimuth_count": 3, "range_count": 3, "azimuth_spacing": "30 m", "range_spacing": "30 m", "prefix": "T"}
    scene = scene_mapping(
        platform={"velocity": "100 m/s", "altitude": "500 m"},
        geometry={"squint": "20 deg"},
        targets={"frame": "ground_los", "origin": "scene_center", "grid": grid, "points": []},
        pfa2={"method": "two_step", "subimage_size": "60 m"},
    )
    (tmp_path / "scene.yaml").write_text(yaml.safe_dump(scene))
    run = CliRunner().invoke
    assert run(cli, ["simulate", str(tmp_path / "scene.yaml"), "-o", str(tmp_path / "raw.h5")]).exit_code == 0
    common = [str(tmp_path / "raw.h5"), "--config", str(tmp_path / "scene.yaml")]
    res = run(cli, ["pfa2", *common, "-o", str(tmp_path / "serial.h5")])
    assert res.exit_code == 0 and "6 sub-images" in res.output, res.output
    res = run(cli, ["pfa2", *common, "-o", str(tmp_path / "dask.h5"), "--scheduler", cluster.scheduler_address])
    assert res.exit_code == 0, res.output
    a, b = read_product(tmp_path / "serial.h5").data, read_product(tmp_path / "dask.h5").data
    assert 20 * np.log10(float(np.abs(a - b).max() / np.abs(a).max()) + 1e-300) < -100  # (in fact bit-identical)


def test_backproject_blocks_on_workers_write_the_local_image(cluster, tmp_path, scene_mapping):
    from click.testing import CliRunner

    from sarproc.cli.main import cli
    from sarproc.product.io import read_product

    scene = scene_mapping(backproject={"block_pixels": 2000})  # several blocks of whole rows
    (tmp_path / "scene.yaml").write_text(yaml.safe_dump(scene))
    run = CliRunner().invoke
    assert run(cli, ["simulate", str(tmp_path / "scene.yaml"), "-o", str(tmp_path / "raw.h5")]).exit_code == 0
    common = [str(tmp_path / "raw.h5"), "--config", str(tmp_path / "scene.yaml")]
    res = run(cli, ["backproject", *common, "-o", str(tmp_path / "local.h5")])
    assert res.exit_code == 0 and " blocks " in res.output, res.output
    res = run(cli, ["backproject", *common, "-o", str(tmp_path / "dask.h5"), "--scheduler", cluster.scheduler_address])
    assert res.exit_code == 0, res.output
    a, b = read_product(tmp_path / "local.h5"), read_product(tmp_path / "dask.h5")
    assert a.data.shape[0] > 1 and np.array_equal(a.data, b.data)
    assert np.array_equal(a.targets, b.targets) and a.attrs.keys() == b.attrs.keys()
    assert np.array_equal(a.attrs["theoretical_irw"], b.attrs["theoretical_irw"])
