"""How close each stage's up-front plan (sarproc STAGE ... --dry-run) comes to what the run then takes.

For every shipped scene config (configs/*.yaml, sweeps excluded) the chain that the reproduction
targets run (simulate, then the config's focusing stages, then evaluate and quicklook; the config variants on
their base scene's raw product; Gotcha from its files; the SICD/CPHD round trip on the demo) is
run stage by stage in subprocesses. Each stage is first run with --dry-run (its plan; the script
checks that nothing was written), then for real, and the plan is set against the measured output
size, the process's peak RSS (VmHWM, interpreter and libraries included, as the plan counts
them) and its wall time (imports included). With --repeat N a stage is run up to N times and the
best (lowest) wall time kept: time on a shared machine only gets longer with load, never shorter.

    .venv/bin/python scripts/plan_accuracy.py [--small | CHAIN ...] [--out DIR] [--repeat N] [--markdown FILE]

Ratios are plan / measured; the aim is every ratio within [0.5, 2].
"""

from __future__ import annotations

import argparse
import datetime
import os
from collections.abc import Callable, Iterable
from pathlib import Path

from sarproc.cli.plan_check import SMALL, all_chains, chain, run_stage, within

ROOT = Path(__file__).resolve().parents[1]
CONFIGS = ROOT / "configs"
GOTCHA = Path(os.environ.get("GOTCHA_DIR", ROOT.parent / "shared" / "data" / "gotcha"))


def measure(names: Iterable[str], out: Path, repeat: int = 1, log: Callable[[str], object] = print) -> list[dict]:
    rows = []
    for name in names:
        for args in chain(name, out, CONFIGS, GOTCHA):
            row = {"config": name, **run_stage(args, repeat, accept=within, cwd=ROOT)}
            rows.append(row)
            log(line(row))
            if "refused" in row:
                break
    return rows


def line(r: dict) -> str:
    if "rss" not in r:
        return f"| {r['config']} | {r['stage']} | refused: {r.get('refused', '')} | | | | | |"
    return (
        f"| {r['config']} | {r['stage']} | {r['plan_out'] / 1e6:.3g} / {r['out'] / 1e6:.3g} MB | "
        f"{r['plan_mem'] / 1e6:.3g} / {r['rss'] / 1e6:.3g} MB | {r['plan_mem'] / r['rss']:.2f} | "
        f"{r['plan_s']:.3g} / {r['wall']:.3g} s (CPU {r['cpu']:.3g} s) | {r['plan_s'] / r['wall']:.2f} | "
        f"{'yes' if within(r) else 'NO'} |"
    )


HEAD = (
    "| config | stage | output plan / actual | peak memory plan / RSS | ratio | time plan / wall (best) | ratio "
    "| within 2x |\n|---|---|---|---|---|---|---|---|"
)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("chains", nargs="*", help=f"configs to run (default: all: {', '.join(all_chains(CONFIGS))})")
    ap.add_argument("--small", action="store_true", help=f"the tests' configs: {', '.join(SMALL)}")
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "plan-accuracy")
    ap.add_argument("--repeat", type=int, default=3, help="real runs per stage at most (best wall time kept)")
    ap.add_argument("--markdown", type=Path, default=None, help="also write the table to this file")
    a = ap.parse_args()
    names = a.chains or (list(SMALL) if a.small else all_chains(CONFIGS))
    a.out.mkdir(parents=True, exist_ok=True)
    print(HEAD)
    rows = measure(names, a.out, a.repeat)
    wrote = [r for r in rows if r.get("dry_run_wrote")]
    bad = [r for r in rows if "rss" in r and not within(r)]
    refused = [r for r in rows if "rss" not in r]
    summary = (
        f"{len(rows) - len(refused)} stages measured, {len(bad)} outside 2x, {len(refused)} refused; "
        f"--dry-run wrote an output: {len(wrote)}"
    )
    print(summary)
    if a.markdown:
        when = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
        table = (
            f"{START}\n<!-- scripts/plan_accuracy.py --repeat {a.repeat} {' '.join(names)}: {when}, "
            f"{os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f} at the end -->\n\n{HEAD}\n"
            + "\n".join(line(r) for r in rows)
            + f"\n\n{summary}\n{END}"
        )
        text = a.markdown.read_text() if a.markdown.exists() else ""
        if START in text and END in text:  # the table replaces the previous one; the prose stays
            text = text[: text.index(START)] + table + text[text.index(END) + len(END) :]
        else:
            text = table + "\n"
        a.markdown.write_text(text)


START, END = "<!-- plan table: start -->", "<!-- plan table: end -->"


if __name__ == "__main__":
    main()
