"""The sweeps behind `make accuracy-*` run exactly the settings of the scripts whose tables they replace."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

from sarproc.cli.sweep_tasks import plan_sweep
from sarproc.product.units import parse_quantity

ROOT = Path(__file__).resolve().parents[2]


def _script(name):
    sys.path.insert(0, str(ROOT / "scripts"))  # accuracy_002 imports reproduce_002 from its folder
    try:
        spec = importlib.util.spec_from_file_location(name, ROOT / "scripts" / f"{name}.py")
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
    finally:
        sys.path.remove(str(ROOT / "scripts"))
    return module


def test_backprojection_sweep_has_the_scripts_settings():
    script = _script("accuracy_backprojection")
    plan = plan_sweep(ROOT / "configs" / "sweeps" / "backprojection.yaml")
    for scene in ("stripmap", "squint30"):
        got = sorted(
            (t.setting["backproject.engine"], t.setting["backproject.upsample"], t.setting["backproject.interpolation"])
            for t in plan.tasks
            if t.scene == scene
        )
        assert got == sorted(set(script.SETTINGS) | {script.REFERENCE})


def test_000_sweep_has_the_scripts_settings_in_its_frame():
    script = _script("accuracy_000")
    plan = plan_sweep(ROOT / "configs" / "sweeps" / "accuracy_000.yaml")
    for scene in ("exp2_small", "airborne_small"):
        tasks = [t for t in plan.tasks if t.scene == scene]
        assert all(t.config["fine_focus"]["output_frame"] == "lrwc" for t in tasks)  # the script's frame
        got = []
        for t in tasks:
            over = {}
            for key, value in t.setting.items():
                section, name = key.split(".")
                over.setdefault(section, {})[name] = value
            got.append(over if over != {"fine_focus": {"stolt_kernel": "knab"}} else {})  # the baseline
        assert sorted(map(repr, got)) == sorted(repr(o) for _, o in script.SETTINGS)


def test_002_sweep_has_the_scripts_settings():
    pytest.importorskip("matplotlib")
    script = _script("accuracy_002")
    plan = plan_sweep(ROOT / "configs" / "sweeps" / "accuracy_002.yaml")
    from sarproc.focus.pfa.chain import Pfa2Params, pfa2
    from sarproc.product.config import build, load_yaml
    from sarproc.simulation.scene import scene_from_mapping
    from sarproc.simulation.simulate import simulate

    mapping = load_yaml(ROOT / "configs" / "nie2016_small.yaml")
    image = pfa2(
        simulate(scene_from_mapping(mapping, "nie2016_small.yaml")),
        build(Pfa2Params, mapping.get("pfa2"), "nie2016_small.yaml", "pfa2"),
    )
    radius = image.attrs["valid_radius_eq7"]  # the script's sub-image sizes are fractions of it
    wanted = []
    for _, change in script.SETTINGS:
        want = dict(change) if change else {"method": "two_step"}
        if "subimage_size" in want:
            want["subimage_size"] *= radius
        wanted.append(want)
    for task in plan.tasks:
        got = {k.split(".", 1)[1]: v for k, v in task.setting.items()}
        if isinstance(got.get("subimage_size"), str):
            got["subimage_size"] = parse_quantity(got["subimage_size"], "length")
        assert sum(script._same(got, w) or _close(got, w) for w in wanted) == 1, got
    assert len(plan.tasks) == len(wanted)


def _close(got, want):
    return set(got) == set(want) and all(
        abs(got[k] - want[k]) <= 1e-9 * abs(want[k]) if isinstance(want[k], float) else got[k] == want[k] for k in want
    )


def _array3d(config):
    from sarproc.focus.array3d.linear_array import Array3DParams
    from sarproc.product.config import as_dict, build

    return repr(sorted(as_dict(build(Array3DParams, config.get("array3d") or {})).items()))


def test_004_sweeps_have_the_scripts_settings_and_isolated_targets():
    pytest.importorskip("matplotlib")
    script = _script("accuracy_004")
    from sarproc.product.config import load_yaml

    paper = load_yaml(ROOT / "configs" / "du2010.yaml")
    base = paper.pop("array3d")
    plan = plan_sweep(ROOT / "configs" / "sweeps" / "accuracy_004.yaml")
    want = sorted(_array3d({"array3d": {**base, **knobs}}) for _, knobs in script.SETTINGS)
    points = paper["targets"]["points"]
    scenes = {"du2010": points, **{f"target{p['name']}": [p] for p in points}}  # the script's isolated scenes
    assert sorted({t.scene for t in plan.tasks}) == sorted(scenes)
    for scene, pts in scenes.items():
        tasks = [t for t in plan.tasks if t.scene == scene]
        assert sorted(_array3d(t.config) for t in tasks) == want  # the 19 settings, each once
        for t in tasks:
            assert t.config["targets"]["points"] == pts
            assert {k: v for k, v in t.config.items() if k not in ("targets", "array3d")} == {
                k: v for k, v in paper.items() if k != "targets"
            }
    wide = plan_sweep(ROOT / "configs" / "sweeps" / "accuracy_004_wide.yaml")
    assert sorted(_array3d(t.config) for t in wide.tasks) == sorted(
        _array3d({"array3d": knobs}) for _, knobs in script.WIDE_SETTINGS
    )  # the script's base there is {}
    assert all({k: v for k, v in t.config.items() if k != "array3d"} == script.WIDE for t in wide.tasks)


def test_003_sweep_has_the_scripts_reconstruct_settings():
    pytest.importorskip("matplotlib")
    script = _script("accuracy_003")
    from sarproc.focus.multichannel.reconstruct import ReconstructParams
    from sarproc.product.config import build
    from sarproc.simulation.scene import scene_from_mapping

    plan = plan_sweep(ROOT / "configs" / "sweeps" / "accuracy_003.yaml")
    scene = script.scene_mapping(ROOT / "configs" / "xu_scene.yaml", [script.TARGET])  # the script's scene
    radar = scene_from_mapping(dict(scene)).radar
    got = []
    for t in plan.tasks:
        assert not t.evaluate and t.focus == ("reconstruct",)
        assert t.config["targets"] == scene["targets"]  # the one moving target T
        assert {k: v for k, v in t.config.items() if k not in ("effects", "reconstruct")} == {
            k: v for k, v in scene.items() if k not in ("effects", "reconstruct")
        }
        ch = t.config["effects"]["azimuth_channels"]
        assert {k: v for k, v in t.config["effects"].items() if k != "azimuth_channels"} == {
            k: v for k, v in scene["effects"].items() if k != "azimuth_channels"
        }
        got.append(
            (
                build(ReconstructParams, t.config.get("reconstruct") or {}),
                ch["n_receivers"],
                parse_quantity(ch["spacing"], "length"),
            )
        )
    want = [(script.search_params(s, step), 3, 2.0) for s, step in script.SEARCH]
    want += [(ReconstructParams(), n, script.channel_spacing(radar, n)) for n in script.CHANNELS]
    # one task per script row (search fast 0.1 and N = 3 are the same reconstruct, as in the script)
    assert sorted((repr(p), n, round(d, 12)) for p, n, d in got) == sorted(
        (repr(p), n, round(d, 12)) for p, n, d in want
    )


def test_reproduce_003_sweeps_and_strip_config_hold_the_reproductions_geometry():
    """make reproduce-003's strips span +-1.5 ghost spacings PRF v / K_a of their own scene (a PRF changed in a
    scene without its strip would silently measure other ghosts), and every given-velocity scene reconstructs
    with the velocity of its target."""
    import math

    from sarproc.focus.backprojection import BackprojectParams
    from sarproc.focus.multichannel.reconstruct import ReconstructParams
    from sarproc.product.config import build, load_yaml
    from sarproc.simulation.scene import scene_from_mapping

    def spacing(config):
        r = scene_from_mapping(dict(config)).radar
        ka = 2 * (r.velocity * math.cos(r.squint)) ** 2 / (r.wavelength * r.reference_range)
        return r.prf / ka * r.velocity

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
    assert sizes == {"97.7300277783166 m"}
