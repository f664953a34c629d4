"""The sweeps behind `make accuracy-*` and `make reproduce-003` hold the settings their tables are read with.

The sweep YAMLs are the one source of the settings: the scripts that tabulate a sweep read its tasks, so
these tests check what each table needs of its sweep (same settings on every scene, the scripts' frame and
targets, sub-image sizes and channel spacings derived exactly from the scene).
"""

from __future__ import annotations

from pathlib import Path

import pytest

from sarproc.cli.sweep_tasks import plan_sweep
from sarproc.product.units import parse_quantity

ROOT = Path(__file__).resolve().parents[2]


def _settings_by_scene(plan) -> dict:
    out: dict = {}
    for t in plan.tasks:
        out.setdefault(t.scene, []).append(repr(sorted(t.setting.items())))
    return out


def test_backprojection_sweep_has_the_same_settings_on_both_scenes_with_the_finest():
    plan = plan_sweep(ROOT / "configs" / "sweeps" / "backprojection.yaml")
    by_scene = _settings_by_scene(plan)
    assert sorted(by_scene) == ["squint30", "stripmap"]  # accuracy_backprojection.py's SCENES
    assert sorted(by_scene["stripmap"]) == sorted(by_scene["squint30"])
    assert len(set(by_scene["stripmap"])) == len(by_scene["stripmap"]) == 22
    finest = {"backproject.engine": "reference", "backproject.upsample": 32, "backproject.interpolation": "linear"}
    assert all(sum(t.setting == finest for t in plan.tasks if t.scene == s) == 1 for s in by_scene)
    # ffbp's settings beside the exact image they are measured against (accuracy_backprojection.py's EXACT)
    exact = {"backproject.engine": "compiled", "backproject.upsample": 8, "backproject.interpolation": "linear"}
    assert all(sum(t.setting == exact for t in plan.tasks if t.scene == s) == 1 for s in by_scene)
    ffbp = [t.setting for t in plan.tasks if t.scene == "stripmap" and t.setting["backproject.engine"] == "ffbp"]
    assert len(ffbp) == 4 and all(f["backproject.upsample"] == 8 for f in ffbp)


def test_000_sweep_measures_in_the_lrwc_frame_with_the_same_settings_on_both_scenes():
    plan = plan_sweep(ROOT / "configs" / "sweeps" / "accuracy_000.yaml")
    assert all(t.config["fine_focus"]["output_frame"] == "lrwc" for t in plan.tasks)  # separable responses
    by_scene = _settings_by_scene(plan)
    assert sorted(by_scene) == ["airborne_small", "exp2_small"]
    assert sorted(by_scene["exp2_small"]) == sorted(by_scene["airborne_small"])
    assert len(set(by_scene["exp2_small"])) == len(by_scene["exp2_small"]) == 16


def test_002_sweep_subimage_sizes_are_fractions_of_the_scenes_valid_radius():
    from sarproc.focus.pfa.chain import Pfa2Params, pfa2
    from sarproc.product.config import build, load_yaml
    from sarproc.simulation.scene import scene_from_mapping
    from sarproc.simulation.simulate import simulate

    plan = plan_sweep(ROOT / "configs" / "sweeps" / "accuracy_002.yaml")
    mapping = load_yaml(ROOT / "configs" / "nie2016_small.yaml")
    image = pfa2(
        simulate(scene_from_mapping(mapping, "nie2016_small.yaml")),
        build(Pfa2Params, mapping.get("pfa2"), "nie2016_small.yaml", "pfa2"),
    )
    radius = image.attrs["valid_radius_eq7"]
    sizes = sorted(
        parse_quantity(t.setting["pfa2.subimage_size"], "length") / radius
        for t in plan.tasks
        if "pfa2.subimage_size" in t.setting
    )
    assert sizes == pytest.approx([0.5, 1.5], rel=1e-12)  # full precision: accuracy_002.py labels them so
    settings = [repr(sorted(t.setting.items())) for t in plan.tasks]
    assert len(set(settings)) == len(settings) == 12
    assert sum(t.setting == {"pfa2.method": "plain"} for t in plan.tasks) == 1


def _array3d(config):
    from sarproc.focus.array3d.linear_array import Array3DParams
    from sarproc.product.config import as_dict, build

    return repr(sorted(as_dict(build(Array3DParams, config.get("array3d") or {})).items()))


