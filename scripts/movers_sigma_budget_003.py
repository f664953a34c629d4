"""Why a mover's v_a misses its stated 1-sigma: its error budget, term by term (paper 003, issue 19).

One clutter case of scripts/movers_sigma_003.py (a seed and a truth (v_r, v_a)) is simulated three times: the
whole scene, the mover alone (clutter amplitude 0) and the clutter alone (its difference; the simulator is
linear). ``reconstruct`` runs on the whole scene, instrumented: at each autofocus the mover-alone and the
clutter-alone channels are taken through the same window, separation mask, velocities, cells and times, and
the autofocus run on each. Per autofocus:

* ``full``: the estimate as run (before the v_r refinement);
* ``mover``: the same path on the mover alone: the path's own error (no clutter, same cells, t_c, range, v_los);
* ``mover@truth``: the mover alone demodulated with the truth v_r, v_a (the v_los error's part);
* the clutter-to-mover energy in the autofocus cells inside the illumination |t' - t_0| <= T / 2 and outside;
* t_0 and the slant range R(t_0) the autofocus took, against the truth (the range converts R'' into v_a).

    PYTHONPATH=. python scripts/movers_sigma_budget_003.py --seed 2 --v-r 4 --v-a -6
"""

from __future__ import annotations

import argparse
import copy
import dataclasses
import importlib.util
import math
from pathlib import Path
from typing import Any

import numpy as np

import sarproc.focus.multichannel.reconstruct as rc
from sarproc.focus.multichannel import detection
from sarproc.product import fft as sfft, moving
from sarproc.product.metadata import C
from sarproc.product.model import moving_target_table
from sarproc.simulation.scene import scene_from_mapping
from sarproc.simulation.simulate import simulate

_spec = importlib.util.spec_from_file_location("movers_sigma_003", Path(__file__).with_name("movers_sigma_003.py"))
assert _spec is not None and _spec.loader is not None
mc = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(mc)

STATE: dict = {"x_tr": {}, "wins": {}, "calls": []}
_to_deramped, _window_at, _autofocus = rc._to_deramped, rc._window_at, rc._autofocus


def to_deramped(raw: Any, g: Any) -> Any:
    out = _to_deramped(raw, g)
    full = STATE.get("full")
    if full is not None and raw is full:
        for name, alt in STATE["alts"].items():
            spec, f_r, _ = _to_deramped(alt, g)
            STATE["x_tr"][name] = sfft.ifft(spec * (np.abs(f_r) <= full.radar.bandwidth / 2), axis=-1)
    return out


def window_at(det: Any, scan: Any) -> Any:
    w = _window_at(det, scan)
    alts = {}
    for name, x_tr in STATE["x_tr"].items():
        x_w = sfft.fft(x_tr[:, :, w.a : w.b], axis=-1)
        ext = detection.extract(x_w, scan.g.times, scan.g.prf, det.time, w.ka_w, scan.params.separation_bandwidth)
        win = rc._Window(ext, w.f_w, scan.g, scan.params)
        win.cells = w.win.cells
        alts[name] = win
    STATE["wins"][id(w.win)] = alts
    if "mover" in STATE["x_tr"]:
        e = np.sum(np.abs(STATE["x_tr"]["mover"][:, :, w.a : w.b]) ** 2, axis=(0, 1))
        cells = np.arange(w.a, w.b)
        top, centroid = int(cells[np.argmax(e)]), float(e @ cells / e.sum())
        STATE.setdefault("dets", []).append((det.cell, det.time, top, centroid, scan.rt0, scan.lead, scan.g.fs))
    return w


def autofocus(est: Any, win: Any, params: Any, g: Any, centre: Any, can_search: bool) -> Any:
    alts = STATE["wins"].get(id(win), {})
    y_cells = sfft.ifft(centre.y_dem, axis=1)
    cp = np.sum(np.abs(y_cells) ** 2, axis=0)
    keep = np.nonzero(cp >= 0.01 * cp.max())[0] if centre.own_cells is None else centre.own_cells
    rec: dict = {
        "v_r_in": est.v_r,
        "v_a_in": est.v_a,
        "v_los_in": est.v_los(g),
        "null_fit": est.by_null_fit,
        "cells": len(keep),
        "t_c": centre.t_c,
        "R_c": centre.slant_range,
    }
    truth = STATE["truth"]
    for name, awin in alts.items():
        for label, (v_r, v_a) in ((name, (est.v_r, est.v_a)), (name + "@truth", (truth["v_r"], truth["v_a"]))):
            if label == "clutter@truth":
                continue
            y_dem = sfft.ifft(awin.demodulated_spectrum(v_r, v_a), axis=0)
            c2 = dataclasses.replace(centre, y_dem=y_dem, own_cells=keep)
            e2 = copy.copy(est)
            e2.v_r, e2.v_a = v_r, v_a
            t0, r0 = _autofocus(e2, awin, params, g, c2, False)
            rec[label] = {"v_a": e2.v_a, "pull": e2.pull, "t_0": t0, "R_0": r0, "snr": e2.autofocus_snr}
        if name in ("mover", "clutter"):
            yc = sfft.ifft(sfft.ifft(awin.demodulated_spectrum(est.v_r, est.v_a), axis=0), axis=1)[:, keep]
            rec["E_" + name] = np.sum(np.abs(yc) ** 2, axis=1)
    e_full = copy.copy(est)
    t0, r0 = _autofocus(e_full, win, params, g, centre, False)
    rec["full"] = {"v_a": e_full.v_a, "pull": e_full.pull, "t_0": t0, "R_0": r0, "snr": e_full.autofocus_snr}
    STATE["calls"].append(rec)
    return _autofocus(est, win, params, g, centre, can_search)


