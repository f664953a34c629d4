"""`sarproc evaluate` end to end on small analytic image products written with sarproc.product.io."""

from __future__ import annotations

import dataclasses
import json
import shutil
import subprocess
import sys

import h5py
import numpy as np
import pytest
from click.testing import CliRunner

from sarproc.cli.main import cli
from sarproc.product.io import write_product
from sarproc.product.metadata import RadarMetadata
from sarproc.product.model import Product, make_targets
from sarproc.quality.metrics import TargetReport
from sarproc.quality.summary import tolerance_score

RES = (1.0, 0.8)  # theoretical IRW (azimuth, range), m
STEP = (0.6, 0.5)  # pixel spacing, m
TARGETS = {"A": (-15.3, -12.2), "B": (16.4, 14.15)}  # > 30 cells apart


def radar():
    return RadarMetadata(
        carrier_frequency=10e9,
        bandwidth=150e6,
        pulse_duration=2e-6,
        chirp_rate=7.5e13,
        range_sampling_rate=180e6,
        prf=500.0,
        velocity=150.0,
        altitude=0.0,
        squint=0.0,
        reference_range=10e3,
        scene_center=(0.0, 10e3, 0.0),
    )


def sinc_image(coords, res, truth, doppler):
    """Separable unweighted responses (band-limited, sampled directly) with a Doppler offset."""
    out = 0
    for t in truth:
        factors = [
            np.sinc(0.886 / r * (c - x0)) * np.exp(2j * np.pi * f * (c - x0))
            for c, r, x0, f in zip(coords, res, t, doppler)
        ]
        grid = factors[0]
        for f in factors[1:]:
            grid = np.multiply.outer(grid, f)
        out = out + grid
    return out.astype(np.complex64)