def test_004_sweeps_have_the_same_settings_on_the_scene_and_each_isolated_target():
    from sarproc.product.config import load_yaml

    paper = load_yaml(ROOT / "configs" / "du2010.yaml")
    paper.pop("array3d")
    plan = plan_sweep(ROOT / "configs" / "sweeps" / "accuracy_004.yaml")
    points = paper["targets"]["points"]
    scenes = {"du2010": points, **{f"target{p['name']}": [p] for p in points}}  # accuracy_004.py's singles
    assert sorted({t.scene for t in plan.tasks}) == sorted(scenes)
    want = sorted(_array3d(t.config) for t in plan.tasks if t.scene == "du2010")
    assert len(set(want)) == len(want) == 19  # distinct once resolved: accuracy_004.py matches tasks by them
    for scene, pts in scenes.items():
        tasks = [t for t in plan.tasks if t.scene == scene]
        assert sorted(_array3d(t.config) for t in tasks) == want
        for t in tasks:
            assert t.config["targets"]["points"] == pts
            assert {k: v for k, v in t.config.items() if k not in ("targets", "array3d")} == {
                k: v for k, v in paper.items() if k != "targets"
            }
    wide = plan_sweep(ROOT / "configs" / "sweeps" / "accuracy_004_wide.yaml")
    scene = load_yaml(ROOT / "configs" / "du2010_wide_swath.yaml")
    assert "array3d" not in scene  # accuracy_004.py's reference cube there starts from array3d's defaults
    assert all({k: v for k, v in t.config.items() if k != "array3d"} == scene for t in wide.tasks)
    assert len({_array3d(t.config) for t in wide.tasks}) == len(wide.tasks) == 7


def test_004_reference_sweep_has_one_float64_cube_per_scene_and_elevation_grid():
    """configs/sweeps/accuracy_004_reference.yaml: for every paper-scene and wide-swath task, exactly one
    reference task simulating the same scene with the same elevation padding (accuracy_004.py's match), at
    float64 with a 32-tap sinc and otherwise the scene's array3d section."""
    from sarproc.focus.array3d.linear_array import Array3DParams
    from sarproc.product.config import as_dict, build, load_yaml

    REFERENCE = {"precision": "float64", "rcmc_kernel": "sinc", "rcmc_kernel_length": 32}
    bases = {"du2010": load_yaml(ROOT / "configs" / "du2010.yaml")["array3d"], "wide": {}}

    def scene(config):
        return {k: v for k, v in config.items() if k != "array3d"}

    refs = plan_sweep(ROOT / "configs" / "sweeps" / "accuracy_004_reference.yaml")
    assert not refs.tasks[0].evaluate
    ref_params = [build(Array3DParams, t.config.get("array3d") or {}) for t in refs.tasks]
    paper = plan_sweep(ROOT / "configs" / "sweeps" / "accuracy_004.yaml")
    wide = plan_sweep(ROOT / "configs" / "sweeps" / "accuracy_004_wide.yaml")
    used = set()
    for task in [t for t in paper.tasks if t.scene == "du2010"] + list(wide.tasks):
        pad = build(Array3DParams, task.config.get("array3d") or {}).elevation_zero_padding
        found = [
            i
            for i, (ref, p) in enumerate(zip(refs.tasks, ref_params))
            if scene(ref.config) == scene(task.config) and p.elevation_zero_padding == pad
        ]
        assert len(found) == 1, (task.task_id, found)
        used.add(found[0])
        # the scene file's array3d section with only the precision, the kernel and the padding set
        want = {**bases[task.scene], **REFERENCE, "elevation_zero_padding": pad}
        assert as_dict(ref_params[found[0]]) == as_dict(build(Array3DParams, want))
    assert used == set(range(len(refs.tasks)))  # no reference cube that no table row reads


