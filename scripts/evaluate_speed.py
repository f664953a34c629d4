#!/usr/bin/env python3
"""Evaluate time against the time of the stage that made the image, before and after (issue 20 item 5).

Makes the products of the make targets' small configs through the command line (demo, paper 000's small
scene, paper 002's small scene through pfa2, paper 003's scene A-B-C and small scene, paper 004's cube, the two
backprojection scenes), then times, interleaved in one run, the focusing stage and ``sarproc evaluate``
of this tree and of a reference tree (``--reference``: a checkout of the code before), best of
``--repeats``, wall and CPU seconds (user + system of the command's process and its children); and compares the
two reports number by number (largest relative difference). Writes ``OUT/evaluate_speed.md`` and ``.json``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import resource
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any, TextIO

ROOT = Path(__file__).resolve().parents[1]
CFG = ROOT / "configs"

# name: (simulate config, [(stage command, config)], evaluate arguments beyond the image)
# case: (scene YAML, [(command, its config or None: the scene's)], extra evaluate arguments)
# (evaluate's arguments as the make target's: --expect; "{out}" is replaced by the case's output directory)
CASES: dict[str, tuple[str, list[tuple[str, str | None]], list[str]]] = {
    "demo": ("demo.yaml", [("backproject", "demo.yaml")], ["--expect", str(CFG / "demo_expect.yaml")]),
    # make demo's evaluate draws the figures too
    "demo --plot": (
        "demo.yaml",
        [("backproject", "demo.yaml")],
        ["--expect", str(CFG / "demo_expect.yaml"), "--plot", "{out}"],
    ),
    "000 small (fine-focus)": (
        "an2012_exp1_small.yaml",
        [("preprocess", "an2012_exp1_small.yaml"), ("coarse-focus", None), ("fine-focus", None)],
        [],
    ),
    "002 small (pfa2)": ("nie2016_small.yaml", [("pfa2", "nie2016_small.yaml")], []),
    # make reproduce-002-small's plain polar format image (its config with pfa2.method plain, as mk/002.mk's sed)
    "002 small plain (pfa2 plain)": ("nie2016_small.yaml", [("pfa2", "nie2016_small.yaml:plain")], []),
    "003 xu_scene (reconstruct, backproject)": (
        "xu_scene.yaml",
        [("reconstruct", "xu_scene.yaml"), ("backproject", "xu_scene.yaml")],
        ["--config", str(CFG / "xu_scene.yaml")],
    ),
    "003 xu_small (reconstruct, backproject)": (
        "xu_small.yaml",
        [("reconstruct", "xu_small.yaml"), ("backproject", "xu_small.yaml")],
        ["--config", str(CFG / "xu_small.yaml")],
    ),
    "004 du2010 cube (array3d)": ("du2010.yaml", [("array3d", "du2010.yaml")], []),
    "bp stripmap": (
        "bp_stripmap.yaml",
        [("backproject", "bp_stripmap.yaml")],
        ["--expect", str(CFG / "bp_expect.yaml")],
    ),
    "bp squint30": (
        "bp_squint30.yaml",
        [("backproject", "bp_squint30.yaml")],
        ["--expect", str(CFG / "bp_expect.yaml")],
    ),
    "bp beam_edge": (
        "bp_beam_edge.yaml",
        [("backproject", "bp_beam_edge.yaml")],
        ["--expect", str(CFG / "bp_beam_edge_expect.yaml")],
    ),
    "bp hamming": (
        "bp_hamming.yaml",
        [("backproject", "bp_hamming.yaml")],
        ["--expect", str(CFG / "bp_hamming_expect.yaml")],
    ),
    "004 du2010 BP cube (backproject)": ("du2010.yaml", [("backproject", "du2010.yaml")], []),
    # make reproduce-004's receiver 14 image before elevation compression (array3d --channel-image, with the cube)
    "004 receiver 14 (array3d)": ("du2010.yaml", [("array3d", "du2010.yaml")], []),
}
# a case whose evaluated image is a second output of its last stage: (that stage's extra arguments, "{second}"
# standing for the second output's path)
SECOND_OUTPUT = {"004 receiver 14 (array3d)": ["--channel-image", "14", "--channel-output", "{second}"]}


def stage_config(cfg: str, out: Path) -> Path:
    """The stage's config file; ``NAME:plain`` is NAME with ``method: two_step`` made plain (mk/002.mk's sed)."""
    name, _, variant = cfg.partition(":")
    if not variant:
        return CFG / name
    path = out / f"{name.removesuffix('.yaml')}_{variant}.yaml"
    text = re.sub(r"(?m)^( *)method: two_step *$", r"\1method: plain", (CFG / name).read_text())
    path.write_text(re.sub(r"\{ *method: two_step", "{method: plain", text))
    return path


def case_tag(name: str) -> str:
    """The case's file-name prefix ("demo --plot": demo_plot)."""
    return name.split(" (")[0].replace("--", "").replace(" ", "_")


