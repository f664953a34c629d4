"""Moving targets on scenes nobody tuned (issue 19): a campaign of randomly drawn reduced scenes, CLI runs tabulated.

Each scene is the radar of configs/xu_scene.yaml reduced as in scripts/movers_limits_003.py (a 10 MHz, 15 us chirp
at 12 MHz: 12.5 m range cells, a few seconds of reconstruct), with drawn at random from ``--seed``:

* 1-6 movers, v_r uniform over +-18 m/s, v_a over +-15 m/s, amplitude 0 to -10 dB, anywhere in the scene; some
  placed beside the previous one (sharing its range cell, or close to it in azimuth);
* 0-3 static points, some bright (amplitude 3-10);
* the antenna pattern (sinc, gaussian or rect, -3 dB beamwidth 0.507 deg), the squint (0-25 deg);
* weak clutter (random seed; then four receivers and the clutter null) or none (three receivers), noise or none.

For each scene the script runs ``sarproc simulate`` and ``sarproc reconstruct`` and reads the reconstructed
product: the moving_targets table against the truth (reconstruct's matching, truth_index), reconstruct.truth
(found, missed and why: a missed mover below the clutter null's minimum detectable velocity, or slower than
detection_velocity, or under the CFAR threshold in noise is an expected miss; the static points' fate,
static_points: a table row within 20 m of one, taken for a mover; unmatched: each other row's nearest static
point), the warnings reconstruct printed and reconstruct's CPU time. Writes <results>/campaign.md and campaign.json.

    PYTHONPATH=. python scripts/mover_campaign.py --n 30 --seed 1 --results results/mover-campaign

``--compare A B`` pairs two campaigns of the same draws (e.g. two waveforms), scene by scene, each a comma-separated
list of results directories pooled: per mover, static and scene the two outcomes side by side and an exact paired
test per column (docs/multichannel.md section 14); writes <results>/compare.md.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import resource
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np
import yaml

from sarproc.product.io import read_product
from sarproc.product.model import moving_target_rows

BASE = Path(__file__).resolve().parents[1] / "configs" / "xu_scene.yaml"
DETECTION_VELOCITY = 1.0  # m/s, reconstruct's default: a detection slower than this is static


def vehicle(name: str, azimuth: float, rng: float, v_a: float, v_r: float, amplitude: float) -> dict:
    return {
        "name": name,
        "azimuth": f"{azimuth:.1f} m",
        "range": f"{rng:.1f} m",
        "amplitude": round(amplitude, 4),
        "velocity": [f"{v_a:.2f} m/s", f"{v_r:.2f} m/s", "0 m/s"],
    }


def draw_scene(rng: np.random.Generator) -> dict:
    """One scene's YAML mapping; its draws under the key ``campaign``."""
    m = yaml.safe_load(BASE.read_text())
    for key in ("backproject", "evaluate"):
        m.pop(key, None)
    m["radar"].update({"bandwidth": "10 MHz", "range_sampling_rate": "12 MHz", "pulse_duration": "15 us"})
    squint = float(rng.uniform(0, 25))
    m["geometry"]["squint"] = f"{squint:.1f} deg"
    pattern = str(rng.choice(["sinc", "gaussian", "rect"]))
    m["effects"]["antenna"] = {"pattern": pattern, "azimuth_beamwidth": "0.507 deg"}
    clutter = bool(rng.random() < 0.5)
    noise = bool(rng.random() < 0.5)
    points: list[dict] = []
    pairs = []
    for i in range(int(rng.integers(1, 7))):
        v_r, v_a = float(rng.uniform(-18, 18)), float(rng.uniform(-15, 15))
        amp = 10 ** (-float(rng.uniform(0, 10)) / 20)
        kind = str(rng.choice(["alone", "same cell", "close azimuth"], p=[0.6, 0.2, 0.2])) if i else "alone"
        if kind == "same cell":  # one 12.5 m range cell, the same azimuth
            prev = points[-1]
            az = float(prev["azimuth"].split()[0]) + float(rng.uniform(-10, 10))
            rg = float(prev["range"].split()[0]) + float(rng.uniform(-5, 5))
        elif kind == "close azimuth":
            prev = points[-1]
            az = float(prev["azimuth"].split()[0]) + float(rng.uniform(-60, 60))
            rg = float(prev["range"].split()[0]) + float(rng.uniform(-60, 60))
        else:
            az, rg = float(rng.uniform(-1000, 1000)), float(rng.uniform(-250, 250))
        if kind != "alone":
            pairs.append((points[-1]["name"], f"M{i + 1}", kind))
        points.append(vehicle(f"M{i + 1}", az, rg, v_a, v_r, amp))
    for j in range(int(rng.integers(0, 4))):
        amp = float(rng.uniform(3, 10)) if rng.random() < 0.5 else 1.0
        points.append(
            {
                "name": f"S{j + 1}",
                "azimuth": f"{rng.uniform(-1000, 1000):.1f} m",
                "range": f"{rng.uniform(-250, 250):.1f} m",
                "amplitude": round(amp, 3),
            }
        )
    m["targets"]["points"] = points
    if clutter:
        m["effects"]["azimuth_channels"] = {"n_receivers": 4, "spacing": "1.5 m"}
        m["effects"]["clutter"] = {
            "n_scatterers": int(rng.integers(40, 150)),
            "azimuth_extent": "2400 m",
            "range_extent": "600 m",
            "amplitude": round(float(rng.uniform(0.05, 0.3)), 3),
            "seed": int(rng.integers(0, 10_000)),
        }
    if noise:
        m["effects"]["noise"] = {"snr": f"{rng.uniform(-20, -5):.1f} dB"}
    m["reconstruct"] = {"method": "modified", "clutter_suppression": clutter}
    m["campaign"] = {
        "squint_deg": squint,
        "pattern": pattern,
        "clutter": clutter,
        "noise": m["effects"].get("noise", {}).get("snr"),
        "pairs": pairs,
    }
    return m


