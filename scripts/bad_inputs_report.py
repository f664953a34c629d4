"""Counts of the bad-input suite (issue 12): runs every case of tests/cli/test_bad_inputs.py
outside pytest and prints one table, plus the cases that fall short.

    .venv/bin/python scripts/bad_inputs_report.py
"""

from __future__ import annotations

import collections
import importlib.util
import re
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def load_suite():
    sys.path.insert(0, str(ROOT / "tests"))
    spec = importlib.util.spec_from_file_location("bad_inputs", ROOT / "tests" / "cli" / "test_bad_inputs.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


# An expected string that is a YAML key path, an HDF5 item, an attribute or an option
KEYLIKE = re.compile(
    r"[a-z_]\.[a-z_]|'[^']+'|--[a-z]|aux/|radar|targets|signal|image|azimuth_time|range_time|"
    r"theoretical_irw|n_channels|frame|reference|acquisition|effects|geometry|platform|backproject|line \d"
)


def names_key(must) -> bool:
    return any(KEYLIKE.search(m) for m in must if not re.search(r"\.(yaml|h5|json)$", m))


def main() -> int:
    suite = load_suite()
    start = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        (Path(tmp) / "products").mkdir()
        products = suite.build_products(Path(tmp) / "products")
        results = []
        for i, name in enumerate(sorted(suite.CASES)):
            case_dir = Path(tmp) / f"case{i}"
            case_dir.mkdir()
            results.append(suite.run_case(name, case_dir, products))
    wall = time.perf_counter() - start
    families = collections.Counter(r["name"].split("-")[0] for r in results)
    rows = [
        ("cases", len(results)),
        ("  by family", ", ".join(f"{k} {v}" for k, v in sorted(families.items()))),
        ("expected exit code", sum(r["code"] == r["want_code"] for r in results)),
        ("exit 2", sum(r["code"] == 2 for r in results)),
        ("exit 2 with every expected string in the message", sum(r["code"] == 2 and not r["missing"] for r in results)),
        (
            "exit 2 whose message names one of the files on the command line",
            sum(r["code"] == 2 and r["file_named"] for r in results),
        ),
        ("  those that do not (usage errors)", ", ".join(r["name"] for r in results if not r["file_named"])),
        (
            "exit 2 naming the key / HDF5 item / option as well (checked string)",
            sum(r["code"] == 2 and not r["missing"] and names_key(r["must"]) for r in results),
        ),
        (
            "  cases with no key to name (file-level: missing, directory, binary, syntax, output place)",
            ", ".join(r["name"] for r in results if not names_key(r["must"])),
        ),
        ("one-line message", sum(r["one_line"] for r in results)),
        ("tracebacks", sum(r["traceback"] for r in results)),
        ("silent accepts (exit 0)", sum(r["silent_accept"] for r in results)),
        ("leftover files", sum(bool(r["leftovers"]) for r in results)),
        ("inputs modified", sum(bool(r["inputs_modified"]) for r in results)),
        ("crashes (uncaught exception)", sum(r["traceback"] and r["code"] not in (1, 2) for r in results)),
        ("wall time, s", f"{wall:.1f}"),
    ]
    print("| count | value |\n|---|---|")
    for k, v in rows:
        print(f"| {k} | {v} |")
    bad = [
        r
        for r in results
        if r["code"] != r["want_code"]
        or r["missing"]
        or r["traceback"]
        or r["leftovers"]
        or r["inputs_modified"]
        or not r["one_line"]
    ]
    for r in bad:
        print(
            f"\nFALLS SHORT {r['name']}: exit {r['code']} (want {r['want_code']}), missing {r['missing']}, "
            f"leftovers {r['leftovers']}, modified {r['inputs_modified']}\n{r['output']}"
        )
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