def child_cpu() -> float:
    """User + system CPU seconds of this script's finished child processes so far."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def run(tree: Path, args: list, log: TextIO) -> tuple[float, float]:
    """One ``sarproc`` command with ``tree`` first on PYTHONPATH; (wall, CPU) seconds. Raises on failure."""
    env = dict(os.environ, PYTHONPATH=str(tree))
    cpu = child_cpu()
    start = time.perf_counter()
    proc = subprocess.run(
        [sys.executable, "-m", "sarproc", *map(str, args)],
        env=env,
        capture_output=True,
        text=True,
        cwd=tree,
        check=False,
    )
    wall = time.perf_counter() - start
    cpu = child_cpu() - cpu
    log.write(f"$ PYTHONPATH={tree} sarproc {' '.join(map(str, args))}  # {wall:.2f} s, CPU {cpu:.2f} s\n{proc.stderr}")
    if proc.returncode != 0:
        raise SystemExit(f"sarproc {' '.join(map(str, args))} failed ({proc.returncode}):\n{proc.stderr}")
    return wall, cpu


def floats(d: Any, prefix: str = "") -> Iterator[tuple[str, Any]]:
    """(path, value) of every leaf of a JSON report."""
    if isinstance(d, dict):
        for k, v in d.items():
            yield from floats(v, f"{prefix}/{k}")
    elif isinstance(d, list):
        for i, v in enumerate(d):
            yield from floats(v, f"{prefix}[{i}]")
    else:
        yield prefix, d


def largest_difference(a: dict, b: dict) -> tuple[float, str]:
    """Largest relative difference between two reports' numbers (inf where a key or a non-number differs)."""
    fa, fb = dict(floats(a)), dict(floats(b))
    if fa.keys() != fb.keys():
        return math.inf, "keys differ"
    worst, where = 0.0, ""
    for k, x in fa.items():
        y = fb[k]
        if isinstance(x, float) and isinstance(y, float):
            d = abs(x - y) / max(abs(x), abs(y), 1e-12)
        else:
            d = 0.0 if x == y else math.inf
        if d > worst:
            worst, where = d, k
    return worst, where


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reference", type=Path, required=True, help="checkout of the code before")
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "evaluate-speed")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--cases", nargs="*", default=list(CASES), help="subset of the cases")
    ap.add_argument("--reuse", action="store_true", help="keep the raw and intermediate products already in --out")
    args = ap.parse_args()
    out = args.out.resolve()
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    with open(out / "log.txt", "w") as log:
        products = {}
        for name in args.cases:
            scene, stages, _ = CASES[name]
            tag = case_tag(name)
            src = out / f"{tag}_raw.h5"
            if not (args.reuse and src.exists()):
                run(ROOT, ["simulate", CFG / scene, "-o", src, "--overwrite", "--no-progress"], log)
            chain = []
            for i, (cmd, cfg) in enumerate(stages):
                dst = out / f"{tag}_{i}_{cmd}.h5"
                # every stage reads its section of the scene's config unless given its own
                chain.append(
                    [cmd, src, "-o", dst, "--overwrite", "--no-progress", "--config", stage_config(cfg or scene, out)]
                )
                src = dst
            if name in SECOND_OUTPUT:
                src = out / f"{tag}_second.h5"
                chain[-1] += [a.replace("{second}", str(src)) for a in SECOND_OUTPUT[name]]
            for c in chain[:-1]:  # the inputs of the timed stage
                if not (args.reuse and Path(c[3]).exists()):
                    run(ROOT, c, log)
            if name in SECOND_OUTPUT and not src.exists():  # made by the timed stage, run once first
                run(ROOT, chain[-1], log)
            products[name] = (chain, src)
        for name in args.cases:
            chain, image = products[name]
            extra = [a.replace("{out}", str(out / f"{case_tag(name)}_plots")) for a in CASES[name][2]]
            stage: list[tuple[float, float]] = []
            before: list[tuple[float, float]] = []
            after: list[tuple[float, float]] = []
            for _ in range(args.repeats):  # interleaved: stage, evaluate before, evaluate after
                stage.append(run(ROOT, chain[-1], log))
                for times, tree, tag in ((before, args.reference.resolve(), "before"), (after, ROOT, "after")):
                    times.append(
                        run(
                            tree,
                            [
                                "evaluate",
                                image,
                                "-o",
                                out / f"{image.stem}_{tag}.json",
                                "--overwrite",
                                "--no-progress",
                                *extra,
                            ],
                            log,
                        )
                    )
            rep = [json.loads((out / f"{image.stem}_{t}.json").read_text()) for t in ("before", "after")]
            diff, where = largest_difference(*rep)
            rows.append(
                {
                    "case": name,
                    "stage": chain[-1][0],
                    "stage_s": min(w for w, _ in stage),
                    "evaluate_before_s": min(w for w, _ in before),
                    "evaluate_after_s": min(w for w, _ in after),
                    "spread_after_s": max(w for w, _ in after) - min(w for w, _ in after),
                    "stage_cpu_s": min(c for _, c in stage),
                    "evaluate_before_cpu_s": min(c for _, c in before),
                    "evaluate_after_cpu_s": min(c for _, c in after),
                    "largest_relative_difference": diff,
                    "where": where,
                }
            )
            print(rows[-1], flush=True)
    lines = [
        (
            f"Evaluate against the stage that made the image (best of {args.repeats} interleaved runs, wall seconds "
            f"of the subprocess, I/O and start-up included, and its CPU seconds, user + system; {os.cpu_count()} "
            f"cores, shared). Reference: {args.reference}."
        ),
        "",
        (
            "| product | stage | stage (s) | evaluate before (s) | evaluate after (s) | after / stage | speed-up | "
            "stage CPU (s) | evaluate CPU before (s) | after (s) | CPU after / stage | "
            "largest relative difference of the reports |"
        ),
        "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['case']} | {r['stage']} | {r['stage_s']:.2f} | {r['evaluate_before_s']:.2f} | "
            f"{r['evaluate_after_s']:.2f} | {r['evaluate_after_s'] / r['stage_s']:.2f} | "
            f"{r['evaluate_before_s'] / r['evaluate_after_s']:.2f} | {r['stage_cpu_s']:.2f} | "
            f"{r['evaluate_before_cpu_s']:.2f} | {r['evaluate_after_cpu_s']:.2f} | "
            f"{r['evaluate_after_cpu_s'] / r['stage_cpu_s']:.2f} | {r['largest_relative_difference']:.1e} "
            f"({r['where'] or '-'}) |"
        )
    (out / "evaluate_speed.md").write_text("\n".join(lines) + "\n")
    (out / "evaluate_speed.json").write_text(json.dumps(rows, indent=1))
    print("\n".join(lines))


if __name__ == "__main__":
    main()