def test_003_sweep_searches_on_three_channels_and_spaces_channels_uniformly():
    from sarproc.focus.multichannel.reconstruct import ReconstructParams
    from sarproc.product.config import build
    from sarproc.simulation.scene import scene_from_mapping

    plan = plan_sweep(ROOT / "configs" / "sweeps" / "accuracy_003.yaml")
    channels = set()
    for t in plan.tasks:
        assert not t.evaluate and t.focus == ("reconstruct",)
        assert [p["name"] for p in t.config["targets"]["points"]] == ["T"]  # the one moving target
        assert parse_quantity(t.config["targets"]["points"][0]["velocity"][1], "velocity") == 10.0
        ch = t.config["effects"]["azimuth_channels"]
        n, d = ch["n_receivers"], parse_quantity(ch["spacing"], "length")
        if any(k.startswith("reconstruct.") for k in t.setting):  # a search row: on N = 3, d = 2 m
            p = build(ReconstructParams, t.config["reconstruct"])
            assert (n, d) == (3, 2.0) and p.coarse_step == max(p.velocity_step, 2.0)
        else:  # a channel row: uniform phase centres at this PRF, d = 2 v / (N PRF)
            radar = scene_from_mapping(dict(t.config)).radar
            assert d == pytest.approx(2 * radar.velocity / (n * radar.prf), rel=1e-12)
            channels.add(n)
    assert channels == {3, 4, 5}  # accuracy_003.py's interpolation rows use the N = 3 task


def test_003_images_sweep_images_every_timed_case_and_the_interpolation_knobs_on_three_channels():
    """configs/sweeps/accuracy_003_images.yaml reconstructs as accuracy_003.yaml's tasks do (one strip each, an
    image each channel row) and as its N = 3 task with backprojection knobs alone (an image and a strip each),
    ``-image`` with the scene's backprojection and guard, ``-strip`` on +-1.5 ghost spacings with the target's
    own +-0.45 spacing left out, in cells of the strip's theoretical azimuth IRW (of the reconstructed product)."""
    from sarproc.focus.backprojection import BackprojectParams, plan_backprojection
    from sarproc.focus.multichannel.channels import ghost_spacing
    from sarproc.focus.multichannel.reconstruct import ReconstructParams, reconstruct
    from sarproc.product.config import build, load_yaml
    from sarproc.quality.metrics import EvaluateParams
    from sarproc.simulation.scene import scene_from_mapping
    from sarproc.simulation.simulate import simulate

    sweeps = ROOT / "configs" / "sweeps"
    timed, plan = plan_sweep(sweeps / "accuracy_003.yaml"), plan_sweep(sweeps / "accuracy_003_images.yaml")
    scene = load_yaml(ROOT / "configs" / "xu_scene.yaml")
    assert all(t.focus == ("reconstruct", "backproject") and t.evaluate for t in plan.tasks)
    knobs = ("interpolation", "upsample")

    def stem(config):
        return {k: v for k, v in config.items() if k not in ("backproject", "evaluate")}

    def bp_knobs(config):
        return {k: v for k, v in config["backproject"].items() if k in knobs}

    n3 = next(t.config for t in timed.tasks if t.setting.get("effects.azimuth_channels.n_receivers") == 3)
    shots: dict = {}  # (what it reconstructs, its backprojection knobs) -> the scene names
    for t in plan.tasks:
        assert t.scene.rsplit("-", 1)[1] in ("image", "strip")
        shots.setdefault((repr(stem(t.config)), repr(bp_knobs(t.config))), []).append(t.scene.rsplit("-", 1)[1])
        if bp_knobs(t.config):
            assert stem(t.config) == stem(n3), t.scene
    for t in timed.tasks:
        channel_row = not any(k.startswith("reconstruct.") for k in t.setting)
        assert sorted(shots.pop((repr(stem(t.config)), "{}"))) == (["image", "strip"] if channel_row else ["strip"])
    assert all(sorted(v) == ["image", "strip"] for v in shots.values())  # the interpolation rows
    interpolation = [bp_knobs(t.config) for t in plan.tasks if bp_knobs(t.config) and t.scene.endswith("-image")]
    assert len(shots) == len(interpolation) and sorted((k["interpolation"], k["upsample"]) for k in interpolation) == (
        sorted([("nearest", 8), ("linear", 2), ("linear", 4), ("linear", 8), ("linear", 16)])
    )
    spacing = ghost_spacing(scene_from_mapping(dict(scene)).radar)
    raws: dict = {}
    for t in plan.tasks:
        bp = build(BackprojectParams, t.config["backproject"])
        guard = build(EvaluateParams, t.config.get("evaluate") or {}).guard_cells
        if t.scene.endswith("-image"):
            assert t.config["backproject"] == {**scene["backproject"], **bp_knobs(t.config)}
            assert guard == 60
            continue
        assert bp.frame == "squint_lrwc" and bp.range_extent == 30.0 and bp.oversample == 1.2
        assert bp.azimuth_extent == pytest.approx(3 * spacing, rel=1e-12)
        # the guard from the reconstructed product's strip theory, once per channel count
        n = t.config["effects"]["azimuth_channels"]["n_receivers"]
        if n not in raws:
            raw = simulate(scene_from_mapping(stem(dict(t.config))))
            rec = reconstruct(raw, build(ReconstructParams, t.config["reconstruct"]))
            assert ghost_spacing(rec.radar, raw.radar.prf) == spacing
            raws[n] = plan_backprojection(rec, bp).attrs["theoretical_irw"][0]
        assert guard == pytest.approx(0.45 * spacing / raws[n], rel=1e-12), t.scene
    assert sorted(raws) == [3, 4, 5]


