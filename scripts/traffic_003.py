"""Tabulate and plot the traffic scene of paper 003 (`make reproduce-003-traffic`; products only).

Reads what the command line wrote under --results:

* ``raw.h5`` (``sarproc reconstruct``): the aux ``moving_targets`` table (one row per detected mover:
  detection SNR, estimated v_r, v_a with 1-sigma, apparent and relocated positions, the matched truth row)
  and the truth targets table;
* ``report.json`` (``sarproc evaluate`` of the backprojected modified reconstruction): each target's
  IRW / PSLR / ISLR, moving ones measured where they appear;
* ``report_conventional.json`` (the conventional reconstruction, the static targets only): the static
  targets must be unaffected by the moving-target processing;
* ``two_movers/raw.h5``, optional: the two-mover case (v_r 10 and -6 m/s, 80 m apart in walk-corrected range);
* ``static/chip_{modified,conventional}_S<k>.json``, optional (configs/xu_traffic_static.yaml: the static
  points 20 dB over the clutter): each static point measured in a chip of the modified and of the
  conventional reconstruction; they must agree within STATIC_TOLERANCE.

Writes ``detections.md`` (the table and the verdicts) and ``traffic.png`` (truth, apparent and relocated
positions). A found mover's relocation error, its bound and the verdict are reconstruct's
(``attrs['reconstruct']['truth']['relocation']``, sarproc.quality.moving.relocation_check, also in evaluate's
moving-target entries): the bound is the velocity error's own relocation error (the truth's static equivalent
relocated with the estimated velocity) plus the apparent-position error (times 1 + |v| / v_platform) plus twice
relocate's tolerance; no allowance by hand (before session 41: evaluate's first-order
``relocation_error_from_velocity`` + 2 m, a fixed allowance for the apparent position).
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from typing import Any

from sarproc.product.io import read_product
from sarproc.product.model import Product, moving_target_rows

V_R_TOLERANCE = 0.1  # m/s, the issue's (and the paper's) slant-range velocity precision
# modified against conventional reconstruction of a static point: peak (dB), IRW/theory, PSLR and ISLR (dB)
STATIC_TOLERANCE = {"peak_db": 0.05, "irw_ratio": 0.005, "pslr_db": 0.1, "islr_db": 0.1}


def names(product: Product) -> list[str]:
    return [n.decode() if isinstance(n, bytes) else str(n) for n in product.targets["name"]]


def axis_metrics(report: dict | None, name: str) -> dict | None:
    for t in (report or {}).get("targets", []):
        if t["name"] == name:
            return {a["axis"]: a for a in t["axes"]}
    return None


def mover_table(product: Product, report: dict | None) -> tuple[list[dict], list[dict]]:
    """Rows per truth mover (found or not) and the false alarms."""
    tt = product.targets
    nm = names(product)
    rows = moving_target_rows(product.aux)
    by_truth = {int(r["truth_index"]): r for r in rows if r["truth_index"] >= 0}
    false = [r for r in rows if r["truth_index"] < 0]
    relocation = {c["name"]: c for c in product.attrs["reconstruct"].get("truth", {}).get("relocation", [])}
    out = []
    for k in range(len(tt)):
        if not (tt["vx"][k] or tt["vy"][k] or tt["vz"][k]):
            continue
        e: dict[str, Any] = {
            "name": nm[k],
            "v_r": float(tt["vy"][k]),
            "v_a": float(tt["vx"][k]),
            "amp_db": 20 * math.log10(abs(tt["amplitude"][k])),
        }
        r = by_truth.get(k)
        if r is not None:
            check = relocation[nm[k]]  # reconstruct's relocation against the truth
            e.update(
                found=True,
                snr=r["snr"],
                v_r_est=r["v_r"],
                v_r_sigma=r["v_r_sigma"],
                v_a_est=r["v_a"],
                v_a_sigma=r["v_a_sigma"],
                dv_r=r["v_r"] - e["v_r"],
                dv_a=r["v_a"] - e["v_a"],
                relocation_error=check["relocation_error"],
                relocation_bound=check["relocation_bound"],
                relocation_ok=check["relocation_within_bound"],
                cells=f"{int(r['range_cell_first'])}-{int(r['range_cell_last']) - 1}",
            )
        else:
            e["found"] = False
        m = axis_metrics(report, nm[k])
        if m:
            e["az_irw_ratio"] = m["azimuth"]["irw_ratio"]
            e["az_pslr"] = m["azimuth"]["pslr_db"]
            e["az_islr"] = m["azimuth"]["islr_db"]
            e["rg_irw_ratio"] = m["range"]["irw_ratio"]
        out.append(e)
    return out, false


def counts(info: dict) -> dict:
    """reconstruct's truth record without its per-detection lists (relocation: tabulated in the table;
    static_points, unmatched: the static points' matches, mover_campaign.py's)."""
    return {k: v for k, v in info.get("truth", {}).items() if k not in ("relocation", "static_points", "unmatched")}


def fmt(v: Any, spec: str) -> str:
    return "n/a" if v is None or (isinstance(v, float) and not math.isfinite(v)) else format(v, spec)


def markdown(
    rows: list[dict],
    false: list[dict],
    statics: list[dict],
    two: tuple[list[dict], list[dict], dict] | None,
    info: dict,
) -> str:
    lines = [
        "# Paper 003 traffic scene (configs/xu_traffic.yaml): moving-target detection\n",
        f"Detections examined: {json.dumps(info.get('detections', {}))}; truth: {json.dumps(counts(info))}\n",
        "| vehicle | amp (dB) | v_r true | v_a true | found | SNR (dB) | v_r est +- 1 sigma | v_r error | "
        "v_a est +- 1 sigma | v_a error | relocation error (m) | bound (m) | az IRW/theory | az PSLR | az ISLR | "
        "range cells |",
        "|---|---:|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|",
    ]
    for e in rows:
        if e["found"]:
            lines.append(
                f"| {e['name']} | {e['amp_db']:.1f} | {e['v_r']:.2f} | {e['v_a']:.2f} | yes | {e['snr']:.1f} | "
                f"{e['v_r_est']:.3f} +- {e['v_r_sigma']:.3f} | {e['dv_r']:+.3f} | "
                f"{e['v_a_est']:.3f} +- {e['v_a_sigma']:.3f} | {e['dv_a']:+.3f} | "
                f"{e['relocation_error']:.2f} | {fmt(e['relocation_bound'], '.2f')} | "
                f"{fmt(e.get('az_irw_ratio'), '.3f')} | {fmt(e.get('az_pslr'), '.2f')} | "
                f"{fmt(e.get('az_islr'), '.2f')} | {e['cells']} |"
            )
        else:
            lines.append(
                f"| {e['name']} | {e['amp_db']:.1f} | {e['v_r']:.2f} | {e['v_a']:.2f} | **missed** |" + " |" * 11
            )
    reasons = info.get("truth", {}).get("missed_reasons", [])
    if reasons:
        lines += ["", "Why each missed vehicle is missed (reconstruct.truth.missed_reasons):", ""]
        lines += [f"- {r}" for r in reasons]
    found = [e for e in rows if e["found"]]
    ok_vr = all(abs(e["dv_r"]) <= V_R_TOLERANCE for e in found)
    ok_reloc = all(e["relocation_ok"] is not False for e in found)  # None: S not relocated, no bound
    lines += [
        "",
        f"- found {len(found)} of {len(rows)} vehicles; false alarms above the CFAR threshold (the measured "
        f"clutter residual + {info.get('cfar_db', 15):g} dB): {len(false)}"
        + cfar_line(info.get("detection_cfar"))
        + (
            "".join(
                f"\n  - false alarm: SNR {f['snr']:.1f} dB, v_r {f['v_r']:.2f}, v_a {f['v_a']:.2f} m/s" for f in false
            )
        ),
        f"- every vehicle found: {'yes' if len(found) == len(rows) else 'no, missed ' + ', '.join(e['name'] for e in rows if not e['found'])}",
        f"- every found vehicle's v_r within {V_R_TOLERANCE} m/s: {'yes' if ok_vr else 'no'} "
        f"(largest error {max((abs(e['dv_r']) for e in found), default=float('nan')):.3f} m/s)",
        "- every relocation within its bound (the velocity error's own relocation error + the apparent-position "
        f"error, reconstruct's truth.relocation): {'yes' if ok_reloc else 'no'}",
    ]
    if statics:
        lines += [
            "",
            "Static targets of xu_traffic.yaml (as bright as the clutter around them), modified against "
            "conventional reconstruction (evaluate of the whole image):",
            "",
            "| target | peak ratio (dB) | az IRW/theory mod / conv | az PSLR mod / conv | rg PSLR mod / conv |",
            "|---|---:|---:|---:|---:|",
        ]
        for s in statics:
            lines.append(
                f"| {s['name']} | {s['peak_db']:+.3f} | {s['az_irw'][0]:.3f} / {s['az_irw'][1]:.3f} | "
                f"{s['az_pslr'][0]:.2f} / {s['az_pslr'][1]:.2f} | {s['rg_pslr'][0]:.2f} / {s['rg_pslr'][1]:.2f} |"
            )
    if two:
        rows2, false2, info2 = two
        lines += [
            "",
            "Two movers 80 m apart in walk-corrected range (configs/xu_two_movers.yaml):",
            "",
            "| mover | v_r true | v_r est | v_r error | v_a est | relocation error (m) |",
            "|---|---:|---:|---:|---:|---:|",
        ]
        for e in rows2:
            if e["found"]:
                lines.append(
                    f"| {e['name']} | {e['v_r']:.2f} | {e['v_r_est']:.3f} | {e['dv_r']:+.3f} | "
                    f"{e['v_a_est']:.3f} | {e['relocation_error']:.2f} |"
                )
            else:
                lines.append(f"| {e['name']} | {e['v_r']:.2f} | missed | | | |")
        lines.append(f"\nfalse alarms: {len(false2)}; detections: {json.dumps(info2.get('detections', {}))}")
    return "\n".join(lines) + "\n"


def static_chip_rows(res: Path) -> list[dict]:
    """Per static point of configs/xu_traffic_static.yaml: (modified, conventional) metrics from its chips."""
    out = []
    for k in range(1, 10):
        name = f"S{k}"
        pair = [load_json(res / "static" / f"chip_{m}_{name}.json") for m in ("modified", "conventional")]
        if not all(pair):
            continue
        row: dict[str, Any] = {"name": name}
        targets = [next(t for t in r["targets"] if t["name"] == name) for r in pair]
        row["peak_db"] = 20 * math.log10(targets[0]["peak_amplitude"] / targets[1]["peak_amplitude"])
        for axis in ("azimuth", "range"):
            a, b = ({x["axis"]: x for x in t["axes"]}[axis] for t in targets)
            for key in ("irw_ratio", "pslr_db", "islr_db"):
                row[f"{axis}_{key}"] = (a[key], b[key])
        row["ok"] = abs(row["peak_db"]) <= STATIC_TOLERANCE["peak_db"] and all(
            abs(row[f"{axis}_{key}"][0] - row[f"{axis}_{key}"][1]) <= STATIC_TOLERANCE[key]
            for axis in ("azimuth", "range")
            for key in ("irw_ratio", "pslr_db", "islr_db")
        )
        out.append(row)
    return out


def static_chip_markdown(rows: list[dict]) -> str:
    if not rows:
        return ""
    tol = STATIC_TOLERANCE
    lines = [
        "",
        "Static targets 20 dB over the clutter (configs/xu_traffic_static.yaml), modified (mover processing) / "
        "conventional reconstruction, each in its own chip; expected equal within "
        f"{tol['peak_db']} dB of peak, {tol['irw_ratio']} of IRW/theory, {tol['pslr_db']} dB of PSLR and ISLR:",
        "",
        "| target | peak mod/conv (dB) | az IRW/theory | az PSLR (dB) | az ISLR (dB) | rg IRW/theory | rg PSLR (dB) | "
        "rg ISLR (dB) | equal |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---|",
    ]
    for r in rows:
        cells = [f"{r['peak_db']:+.4f}"]
        for axis in ("azimuth", "range"):
            a, b = r[f"{axis}_irw_ratio"]
            cells.append(f"{a:.4f} / {b:.4f}")
            for key in ("pslr_db", "islr_db"):
                a, b = r[f"{axis}_{key}"]
                cells.append(f"{a:.3f} / {b:.3f}")
        lines.append(f"| {r['name']} | " + " | ".join(cells) + f" | {'yes' if r['ok'] else '**no**'} |")
    lines.append(f"\n- static targets unaffected: {'yes' if all(r['ok'] for r in rows) else 'no'}")
    return "\n".join(lines) + "\n"


def static_rows(product: Product, report: dict, report_conv: dict) -> list[dict]:
    out = []
    nm = names(product)
    tt = product.targets
    for k in range(len(tt)):
        if tt["vx"][k] or tt["vy"][k] or tt["vz"][k]:
            continue
        a, b = axis_metrics(report, nm[k]), axis_metrics(report_conv, nm[k])
        pa = [t["peak_amplitude"] for t in report["targets"] if t["name"] == nm[k]]
        pb = [t["peak_amplitude"] for t in report_conv["targets"] if t["name"] == nm[k]]
        if not (a and b and pa and pb):
            continue
        out.append(
            {
                "name": nm[k],
                "peak_db": 20 * math.log10(pa[0] / pb[0]),
                "az_irw": (a["azimuth"]["irw_ratio"], b["azimuth"]["irw_ratio"]),
                "az_pslr": (a["azimuth"]["pslr_db"], b["azimuth"]["pslr_db"]),
                "rg_pslr": (a["range"]["pslr_db"], b["range"]["pslr_db"]),
            }
        )
    return out


def figure(product: Product, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tt = product.targets
    rows = moving_target_rows(product.aux)
    moving = (tt["vx"] != 0) | (tt["vy"] != 0)
    fig, ax = plt.subplots(figsize=(10, 6))
    ax.plot(tt["x"][moving] / 1e3, tt["y"][moving] / 1e3, "ko", label="vehicle (truth, t = 0)")
    ax.plot(tt["x"][~moving] / 1e3, tt["y"][~moving] / 1e3, "ks", mfc="none", label="static target")
    for r in rows:
        ax.plot(r["apparent_x"] / 1e3, r["apparent_y"] / 1e3, "r^", ms=7)
        ax.plot(r["relocated_x"] / 1e3, r["relocated_y"] / 1e3, "b+", ms=12)
        ax.annotate(
            "",
            (r["relocated_x"] / 1e3, r["relocated_y"] / 1e3),
            (r["apparent_x"] / 1e3, r["apparent_y"] / 1e3),
            arrowprops={"arrowstyle": "->", "color": "0.6"},
        )
    ax.plot([], [], "r^", label="apparent (where it focuses)")
    ax.plot([], [], "b+", label="relocated (apparent + estimated velocity)")
    ax.set_xlabel("x, along track (km)")
    ax.set_ylabel("y, slant range (km)")
    ax.set_title("xu_traffic.yaml: detected movers")
    ax.legend(loc="best", fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def load_json(path: str | Path) -> Any:
    return json.loads(Path(path).read_text()) if Path(path).exists() else None


def cfar_line(cfar: dict | None) -> str:
    """The second pass's CFAR against the measured background (reconstruct.detection_cfar), in words."""
    if not cfar or "tail" not in cfar:
        return ""
    return (
        f"\n- CFAR against the measured background (examined responses taken out): {cfar['background_peaks']} peaks, "
        f"generalised Pareto tail xi {cfar['tail']['xi']:.2f}; threshold {cfar['threshold_db']:.1f} dB for a "
        f"false-alarm rate {cfar['false_alarm_rate']:g} per peak (set by {cfar['set_by']}; "
        f"{cfar['expected_false_alarms']:.2f} expected)"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--results", default="results/003-traffic")
    args = ap.parse_args()
    res = Path(args.results)
    rec = read_product(res / "raw.h5", load=False)
    report = load_json(res / "report.json")
    rows, false = mover_table(rec, report)
    statics = static_rows(rec, report, load_json(res / "report_conventional.json")) if report else []
    info = dict(rec.attrs["reconstruct"])
    info["cfar_db"] = next(
        (
            h["parameters"].get("detection_snr", 15)
            for h in rec.history
            if str(h.get("command", "")).startswith("reconstruct")
        ),
        15,
    )
    two = None
    if (res / "two_movers" / "raw.h5").exists():
        rec2 = read_product(res / "two_movers" / "raw.h5", load=False)
        two = (*mover_table(rec2, None), rec2.attrs["reconstruct"])
    text = markdown(rows, false, statics, two, info) + static_chip_markdown(static_chip_rows(res))
    static_rec = res / "static" / "raw_modified.h5"
    if static_rec.exists():
        st = read_product(static_rec, load=False).attrs["reconstruct"]
        text += (
            f"\nMovers of configs/xu_traffic_static.yaml: truth {json.dumps(counts(st))}; "
            f"detections {json.dumps(st.get('detections', {}))}\n"
        )
    (res / "detections.md").write_text(text)
    figure(rec, res / "traffic.png")
    print(text)


if __name__ == "__main__":
    main()