def watched(p: subprocess.Popen, cpu_limit: float) -> str:
    """Wait for ``p``, killing it once it has used ``cpu_limit`` seconds of CPU (read from /proc: CPU, not wall, so a
    loaded machine does not stop it; RLIMIT_CPU is not enforced in every sandbox); its stderr."""
    chunks: list[str] = []
    reader = threading.Thread(target=lambda: chunks.append(p.stderr.read() if p.stderr else ""))
    reader.start()
    tick = os.sysconf("SC_CLK_TCK")
    while p.poll() is None:
        try:
            fields = Path(f"/proc/{p.pid}/stat").read_text().rsplit(")", 1)[1].split()
            if (int(fields[11]) + int(fields[12])) / tick > cpu_limit:  # utime + stime
                p.kill()
        except (OSError, IndexError, ValueError):
            pass
        time.sleep(1.0)
    p.wait()
    reader.join()
    return "".join(chunks)


def run_scene(mapping: dict, work: Path, tag: str, timeout: float) -> dict:
    """simulate and reconstruct one scene through the CLI; the product's findings against the truth. A reconstruct
    using over ``timeout`` seconds of CPU is stopped (:func:`watched`) and recorded as a failure (its cost)."""
    draws = mapping.pop("campaign")
    cfg = work / f"{tag}.yaml"
    cfg.write_text(yaml.safe_dump(mapping))
    cli = ["nice", sys.executable, "-m", "sarproc"]
    raw, rec_path = work / f"{tag}_mc.h5", work / f"{tag}.h5"
    out: dict = {"tag": tag, **draws}
    sim = subprocess.run(
        [*cli, "simulate", str(cfg), "-o", str(raw), "--overwrite", "--no-progress"], capture_output=True, text=True
    )
    if sim.returncode:
        return {**out, "crash": f"simulate: {sim.stderr.strip().splitlines()[-1:]}"}
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    p = subprocess.Popen(
        [*cli, "reconstruct", str(raw), "-o", str(rec_path), "--config", str(cfg), "--overwrite", "--no-progress"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    stderr = watched(p, timeout)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    out["cpu_s"] = (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)
    out["wall_s"] = time.perf_counter() - t0
    if p.returncode == -signal.SIGKILL:
        return {**out, "crash": f"reconstruct: over {timeout:.0f} s of CPU, stopped"}
    if p.returncode:
        return {**out, "crash": f"reconstruct: {stderr.strip().splitlines()[-1:]}"}
    out["warnings"] = [ln.split("WARNING: ", 1)[1] for ln in stderr.splitlines() if "WARNING: " in ln]
    rec = read_product(rec_path, load=False)
    raw.unlink()
    rec_path.unlink()
    info = rec.attrs["reconstruct"]
    truth = info.get("truth", {})
    reasons = {r.split(":", 1)[0]: r for r in truth.get("missed_reasons", [])}
    t = rec.targets
    names = [n.decode() for n in t["name"]]
    theta = math.radians(draws["squint_deg"])
    rows = moving_target_rows(rec.aux)
    by_truth = {int(r["truth_index"]): r for r in rows if r["truth_index"] >= 0}  # reconstruct's matching
    taken = {p["name"]: p["detections_within"] for p in truth.get("static_points", [])}  # and its static points'
    movers, statics = [], []
    for k, name in enumerate(names):
        v_a, v_r = float(t["vx"][k]), float(t["vy"][k])  # slant plane (altitude 0): vy is v_r, vx v_a
        if v_a == 0 and v_r == 0 and float(t["vz"][k]) == 0:
            statics.append({"name": name, "amplitude": abs(t["amplitude"][k]), "taken_for_mover": taken[name]})
            continue
        v_los = v_r * math.cos(theta) + v_a * math.sin(theta)
        m = {"name": name, "v_r": v_r, "v_a": v_a, "v_los": v_los, "amplitude": abs(t["amplitude"][k])}
        r = by_truth.get(k)
        if r is not None:
            m.update(
                found=True,
                snr=r["snr"],
                dv_r=r["v_r"] - v_r,
                s_r=r["v_r_sigma"],
                dv_a=r["v_a"] - v_a,
                s_a=r["v_a_sigma"],
            )
        else:
            reason = reasons.get(name, "not in missed_reasons")
            mdv = re.search(r"minimum detectable velocity ([0-9.]+) m/s", reason)
            m.update(found=False, reason=reason, mdv=float(mdv.group(1)) if mdv else None)
        movers.append(m)
    false = []
    for u in truth.get("unmatched", []):  # rows matched to no mover: reconstruct's nearest static point and whether
        r = rows[u["row"]]  # it lies at it (within its matching radius: taken for a mover, not a false alarm)
        if u["at_static"]:
            continue
        false.append(
            {
                "snr": r["snr"],
                "v_r": r["v_r"],
                "v_a": r["v_a"],
                "nearest": u["nearest_static"] or "-",
                "nearest_m": math.inf if u["distance"] is None else u["distance"],
            }
        )
    out.update(
        movers=movers,
        statics=statics,
        false_alarms=false,
        detections=info.get("detections", {}),
        cfar_db=info.get("detection_cfar", {}).get("threshold_db"),
    )
    return out


def expected(m: dict, noise: bool) -> bool:
    """Whether a missed mover is an expected miss, by its miss reason (reconstruct.truth.missed_reasons): below the
    clutter null's MDV, or its v_los within 20 % of detection_velocity (taken for static: the gain model's and the
    search's margin), or in noise under the CFAR threshold or too weak for the velocity search (detection SNR under
    20 dB: docs/multichannel.md section 8, against SNR), or in noise without the clutter null taken for static because
    its estimated v_los is not 2 sigma over detection_velocity (section 10), also only under 20 dB: the same bound
    on what the velocity search can tell, whichever rule then refuses the detection; or in noise, examined in the
    first pass over its threshold but under the measured CFAR threshold, then taken out with a brighter response,
    again under 20 dB (section 11: too weak to be detected at the false-alarm rate, or told from rest, alone)."""
    reason = m["reason"]
    weak = re.search(r"detected \(SNR ([0-9.]+) dB\) but no slant-range velocity explains", reason)
    rest = re.search(r"detected \(SNR ([0-9.]+) dB\) without a clutter null, taken for static", reason)
    taken_out = re.search(r"detected \(SNR ([0-9.]+) dB\) but taken out with the response", reason)
    return bool(
        "below this null's minimum detectable velocity" in reason
        or abs(m["v_los"]) < 1.2 * DETECTION_VELOCITY
        or (
            noise
            and "under the CFAR threshold" in reason
            and "clutter null keeps" not in reason
            and "fell" not in reason
        )
        or (noise and weak is not None and float(weak.group(1)) < 20.0)
        # in noise without the clutter null, eq. 5's velocity not 2 sigma over detection_velocity: rest not ruled out
        or (noise and rest is not None and float(rest.group(1)) < 20.0)
        or (
            noise
            and taken_out is not None
            and float(taken_out.group(1)) < 20.0
            and "under the measured CFAR threshold" in reason
        )
    )


def mover_cell(m: dict, noise: bool) -> str:
    if m["found"]:
        flag = "" if abs(m["dv_r"]) <= max(0.1, 3 * m["s_r"]) else " **v_r**"
        return f"{m['name']} ok {m['dv_r']:+.3f}/{m['s_r']:.3f} {m['dv_a']:+.2f}/{m['s_a']:.2f}{flag}"
    what = "expected" if expected(m, noise) else "**MISSED**"
    mdv = "" if m["mdv"] is None else f", MDV {m['mdv']:.2f}"
    return f"{m['name']} {what} (v_los {m['v_los']:+.2f}{mdv})"


def table(results: list[dict]) -> list[str]:
    lines = [
        "| scene | squint, beam | clutter, noise | movers: dv_r/sigma_r dv_a/sigma_a (m/s) | false alarms | "
        "statics (taken) | warnings | CPU s |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for s in results:
        head = f"| {s['tag']} | {s['squint_deg']:.1f}, {s['pattern']} | {'yes' if s['clutter'] else 'no'}, {s['noise'] or 'no'} |"
        if "crash" in s:
            lines.append(f"{head} **CRASH** {s['crash']} | | | | {s.get('cpu_s', 0):.0f} |")
            continue
        movers = "; ".join(mover_cell(m, bool(s["noise"])) for m in s["movers"])
        fa = "; ".join(
            f"SNR {f['snr']:.0f} v_r {f['v_r']:+.1f} ({f['nearest']} {f['nearest_m']:.0f} m)" for f in s["false_alarms"]
        )
        st = ", ".join(
            f"{x['name']}({x['amplitude']:g}){' **TAKEN**' if x['taken_for_mover'] else ''}" for x in s["statics"]
        )
        warns = [w for w in s["warnings"] if not w.startswith("reconstruct: truth mover")]
        lines.append(
            f"{head} {movers} | {len(s['false_alarms'])} {fa} | {st or '-'} | {len(warns)} | {s['cpu_s']:.0f} |"
        )
    return lines


def summary(results: list[dict]) -> list[str]:
    ok = [s for s in results if "crash" not in s]
    movers = [m for s in ok for m in s["movers"]]
    found = [m for m in movers if m["found"]]
    detectable = [m for s in ok for m in s["movers"] if m["found"] or not expected(m, bool(s["noise"]))]
    within = sum(abs(m["dv_r"]) <= 0.1 for m in found)
    within3 = sum(abs(m["dv_r"]) <= 3 * m["s_r"] for m in found)
    fa = sum(len(s["false_alarms"]) for s in ok)
    taken = sum(x["taken_for_mover"] > 0 for s in ok for x in s["statics"])
    n_static = sum(len(s["statics"]) for s in ok)
    cpu = [s["cpu_s"] for s in ok]
    return [
        "| scenes | crashes | found / expected-detectable | expected misses | v_r within 0.1 m/s | v_r within 3 sigma "
        "| false alarms / scene | statics taken for movers | reconstruct CPU s (median, max) |",
        "|---|---|---|---|---|---|---|---|---|",
        f"| {len(results)} | {len(results) - len(ok)} | {len(found)} / {len(detectable)} | "
        f"{len(movers) - len(detectable)} | {within} / {len(found)} | {within3} / {len(found)} | "
        f"{fa / max(len(ok), 1):.2f} ({fa}) | {taken} / {n_static} | "
        f"{np.median(cpu) if cpu else 0:.0f}, {max(cpu, default=0):.0f} |",
    ]


def sigma_line(results: list[dict]) -> str:
    """How honest the stated v_r 1-sigma is: the found movers' z = dv_r / sigma_r within 1, 2, 3 sigma (68.3, 95.4,
    99.7 % for an honest Gaussian 1-sigma) and their rms (1)."""
    z = np.array([m["dv_r"] / m["s_r"] for s in results if "crash" not in s for m in s["movers"] if m["found"]])
    if not len(z):
        return "v_r z = dv_r / sigma_r: no mover found"
    within = [int(np.sum(np.abs(z) <= k)) for k in (1, 2, 3)]
    pct = " / ".join(f"{100 * w / len(z):.0f}" for w in within)
    return (
        f"v_r z = dv_r / sigma_r over the {len(z)} found: within 1 / 2 / 3 sigma "
        f"{' / '.join(map(str, within))} ({pct} %; 68.3 / 95.4 / 99.7 for an honest 1-sigma), "
        f"rms {float(np.sqrt(np.mean(z**2))):.2f}, median |z| {float(np.median(np.abs(z))):.2f}"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=30, help="scenes")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--first", type=int, default=0, help="skip the first this many scenes (same draws)")
    ap.add_argument("--results", default="results/mover-campaign")
    ap.add_argument("--timeout", type=float, default=300.0, help="stop a reconstruct after this many seconds of CPU")
    ap.add_argument("--retabulate", action="store_true", help="rewrite campaign.md from the results' campaign.json")
    ap.add_argument("--compare", nargs=2, metavar=("A", "B"), help="pair two campaigns' results (see above)")
    args = ap.parse_args()
    if args.compare:
        lines = compare(pooled(args.compare[0]), pooled(args.compare[1]), args.compare)
        Path(args.results).mkdir(parents=True, exist_ok=True)
        (Path(args.results) / "compare.md").write_text("\n".join(lines) + "\n")
        print("\n".join(lines))
        return
    if args.retabulate:
        write(Path(args.results), json.loads((Path(args.results) / "campaign.json").read_text()), args)
        return
    rng = np.random.default_rng(args.seed)
    scenes = [draw_scene(rng) for _ in range(args.n)]
    out = Path(args.results)
    out.mkdir(parents=True, exist_ok=True)
    results = []
    with tempfile.TemporaryDirectory() as tmp:
        for i, mapping in enumerate(scenes):
            if i < args.first:
                continue
            # the scene as simulate and reconstruct read it (reconstruct --config), to rerun one by hand
            (out / f"scene{i:03d}.yaml").write_text(
                yaml.safe_dump({k: v for k, v in mapping.items() if k != "campaign"})
            )
            s = run_scene(mapping, Path(tmp), f"{i:03d}", args.timeout)
            results.append(s)
            print(table([s])[-1], flush=True)
            for w in s.get("warnings", []):
                print("   ", w, flush=True)
            write(out, results, args)  # after each scene: a stopped campaign keeps what it ran
    print("\n".join(summary(results)))
    print(sigma_line(results))


def pooled(dirs: str) -> dict[str, dict]:
    """The scenes of comma-separated results directories' campaign.json, by tag (a later directory's scene wins)."""
    return {s["tag"]: s for d in dirs.split(",") for s in json.loads((Path(d) / "campaign.json").read_text())}


def mcnemar(b: int, c: int) -> float:
    """Exact two-sided McNemar (sign) test: the binomial(b + c, 1/2) probability of a split at least as uneven as
    b : c between the discordant pairs."""
    n, k = b + c, min(b, c)
    return min(1.0, 2 * sum(math.comb(n, i) for i in range(k + 1)) / 2**n) if n else 1.0


def compare(a: dict[str, dict], b: dict[str, dict], names: list[str]) -> list[str]:
    """The two campaigns' columns over the scenes both ran without a crash, paired: per mover (found; an unexpected
    miss; of those found in both, v_r within 0.1 m/s and within 3 sigma), per static (taken for a mover), per scene
    (false alarms: counts), exact McNemar / sign tests on the discordant pairs (each listed); per mover found in
    both, z^2 = (dv_r / sigma_r)^2 by the Wilcoxon signed-rank test. Two-sided p; no correction for the several
    columns. Then each campaign's own summary over those scenes."""
    from scipy.stats import wilcoxon

    tags = sorted(t for t in a.keys() & b.keys() if "crash" not in a[t] and "crash" not in b[t])
    rows, listed = [], []

    def paired(label: str, pairs: list[tuple[str, bool, bool]]) -> None:
        only_a = [k for k, x, y in pairs if x and not y]
        only_b = [k for k, x, y in pairs if y and not x]
        rows.append(
            f"| {label} | {sum(x for _, x, _ in pairs)} / {len(pairs)} | {sum(y for _, _, y in pairs)} / "
            f"{len(pairs)} | {len(only_a)} : {len(only_b)} | exact McNemar | {mcnemar(len(only_a), len(only_b)):.3g} |"
        )
        listed.append(f"- {label}: A only {', '.join(only_a) or '-'}; B only {', '.join(only_b) or '-'}")

    movers = [
        (f"{tag} {x['name']}", x, y, bool(a[tag]["noise"]))
        for tag in tags
        for x, y in zip(a[tag]["movers"], b[tag]["movers"], strict=True)
    ]
    assert all(x["name"] == y["name"] for _, x, y, _ in movers), "not the same draws"
    paired("movers found", [(k, x["found"], y["found"]) for k, x, y, _ in movers])
    paired(
        "unexpected misses",
        [(k, not x["found"] and not expected(x, n), not y["found"] and not expected(y, n)) for k, x, y, n in movers],
    )
    both = [(k, x, y) for k, x, y, _ in movers if x["found"] and y["found"]]
    paired("found in both: v_r within 0.1 m/s", [(k, abs(x["dv_r"]) <= 0.1, abs(y["dv_r"]) <= 0.1) for k, x, y in both])
    paired(
        "found in both: v_r within 3 sigma",
        [(k, abs(x["dv_r"]) <= 3 * x["s_r"], abs(y["dv_r"]) <= 3 * y["s_r"]) for k, x, y in both],
    )
    paired(
        "statics taken for movers",
        [
            (f"{tag} {x['name']}", x["taken_for_mover"] > 0, y["taken_for_mover"] > 0)
            for tag in tags
            for x, y in zip(a[tag]["statics"], b[tag]["statics"], strict=True)
        ],
    )
    fa = [(t, len(a[t]["false_alarms"]), len(b[t]["false_alarms"])) for t in tags]
    more_a, more_b = [t for t, x, y in fa if x > y], [t for t, x, y in fa if y > x]
    rows.append(
        f"| false alarms (scenes with more) | {sum(x for _, x, _ in fa)} | {sum(y for _, _, y in fa)} | "
        f"{len(more_a)} : {len(more_b)} | exact sign test | {mcnemar(len(more_a), len(more_b)):.3g} |"
    )
    listed.append(f"- false alarms, more in: A {', '.join(more_a) or '-'}; B {', '.join(more_b) or '-'}")
    z2 = np.array([((x["dv_r"] / x["s_r"]) ** 2, (y["dv_r"] / y["s_r"]) ** 2) for _, x, y in both]).reshape(-1, 2)
    rms = np.sqrt(z2.mean(axis=0)) if len(z2) else np.full(2, math.nan)
    p_z = float(wilcoxon(z2[:, 1] - z2[:, 0]).pvalue) if np.any(z2[:, 1] != z2[:, 0]) else 1.0
    rows.append(
        f"| found in both: rms z = dv_r / sigma_r | {rms[0]:.2f} ({len(z2)}) | {rms[1]:.2f} ({len(z2)}) | "
        f"{int(np.sum(z2[:, 0] > z2[:, 1]))} : {int(np.sum(z2[:, 1] > z2[:, 0]))} (larger z^2) | "
        f"Wilcoxon signed-rank on z^2 | {p_z:.3g} |"
    )
    own = [[a[t] for t in tags], [b[t] for t in tags]]
    return [
        f"# Paired: A = {names[0]}, B = {names[1]}",
        "",
        f"{len(tags)} scenes ({', '.join(tags)}); crashed in either: {len(a.keys() & b.keys()) - len(tags)}.",
        "",
        "| column | A | B | discordant (A only : B only) | test | two-sided p |",
        "|---|---|---|---|---|---|",
        *rows,
        "",
        *listed,
        "",
        "A's own summary:",
        "",
        *summary(own[0]),
        "",
        sigma_line(own[0]),
        "",
        "B's own summary:",
        "",
        *summary(own[1]),
        "",
        sigma_line(own[1]),
    ]


def write(out: Path, results: list[dict], args: argparse.Namespace) -> None:
    lines = [
        f"# Mover campaign: {len(results)} of {args.n} random scenes, seed {args.seed}, reconstruct stopped over "
        f"{args.timeout:g} s of CPU (scripts/mover_campaign.py)",
        "",
        *summary(results),
        "",
        sigma_line(results),
        "",
        *table(results),
        "",
        "Per mover: dv_r / sigma_r and dv_a / sigma_a (estimate - truth, stated 1-sigma); **v_r**: |dv_r| over both "
        "0.1 m/s and 3 sigma. A miss is expected when the product says it is below the clutter null's MDV, its "
        "v_los is under detection_velocity, or (in noise) it is under the CFAR threshold.",
    ]
    (out / "campaign.md").write_text("\n".join(lines) + "\n")
    (out / "campaign.json").write_text(json.dumps(results, indent=1, default=float))


if __name__ == "__main__":
    main()