def test_reproduce_003_sweeps_and_strip_config_hold_the_reproductions_geometry():
    """make reproduce-003's strips span +-1.5 ghost spacings PRF v / K_a of their own scene (a PRF changed in a
    scene without its strip would silently measure other ghosts), and every given-velocity scene reconstructs
    with the velocity of its target."""

    from sarproc.focus.backprojection import BackprojectParams
    from sarproc.focus.multichannel.channels import ghost_spacing
    from sarproc.focus.multichannel.reconstruct import ReconstructParams
    from sarproc.product.config import build, load_yaml
    from sarproc.simulation.scene import scene_from_mapping

    def spacing(config):
        return ghost_spacing(scene_from_mapping(dict(config)).radar)

    strips = 0
    names = ("reproduce_003_cases", "reproduce_003_given", "reproduce_003_speeds", "hard_cases_003")
    for name in names:
        for t in plan_sweep(ROOT / "configs" / "sweeps" / f"{name}.yaml").tasks:
            bp = build(BackprojectParams, t.config.get("backproject") or {})
            if bp.frame == "squint_lrwc":
                strips += 1
                assert bp.azimuth_extent == pytest.approx(3 * spacing(t.config), abs=0.05), t.task_id
                assert bp.range_extent == 30.0 and bp.oversample == 1.2
            if t.scene[0] in "ge" and name == "reproduce_003_given":
                rec = build(ReconstructParams, t.config["reconstruct"])
                v_r = parse_quantity(t.config["targets"]["points"][0]["velocity"][1], "velocity")
                assert rec.radial_velocity == pytest.approx(v_r + (float(t.scene[1:]) if t.scene[0] == "e" else 0))
    assert strips == 6 + 16 + 18 + 11
    strip = load_yaml(ROOT / "configs" / "xu_strip.yaml")
    scene = load_yaml(ROOT / "configs" / "xu_scene.yaml")
    assert build(BackprojectParams, strip["backproject"]).azimuth_extent == pytest.approx(3 * spacing(scene), abs=0.05)


def test_motion_002_sweeps_focus_the_same_raw_products_over_the_issues_ranges():
    """Issue 22: pfa2 and backprojection of the same simulated scenes; motion from 0.1 to 5 m, 0.3 to 5 s, 1 m/s."""
    pfa = plan_sweep(ROOT / "configs" / "sweeps" / "motion_002.yaml")
    bp = plan_sweep(ROOT / "configs" / "sweeps" / "motion_002_bp.yaml")
    assert {s.key for s in pfa.sims} == {s.key for s in bp.sims} and len(pfa.sims) == 15
    assert {t.scene: t.sim_key for t in pfa.tasks} == {t.scene: t.sim_key for t in bp.tasks}
    assert len(pfa.tasks) == 3 * len(bp.tasks) and all(t.focus == ("backproject",) for t in bp.tasks)
    motions = [s.config.get("effects", {}).get("platform_motion", {}) for s in pfa.sims]

    def values(key, unit):
        return [parse_quantity(m[key], unit) for m in motions if key in m]

    amplitudes = values("cross_track_amplitude", "length") + values("vertical_amplitude", "length")
    periods = values("cross_track_period", "time") + values("vertical_period", "time")
    assert min(amplitudes) == pytest.approx(0.1) and max(amplitudes) == pytest.approx(5)
    assert min(periods) == pytest.approx(0.3) and max(periods) == pytest.approx(5)
    assert max(values("along_track_velocity_error", "velocity")) == pytest.approx(1)
    # the eq. (7) case is the sub-image size of the straight scene's default (accuracy_002.yaml's radius)
    sizes = {t.setting.get("pfa2.subimage_size") for t in pfa.tasks} - {None}
    assert sizes == {"97.72952064134462 m"}