rc._to_deramped, rc._window_at, rc._autofocus = to_deramped, window_at, autofocus


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seed", type=int, required=True)
    ap.add_argument("--v-r", type=float, required=True)
    ap.add_argument("--v-a", type=float, required=True)
    ap.add_argument("--clutter-amplitude", type=float, default=1.0, help="0: the mover alone through the null path")
    args = ap.parse_args()
    m = mc.scene([mc.vehicle("SLOWISH", 0, 0, args.v_a, args.v_r)], args.seed)
    m["effects"]["clutter"]["amplitude"] = args.clutter_amplitude
    full = simulate(scene_from_mapping(m))
    m["effects"]["clutter"]["amplitude"] = 0.0
    mover = simulate(scene_from_mapping(m))
    clutter = dataclasses.replace(full, data=full.data - mover.data)
    STATE.update(full=full, alts={"mover": mover, "clutter": clutter})
    t = full.targets
    xyz = np.array([t["x"][0], t["y"][0], t["z"][0]])
    vel = np.array([t["vx"][0], t["vy"][0], t["vz"][0]])
    times = np.asarray(full.coords["azimuth_time"], float)
    centres = moving.phase_centres(full)
    t0 = moving.illumination_centre_time(full.radar, times, xyz, vel, centres)
    p0 = np.array([np.interp(t0, times, centres[:, k]) for k in range(3)])
    r0 = float(np.linalg.norm(xyz + vel * t0 - p0))
    STATE["truth"] = {"v_r": float(vel[1]), "v_a": float(vel[0]), "t_0": t0, "R_0": r0}
    rec = rc.reconstruct(full, rc.ReconstructParams(clutter_suppression=True))
    table = moving_target_table(rec.aux)
    info = rec.attrs["reconstruct"]["moving_targets"]
    print(f"case seed {args.seed} v_r {args.v_r:g} v_a {args.v_a:g}: truth t_0 {t0 * 1e3:.2f} ms, R(t_0) {r0:.2f} m")
    for i in range(len(table["id"])):
        mt = info[int(table["id"][i])]
        print(
            f"  row {i}: truth {int(table['truth_index'][i])} snr {table['snr'][i]:.1f} dB  "
            f"dv_r {table['v_r'][i] - vel[1]:+.3f} (sigma {table['v_r_sigma'][i]:.3f})  "
            f"dv_a {table['v_a'][i] - vel[0]:+.3f} (sigma {table['v_a_sigma'][i]:.3f})  "
            f"af snr {mt.get('autofocus_snr_db')} pull {mt.get('autofocus_pull')}"
        )
    g = rc._geometry(full, rc.ReconstructParams())
    lam = C / g.fc
    for cell, time, top, centroid, rt0, lead, fs in STATE.get("dets", []):
        wc = r0 + g.velocity * math.sin(g.squint) * t0  # the truth's walk-corrected range
        truth_cell = lead + (2 * wc / C - rt0) * fs
        print(
            f"  detection cell {cell} at {1e3 * time:.1f} ms: truth walk-corrected range at cell {truth_cell:.2f}; "
            f"the mover's energy peaks at cell {top}, centroid {centroid:.2f}"
        )
    for k, c in enumerate(STATE["calls"]):
        print(
            f"  autofocus call {k}: null fit {c['null_fit']}, {c['cells']} cells, in: dv_r {c['v_r_in'] - vel[1]:+.3f}"
            f" dv_los {c['v_los_in'] - (vel[1] * math.cos(g.squint) + vel[0] * math.sin(g.squint)):+.4f}"
            f"  t_c {1e3 * (c['t_c'] - t0):+.2f} ms  R_c - R(t_c) {c['R_c'] - r0 + g.velocity * math.sin(g.squint) * (c['t_c'] - t0):+.2f} m"
        )
        for label in ("full", "mover", "mover@truth", "clutter"):
            if label not in c:
                continue
            r = c[label]
            print(
                f"    {label:12s} dv_a {r['v_a'] - vel[0]:+.3f}  pull {r['pull']:+.3f}  t_0 {1e3 * (r['t_0'] - t0):+.2f} ms"
                f"  R(t_0) err {r['R_0'] - r0 - (-g.velocity * math.sin(g.squint)) * (r['t_0'] - t0):+.2f} m"
                f"  af snr {10 * math.log10(r['snr']) if 0 < r['snr'] < math.inf else r['snr']:.1f}"
            )
        if "E_mover" in c:
            ka = 2 * (g.velocity * math.cos(g.squint)) ** 2 / (lam * r0)
            t_ill = 2 * g.half_band / ka
            inside = np.abs(g.out_times - c["full"]["t_0"]) <= t_ill / 2
            em, ec = c["E_mover"], c["E_clutter"]
            if not em[inside].sum() > 0:
                continue
            print(
                f"    clutter / mover energy in the autofocus cells: inside the illumination "
                f"{10 * math.log10(ec[inside].sum() / em[inside].sum()):+.1f} dB, outside "
                f"{10 * math.log10(ec[~inside].sum() / em[inside].sum()):+.1f} dB (of the mover's), T {t_ill:.3f} s"
            )


if __name__ == "__main__":
    main()