def make_image(path, *, irw=True, three_d=False, ghost_db=None, targets=TARGETS):
    names = list(targets)
    truth = [targets[n] for n in names]
    if three_d:
        dims, res, steps = ("elevation", "azimuth", "range"), (0.02,) + RES, (0.012,) + STEP
        truth = [(0.0011 * (i + 1),) + t for i, t in enumerate(truth)]
        shape = (48, 128, 128)
    else:
        dims, res, steps, shape = ("azimuth", "range"), RES, STEP, (128, 128)
    coords = {d: (np.arange(n) - n // 2) * s for d, n, s in zip(dims, shape, steps)}
    doppler = tuple(0.3 / s for s in steps)  # band centres 0.3 cycles/sample
    data = sinc_image([coords[d] for d in dims], res, truth, doppler)
    if ghost_db is not None:
        ghost = truth[0][:-2] + (-20.0, 20.0)  # outside both targets' +-20-cell boxes
        data = data + 10 ** (ghost_db / 20) * sinc_image([coords[d] for d in dims], res, [ghost], doppler)
    frame = [np.zeros(len(names))] * 3
    for i, d in enumerate(dims):
        frame[("azimuth", "range", "elevation").index(d)] = np.array([t[i] for t in truth])
    targets = make_targets(names, np.zeros((len(names), 3)), np.ones(len(names)), frame_coords=frame)
    attrs = {"frame": {"name": "ground"}}
    if irw:
        attrs["theoretical_irw"] = list(res)
    prod = Product(
        kind="image3d" if three_d else "image",
        data=data,
        dims=dims,
        coords=coords,
        radar=radar(),
        targets=targets,
        attrs=attrs,
    )
    write_product(path, prod)
    return path


@pytest.fixture(scope="module")
def image2d(tmp_path_factory):
    return make_image(tmp_path_factory.mktemp("img") / "image.h5")


def run(*args):
    return CliRunner().invoke(cli, ["evaluate", *map(str, args)])


def test_table_json_and_plots(image2d, tmp_path):
    report, plots = tmp_path / "report.json", tmp_path / "plots"
    res = run(image2d, "-o", report, "--plot", plots)
    assert res.exit_code == 0, res.output
    assert "| A | azimuth |" in res.output and "| B | range |" in res.output
    assert "False target:" in res.output
    doc = json.loads(report.read_text())
    assert doc["dims"] == ["azimuth", "range"] and doc["units"] == {"azimuth": "m", "range": "m"}
    for t in doc["targets"]:
        for m in t["axes"]:
            assert abs(m["irw_ratio"] - 1) < 0.005
            assert abs(m["pslr_db"] + 13.26) < 0.1
            assert abs(m["islr_db"] + 10.16) < 0.1
            assert abs(m["position_error_cells"]) < 0.02
    assert sorted(p.name for p in plots.iterdir()) == ["quicklook.png", "target_A.png", "target_B.png"]
    for p in plots.iterdir():
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # JSON output never replaces the input.
    res = run(image2d, "-o", image2d)
    assert res.exit_code == 2 and "input" in res.output


def test_json_gives_each_targets_tolerance_score(image2d, tmp_path):
    """The JSON report scores each target against the tolerances (summary.tolerance_score), so scripts and
    users read it from `sarproc evaluate -o` (scripts/accuracy_002.py's worst-target column)."""
    report = tmp_path / "report.json"
    assert run(image2d, "-o", report).exit_code == 0
    targets = json.loads(report.read_text())["targets"]
    for t in targets:
        assert t["tolerance_score"] == tolerance_score(TargetReport.from_dict(t))
        assert 0 < t["tolerance_score"] < 0.2  # ideal sinc responses: well within the tolerances


@pytest.mark.parametrize("three_d", [False, True], ids=["2d", "3d"])
def test_plots_text_inside_the_figure_and_apart(tmp_path, monkeypatch, three_d):
    """The figures are laid out with fixed margins (no constrained layout: it drew every text once more): every
    label, tick label and title lies inside its figure, and no two overlap (a colour bar's label and the next
    panel's axis label, tick labels of a narrowed axis)."""
    from matplotlib.text import Text

    from sarproc.quality import plotting

    drawn, write = [], plotting._write_png

    def recording(fig, path):
        write(fig, path)
        drawn.append(fig)

    monkeypatch.setattr(plotting, "_write_png", recording)
    img = make_image(tmp_path / "img.h5", three_d=three_d)
    res = run(img, "-o", tmp_path / "r.json", "--plot", tmp_path / "p")
    assert res.exit_code == 0, res.output
    assert len(drawn) == 3  # the quicklook and both targets (one figure drawn for each in turn)
    for fig in drawn:
        fig.canvas.draw()  # at the figure's own dpi, which its bbox uses (savefig drew at 110)
        renderer = fig.canvas.get_renderer()
        frame = fig.bbox.padded(1.0)
        texts = [t for t in fig.findobj(Text) if t.get_visible() and t.get_text().strip()]
        # tick labels of two different axes may meet at a corner (where the ticks are, not the layout)
        owner = {id(t): id(axis) for ax in fig.axes for axis in (ax.xaxis, ax.yaxis) for t in axis.get_ticklabels()}
        boxes = [(t.get_text(), owner.get(id(t)), t.get_window_extent(renderer)) for t in texts]
        assert len(boxes) > 10
        for text, _, box in boxes:
            assert frame.contains(box.x0, box.y0) and frame.contains(box.x1, box.y1), text
        for i, (a, axis_a, box_a) in enumerate(boxes):
            for b, axis_b, box_b in boxes[i + 1 :]:
                if axis_a is None or axis_b is None or axis_a == axis_b:
                    assert not box_a.overlaps(box_b), (a, b)


@pytest.mark.parametrize("three_d", [False, True], ids=["2d", "3d"])
def test_target_figures_drawn_in_turn_equal_whole_figures(tmp_path, three_d):
    """One TargetFigure draws every target of an image over one drawing of what they share (panels, ticks,
    labels, colour bars), with the panels' titles placed at their top instead of found at each draw: each PNG
    has the pixels of the whole figure drawn by savefig with matplotlib placing the titles, and those of a
    figure made for that target alone."""
    from PIL import Image

    from sarproc.product.io import read_product
    from sarproc.quality.metrics import evaluate_product
    from sarproc.quality.plotting import DPI, TargetFigure, plot_target

    product = read_product(make_image(tmp_path / "img.h5", three_d=three_d))
    report = evaluate_product(product)
    irw, units = product.attrs["theoretical_irw"], dict.fromkeys(product.dims, "m")
    figure = TargetFigure(product.data, product.dims, product.coords, irw, units)
    pictures = []
    for t in report.targets:
        turn = np.asarray(Image.open(figure.draw(tmp_path / f"{t.name}.png", t)))
        alone = plot_target(tmp_path / f"{t.name}_alone.png", product.data, product.dims, product.coords, irw, t, units)
        assert figure.fig is not None
        for ax in figure.axs:
            ax.set_title(ax.get_title(), fontsize=8)  # placed by matplotlib as it draws
        figure.fig.savefig(tmp_path / f"{t.name}_whole.png", dpi=DPI)
        assert np.array_equal(turn, np.asarray(Image.open(tmp_path / f"{t.name}_whole.png")))
        assert np.array_equal(turn, np.asarray(Image.open(alone)))
        pictures.append(turn)
    assert len(pictures) == 2 and not np.array_equal(*pictures)


def test_3d_image_with_config(tmp_path):
    img = make_image(tmp_path / "cube.h5", three_d=True)
    cfg = tmp_path / "cfg.yaml"
    cfg.write_text("evaluate:\n  upsample: 32\n  guard_cells: 15\n")
    report = tmp_path / "r.json"
    res = run(img, "--config", cfg, "-o", report, "--plot", tmp_path / "p")
    assert res.exit_code == 0, res.output
    doc = json.loads(report.read_text())
    assert doc["params"]["upsample"] == 32 and doc["params"]["guard_cells"] == 15
    for t in doc["targets"]:
        assert [m["axis"] for m in t["axes"]] == ["elevation", "azimuth", "range"]
        for m in t["axes"]:
            assert abs(m["irw_ratio"] - 1) < 0.005 and abs(m["position_error_cells"]) < 0.02
    assert "| A | elevation |" in res.output and " rad |" in res.output
    assert (tmp_path / "p" / "target_B.png").exists()
    bad = tmp_path / "bad.yaml"
    bad.write_text("evaluate:\n  upsample: 4\n")
    res = run(img, "--config", bad)
    assert res.exit_code == 2 and "evaluate.upsample" in res.output


EXPECT_OK = """\
irw_ratio_max: 1.05        # IRW / theory
pslr_db: [-13.76, -12.76]
islr_db: [-10.66, -9.66]
position_cells_max: 0.5
false_target_db_max: -30
axes: {range: {irw_ratio_max: 1.1}}
targets: {B: {pslr_db: [-20, -12]}}
"""


def test_targets_subset_keeps_the_others_as_neighbours(tmp_path):
    """--targets A on two targets 3-4 IRW apart (inside each other's ISLR windows): B is still fitted and
    subtracted from A's chip, so A's figures are those of the run over both (issue 21: B's side lobes left
    in A's window read its range ISLR 1.2 dB high on paper 004's cube)."""
    image = make_image(tmp_path / "close.h5", targets={"A": (-2.1, -1.6), "B": (1.9, 1.55)})
    reports = {}
    for label, extra in (("all", []), ("A", ["--targets", "A"])):
        res = run(image, "-o", tmp_path / f"{label}.json", *extra)
        assert res.exit_code == 0, res.output
        reports[label] = json.loads((tmp_path / f"{label}.json").read_text())
    both, alone = reports["all"]["targets"], reports["A"]["targets"]
    assert [t["name"] for t in both] == ["A", "B"] and [t["name"] for t in alone] == ["A"]
    assert alone[0]["neighbours_removed"] == ["B"]
    assert alone[0] == both[0]
    # and B's side lobes would be in A's windows without it: its ISLR rises
    res = run(image, "-o", tmp_path / "off.json", "--targets", "A", "--config", _no_neighbours(tmp_path))
    assert res.exit_code == 0, res.output
    off = json.loads((tmp_path / "off.json").read_text())["targets"][0]
    assert max(m["islr_db"] for m in off["axes"]) > max(m["islr_db"] for m in both[0]["axes"]) + 1.0


def _no_neighbours(tmp_path):
    path = tmp_path / "no_neighbours.yaml"
    path.write_text("evaluate: {remove_neighbours: false}\n")
    return path


def test_expect_pass_and_fail(image2d, tmp_path):
    ok = tmp_path / "ok.yaml"
    ok.write_text(EXPECT_OK)
    res = run(image2d, "--expect", ok)
    assert res.exit_code == 0, res.output
    assert "all checks passed" in res.output

    fail = tmp_path / "fail.yaml"
    fail.write_text("irw_ratio_max: 0.99\ntargets: {B: {axes: {range: {islr_db: [-9, -8]}}}}\n")
    report = tmp_path / "r.json"
    res = run(image2d, "--expect", fail, "-o", report)
    assert res.exit_code == 1, res.output
    fails = [ln for ln in res.output.splitlines() if ln.startswith("FAIL")]
    assert len(fails) == 5  # 4 IRW checks + B's range ISLR
    assert any("target B axis range: islr_db" in ln and "in [-9, -8]" in ln for ln in fails)
    assert any("target A axis azimuth: irw_ratio" in ln and "<= 0.99" in ln for ln in fails)
    doc = json.loads(report.read_text())
    assert doc["expect"]["passed"] is False and len(doc["expect"]["failures"]) == 5


def test_false_target_gate(tmp_path):
    img = make_image(tmp_path / "ghost.h5", ghost_db=-24.0)
    exp = tmp_path / "e.yaml"
    exp.write_text("false_target_db_max: -30\n")
    res = run(img, "--expect", exp)
    assert res.exit_code == 1
    line = next(ln for ln in res.output.splitlines() if ln.startswith("FAIL false target"))
    level = float(line.split("=")[1].split(",")[0])
    assert level == pytest.approx(-24.0, abs=0.1)


def test_false_target_list_in_table_and_json(tmp_path):
    """The list of false targets over the residual's floor reaches the JSON and the printed report."""
    img, report = make_image(tmp_path / "ghost.h5", ghost_db=-30.0), tmp_path / "report.json"
    res = run(img, "-o", report)
    assert res.exit_code == 0, res.output
    doc = json.loads(report.read_text())
    (first,) = doc["false_targets"]["entries"]
    assert [first[k] for k in ("level_db", "position")] == [doc["false_target"][k] for k in ("level_db", "position")]
    ghost = (-20.0, 20.0)  # make_image's
    assert first["level_db"] == pytest.approx(-30.0, abs=0.5)
    assert first["position"]["azimuth"] == pytest.approx(ghost[0], abs=RES[0])
    assert first["position"]["range"] == pytest.approx(ghost[1], abs=RES[1])
    cells = {n: np.hypot(*(np.subtract(ghost, t) / RES)) for n, t in TARGETS.items()}
    assert first["nearest_target"] == min(cells, key=cells.__getitem__) == "B"
    assert first["nearest_cells"] == pytest.approx(cells["B"], abs=1.0)
    assert "False targets on the residual over its floor + 1 dB" in res.output
    assert f"| 1 | {first['level_db']:.2f} | azimuth = " in res.output


@pytest.mark.parametrize(
    "content, match",
    [
        ("pslr: [-14, -13]\n", "unknown key(s) 'pslr'"),
        ("targets: {Z: {pslr_db: [-14, -13]}}\n", "targets.Z: the image has no target 'Z'"),
        ("axes: {range: {irw_ratio_max: 3 m}}\n", "axes.range.irw_ratio_max"),
        ("pslr_db: [-12, -14]\n", "lo <= hi"),
    ],
)
def test_bad_expect_file(image2d, tmp_path, content, match):
    exp = tmp_path / "e.yaml"
    exp.write_text(content)
    res = run(image2d, "--expect", exp)
    assert res.exit_code == 2
    assert str(exp) in res.output and match in res.output


def test_bad_inputs_exit_2(tmp_path, image2d):
    res = run(tmp_path / "missing.h5")
    assert res.exit_code == 2 and "missing.h5: file not found" in res.output

    no_irw = make_image(tmp_path / "no_irw.h5", irw=False)
    res = run(no_irw)
    assert res.exit_code == 2 and "no_irw.h5" in res.output and "theoretical_irw" in res.output

    raw = tmp_path / "raw.h5"
    coords = {"azimuth_time": np.arange(8) * 1e-3, "range_time": np.arange(16) * 1e-8}
    write_product(
        raw,
        Product(
            kind="raw",
            data=np.zeros((8, 16), np.complex64),
            dims=("azimuth_time", "range_time"),
            coords=coords,
            radar=radar(),
            targets=make_targets(["A"], [[0, 1e4, 0]], [1.0]),
        ),
    )
    res = run(raw)
    assert res.exit_code == 2 and "raw.h5" in res.output and "'raw'" in res.output

    nan = tmp_path / "nan.h5"
    shutil.copy(image2d, nan)
    with h5py.File(nan, "r+") as f:
        f["image"][3, 3] = np.nan
    res = run(nan)
    assert res.exit_code == 2 and "NaN" in res.output

    outside = tmp_path / "outside.h5"
    make_image(outside)
    with h5py.File(outside, "r+") as f:
        t = f["targets"][()]
        t["range"][0] = 1e4
        f["targets"][...] = t
    res = run(outside)
    assert res.exit_code == 2 and "outside.h5" in res.output and "target 'A'" in res.output


def test_subprocess_and_help(image2d):
    res = subprocess.run(
        [sys.executable, "-m", "sarproc", "evaluate", str(image2d)], capture_output=True, text=True, timeout=120
    )
    assert res.returncode == 0, res.stderr
    assert res.stdout.startswith("| target | axis |")
    assert CliRunner().invoke(cli, ["evaluate", "--help"]).exit_code == 0


def test_ghost_test_finds_the_injected_ghost_at_its_level(tmp_path):
    """`sarproc ghost-test`: G's response (ghosted - clean) injected into the clean image is the residual
    false target at the injected level and place (scripts/residual_ghosts.py's table)."""
    clean = make_image(tmp_path / "clean.h5")
    ghosted = make_image(tmp_path / "ghosted.h5", ghost_db=0.0)  # G of amplitude 1 at make_image's (-20, 20)
    report = tmp_path / "ghost.json"
    res = CliRunner().invoke(cli, ["ghost-test", str(clean), str(ghosted), "--levels", "-30,-35", "-o", str(report)])
    assert res.exit_code == 0, res.output
    doc = json.loads(report.read_text())
    assert doc["ghost_position"]["azimuth"] == pytest.approx(-20.0, abs=STEP[0])
    assert doc["ghost_position"]["range"] == pytest.approx(20.0, abs=STEP[1])
    assert [r["injected_db"] for r in doc["rows"]] == [-30.0, -35.0]
    for r in doc["rows"]:
        assert r["error_db"] == pytest.approx(r["found_db"] - r["injected_db"])
        assert abs(r["error_db"]) < 0.2
        assert all(abs(e) < 0.5 for e in r["error_cells"].values())
        assert r["found_position"]["azimuth"] == pytest.approx(-20.0, abs=0.1)
    assert doc["floor_db"] < -60 and doc["rows"][0]["floor_db"] < -60
    assert "| -30.0 | " in res.output and "residual floor" in res.output
    cube = make_image(tmp_path / "cube.h5", three_d=True)  # not one grid (nor a 2D image): refused
    res = CliRunner().invoke(cli, ["ghost-test", str(clean), str(cube)])
    assert res.exit_code == 2, res.output


def test_ghost_test_writes_strict_json_without_nan(tmp_path, monkeypatch):
    """`sarproc ghost-test -o`: figures that are not finite (an unmeasured -inf floor, a NaN level) are written as
    null, as evaluate's report (json.dumps allow_nan=False): the file parses as strict JSON and the table still
    prints them."""
    import sarproc.quality.ghost_test as gt

    nan, inf = float("nan"), float("inf")
    row = gt.GhostRow(-30.0, nan, {"azimuth": -20.0, "range": 20.0}, {"azimuth": 0.1, "range": inf}, -31.0, -inf)
    fake = gt.GhostTest(("azimuth", "range"), {"azimuth": -20.0, "range": 20.0}, 1.0, 2.0, -inf, nan, -70.0, (row,))
    monkeypatch.setattr(gt, "injected_ghosts", lambda *a, **k: fake)
    clean = make_image(tmp_path / "clean.h5")
    report = tmp_path / "ghost.json"
    res = CliRunner().invoke(cli, ["ghost-test", str(clean), str(clean), "-o", str(report)])
    assert res.exit_code == 0, res.output

    def refuse(name):
        raise ValueError(f"non-standard JSON constant {name}")

    doc = json.loads(report.read_text(), parse_constant=refuse)
    assert doc["floor_db"] is None and doc["false_target_db"] is None and doc["guard_db"] == -70.0
    r = doc["rows"][0]
    assert r["found_db"] is None and r["error_db"] is None and r["floor_db"] is None
    assert r["error_cells"] == {"azimuth": 0.1, "range": None} and r["guard_db"] == -31.0
    assert "| -30.0 | nan |" in res.output  # the printed table keeps the figures as they are


def test_image_without_truth_gets_the_truth_free_measures(tmp_path):
    """An image with an empty targets table (real data): evaluate reports its entropy and brightest points, and
    against --reference the NCC and each point's offset (scripts/reproduce_gotcha.py's table)."""
    from sarproc.product.io import read_product
    from sarproc.quality.image_measures import entropy, magnitude_ncc

    img = read_product(make_image(tmp_path / "truth.h5"))
    img.targets = make_targets([], np.zeros((0, 3)), np.ones(0), frame_coords=[np.zeros(0)] * 3)
    path, ref_path, report = tmp_path / "notruth.h5", tmp_path / "ref.h5", tmp_path / "m.json"
    write_product(path, img)
    ref = dataclasses.replace(img, data=np.roll(img.data, 1, axis=0))  # one row later
    write_product(ref_path, ref)
    res = run(path, "--reference", ref_path, "--points", "2", "-o", report)
    assert res.exit_code == 0, res.output
    doc = json.loads(report.read_text())
    assert doc["entropy"] == entropy(np.abs(img.data)) and doc["reference_entropy"] == entropy(np.abs(ref.data))
    assert doc["ncc"] == magnitude_ncc(np.abs(img.data), np.abs(ref.data)) and doc["same_grid"] is True
    assert doc["spacing"] == {"azimuth": pytest.approx(STEP[0]), "range": pytest.approx(STEP[1])}
    truth = sorted((TARGETS[n][0] / STEP[0] + 64, TARGETS[n][1] / STEP[1] + 64) for n in TARGETS)
    found = sorted(tuple(p["peak"]) for p in doc["points"])
    assert len(found) == 2 and np.allclose(found, truth, atol=0.25)
    for p in doc["points"]:
        assert p["offset"] == pytest.approx([-1.0, 0.0], abs=1e-9)
        assert p["level_db"] <= 0
    assert "No truth: 128 x 128 pixels" in res.output and "NCC of the magnitudes" in res.output
    res = run(path)
    assert res.exit_code == 0 and "offset (px)" not in res.output and 2 <= res.output.count("\n| (") <= 10
    assert "|---|---:|---:|\n" in res.output  # one alignment cell per column
    dry = run(path, "--dry-run", "-o", tmp_path / "dry.json")
    assert dry.exit_code == 0 and "nothing computed" in dry.output and not (tmp_path / "dry.json").exists()
    assert run(path, "--expect", tmp_path / "x.yaml").exit_code == 2
    assert run(make_image(tmp_path / "t.h5"), "--reference", ref_path).exit_code == 2


def test_targets_outside_a_cropped_image_are_all_named_with_the_subset_that_works(tmp_path):
    """Session 41 new-user trial: an image backprojected on a grid around some targets only. evaluate refused
    it naming the first target outside; it now names every one, the extent, and the --targets that measures
    the targets the image holds (exit 2, no report)."""
    far = {**TARGETS, "FAR1": (200.0, 0.0), "FAR2": (0.0, -300.0)}
    path = make_image(tmp_path / "cropped.h5", targets=far)
    result = run(path, "-o", tmp_path / "r.json")
    assert result.exit_code == 2, result.output
    assert "cropped.h5: 2 of 4 targets 'FAR1' (azimuth = 200, range = 0), 'FAR2' (azimuth = 0, range = -300) lie " in (
        result.output
    )
    assert "outside the image extent (azimuth [-38.4, 37.8], range [-32, 31.5]); " in result.output
    assert result.output.rstrip().endswith("measure those it holds alone with --targets A,B")
    assert not (tmp_path / "r.json").exists()
    assert run(path, "-o", tmp_path / "r.json", "--targets", "A,B").exit_code == 0