def test_004_hard_cases_reduce_the_paper_scene_and_put_the_grating_target_half_a_degree_past_the_lobe():
    """configs/sweeps/hard_cases_004.yaml: the paper scene with 8 receivers, 65 pulses and array3d's defaults
    (no array3d knob set), one target each; the grating case's target sits at asin(lambda / d + sin 0.5 deg),
    measured at its fold (0.5 deg); refusals are rows (the 1-receiver case's result)."""
    import math

    from sarproc.product.config import load_yaml

    paper = load_yaml(ROOT / "configs" / "du2010.yaml")
    path = ROOT / "configs" / "sweeps" / "hard_cases_004.yaml"
    plan = plan_sweep(path)
    assert load_yaml(path)["refusals"] is True
    tasks = {t.scene: t for t in plan.tasks}
    assert set(tasks) == {"nadir", "one_receiver", "two_receivers", "grating", "azimuth_edge", "sector_edge"}
    receivers = {"one_receiver": 1, "two_receivers": 2}
    for scene, t in tasks.items():
        assert t.config["array3d"] == {} and t.config["acquisition"]["n_pulses"] == 65
        array = t.config["effects"]["cross_track_array"]
        assert array["n_receivers"] == receivers.get(scene, 8)
        assert parse_quantity(array["spacing"], "length") == parse_quantity(
            paper["effects"]["cross_track_array"]["spacing"], "length"
        )
        assert [p["name"] for p in t.config["targets"]["points"]] == ["A"]
        assert t.config.get("evaluate", {}).get("fold_elevation", False) is (scene == "grating")
    grating = tasks["grating"].config
    lam = 299792458.0 / parse_quantity(paper["radar"]["carrier_frequency"], "frequency")
    d = parse_quantity(paper["effects"]["cross_track_array"]["spacing"], "length")
    theta = parse_quantity(grating["targets"]["points"][0]["elevation"], "angle")
    assert theta == pytest.approx(math.asin(lam / d + math.sin(math.radians(0.5))), abs=1e-14)
    assert parse_quantity(grating["effects"]["antenna"]["elevation_beamwidth"], "angle") == 0.0


def test_000_hard_cases_prf_is_the_coarse_need_of_their_base_scene():
    """configs/sweeps/hard_cases_000.yaml: prf_up / prf_down differ from prf_base only in the PRF (and the
    output frame), which is 1.02 / 0.98 of prf_base's coarse deramp_extent rounded to 1 mHz; every case but
    sqrt_limit measures in the squint_lrwc frame; refusals are rows."""
    from sarproc.focus.squint_deramp.coarse_focus import CoarseFocusParams, coarse_focus
    from sarproc.focus.squint_deramp.preprocess import PreprocessParams, preprocess
    from sarproc.product.config import build, load_yaml
    from sarproc.simulation.scene import scene_from_mapping
    from sarproc.simulation.simulate import simulate

    path = ROOT / "configs" / "sweeps" / "hard_cases_000.yaml"
    assert load_yaml(path)["refusals"] is True
    tasks = {t.scene: t for t in plan_sweep(path).tasks}
    base = tasks["prf_base"].config
    stages = ("preprocess", "coarse_focus", "fine_focus")
    raw = simulate(scene_from_mapping({k: v for k, v in base.items() if k not in stages}))
    coarse = coarse_focus(
        preprocess(raw, build(PreprocessParams, base["preprocess"])), build(CoarseFocusParams, base["coarse_focus"])
    )
    extent = coarse.attrs["deramp_extent"]
    for scene, factor in (("prf_up", 1.02), ("prf_down", 0.98)):
        cfg = tasks[scene].config
        assert cfg["radar"]["prf"] == f"{extent * factor:.3f} Hz"
        assert cfg["fine_focus"] == {**base["fine_focus"], "output_frame": "lrwc"}
        assert {k: v for k, v in cfg.items() if k not in ("radar", "fine_focus")} == {
            k: v for k, v in base.items() if k not in ("radar", "fine_focus")
        }
    for scene, t in tasks.items():
        if scene not in ("prf_base", "sqrt_limit"):
            assert t.config["fine_focus"]["output_frame"] == "lrwc", scene
