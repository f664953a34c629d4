"""Tabulate two folders of products made by two sarproc trees (issue 21): `make compare-products BASE=DIR`.

Reads only; processes nothing. Files are paired by name (BASE_DIR/x against NEW_DIR/x). For each HDF5
product: the signal (sarproc.product.io.read_product) as difference power over signal power in dB
(10 log10 sum|new - base|^2 / sum|base|^2; -inf: identical) and the largest difference over the largest
magnitude; every other dataset and attribute compared exactly (those that differ named; root 'history'
holds times and versions, so it is named apart). For each evaluate report (JSON): the largest absolute
difference of any number, per metric family (the last key of its path: irw, pslr_db, position, ...), and
any non-number that differs. For every file: whether the sha256 agree; other files (SICD, CPHD): the bytes
that differ. Prints Markdown.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from sarproc.cli.markdown import markdown_table
from sarproc.product.io import read_product


def sha256(path: Path) -> str:
    h = hashlib.sha256()
    with path.open("rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def difference_db(base: np.ndarray, new: np.ndarray) -> tuple[float, float]:
    """(difference power / signal power in dB, max |new - base| / max |base|), in float64."""
    a = np.asarray(base, dtype=np.complex128)
    d = np.asarray(new, dtype=np.complex128) - a
    err, sig = float(np.vdot(d, d).real), float(np.vdot(a, a).real)
    db = -math.inf if err == 0 else (math.inf if sig == 0 else 10 * math.log10(err / sig))
    peak = float(np.max(np.abs(a))) if a.size else 0.0
    return db, (float(np.max(np.abs(d))) / peak if peak else float(np.max(np.abs(d), initial=0.0)))


def _same(a: Any, b: Any) -> bool:
    try:
        return bool(np.array_equal(np.asarray(a), np.asarray(b)))
    except (TypeError, ValueError):
        return bool(a == b)


def hdf5_differences(base: Path, new: Path, signal: str) -> tuple[list[str], list[str]]:
    """(datasets other than the signal that differ, attributes that differ as 'object@name')."""
    dsets: list[str] = []
    attrs: list[str] = []
    with h5py.File(base, "r") as fa, h5py.File(new, "r") as fb:
        objs_a: dict[str, Any] = {"/": fa}
        objs_b: dict[str, Any] = {"/": fb}
        fa.visititems(lambda n, o: objs_a.__setitem__(n, o))
        fb.visititems(lambda n, o: objs_b.__setitem__(n, o))
        for name in sorted(set(objs_a) | set(objs_b)):
            if name not in objs_a or name not in objs_b:
                dsets.append(f"{name} (only in {'new' if name in objs_b else 'base'})")
                continue
            oa, ob = objs_a[name], objs_b[name]
            for key in sorted(set(oa.attrs) | set(ob.attrs)):
                if key in ("DIMENSION_LIST", "REFERENCE_LIST"):
                    continue
                if key not in oa.attrs or key not in ob.attrs or not _same(oa.attrs[key], ob.attrs[key]):
                    attrs.append(f"{name}@{key}")
            if isinstance(oa, h5py.Dataset) and name != signal and not _same(oa[()], ob[()]):
                dsets.append(name)
    return dsets, attrs


def _fmt_db(db: float) -> str:
    return "identical" if db == -math.inf else f"{db:.1f} dB"


def compare_hdf5(base: Path, new: Path) -> dict[str, Any]:
    pa, pb = read_product(base), read_product(new)
    with h5py.File(base, "r") as f:
        signal = next(n for n, o in f.items() if isinstance(o, h5py.Dataset) and o.dtype.kind == "c")
    row: dict[str, Any] = {"kind": pa.kind, "shape": "x".join(map(str, pa.data.shape))}
    if pa.data.shape != pb.data.shape:
        row["signal"] = f"shapes differ: {pa.data.shape} vs {pb.data.shape}"
        row["rel"] = ""
    else:
        db, rel = difference_db(pa.data, pb.data)
        row["signal"], row["rel"] = _fmt_db(db), f"{rel:.1e}"
    dsets, attrs = hdf5_differences(base, new, signal)
    row["datasets"] = ", ".join(dsets) or "none"
    other = [a for a in attrs if a != "/@history"]
    row["attrs"] = ", ".join(other) or ("history only" if attrs else "none")
    return row


def _leaves(x: Any, path: str = "") -> dict[str, Any]:
    if isinstance(x, dict):
        out: dict[str, Any] = {}
        for k, v in x.items():
            out.update(_leaves(v, f"{path}/{k}"))
        return out
    if isinstance(x, list):
        out = {}
        for i, v in enumerate(x):
            out.update(_leaves(v, f"{path}[{i}]"))
        return out
    return {path: x}


def _family(path: str) -> str:
    last = path.rsplit("/", 1)[-1]
    return last.split("[", 1)[0]


def compare_json(base: Path, new: Path) -> dict[str, Any]:
    la, lb = _leaves(json.loads(base.read_text())), _leaves(json.loads(new.read_text()))
    worst: dict[str, float] = {}
    other: list[str] = []
    n_numbers = n_moved = 0
    for key in sorted(set(la) | set(lb)):
        a, b = la.get(key, "<missing>"), lb.get(key, "<missing>")
        num = (int, float)
        if isinstance(a, num) and isinstance(b, num) and not isinstance(a, bool) and not isinstance(b, bool):
            fam = _family(key)
            worst[fam] = max(worst.get(fam, 0.0), abs(float(b) - float(a)))
            n_numbers += 1
            n_moved += a != b
        elif a != b and key != "/input":
            other.append(key)
    moved = {k: v for k, v in worst.items() if v > 0}
    return {
        "numbers": f"{n_moved} of {n_numbers}",
        "moved": ", ".join(f"{k} {v:.2g}" for k, v in sorted(moved.items(), key=lambda kv: -kv[1])) or "none",
        "other": ", ".join(other[:6]) + (f" (+{len(other) - 6})" if len(other) > 6 else "") or "none",
    }


def compare_bytes(base: Path, new: Path) -> str:
    a, b = base.read_bytes(), new.read_bytes()
    if len(a) != len(b):
        return f"sizes differ ({len(a)} vs {len(b)} bytes)"
    where = np.flatnonzero(np.frombuffer(a, np.uint8) != np.frombuffer(b, np.uint8))
    if not where.size:
        return f"all {len(a)} bytes equal"
    return f"{where.size} of {len(a)} bytes differ, at offsets {where[0]}..{where[-1]}"


PRODUCT_COLUMNS = (
    "product",
    "kind",
    "shape",
    "signal diff / signal",
    "max abs diff / max abs",
    "other datasets",
    "attributes",
    "sha256",
)
REPORT_COLUMNS = (
    "report",
    "numbers differing",
    "largest difference per metric family (absolute)",
    "other fields differing",
    "sha256",
)


def same_bytes(b: Path, a: Path) -> str:
    return "same" if sha256(b) == sha256(a) else "differ"


def product_row(base: Path, new: Path, name: str) -> list[str]:
    b, a = base / name, new / name
    if not a.exists():
        return [name, "missing in new"] + [""] * (len(PRODUCT_COLUMNS) - 2)
    r = compare_hdf5(b, a)
    return [name, r["kind"], r["shape"], r["signal"], r["rel"], r["datasets"], r["attrs"], same_bytes(b, a)]


def report_row(base: Path, new: Path, name: str) -> list[str]:
    b, a = base / name, new / name
    if not a.exists():
        return [name, "missing in new"] + [""] * (len(REPORT_COLUMNS) - 2)
    r = compare_json(b, a)
    return [name, str(r["numbers"]), r["moved"], r["other"], same_bytes(b, a)]


def file_row(base: Path, new: Path, name: str) -> list[str]:
    b, a = base / name, new / name
    if not a.exists():
        return [name, "missing in new", ""]
    return [name, compare_bytes(b, a), same_bytes(b, a)]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("base", type=Path, help="folder of the older tree's products")
    ap.add_argument("new", type=Path, help="folder of this tree's products (same file names)")
    args = ap.parse_args()
    names = sorted(p.name for p in args.base.iterdir() if p.is_file() and not p.name.endswith(".done.json"))
    h5 = [n for n in names if n.endswith(".h5")]
    js = [n for n in names if n.endswith(".json")]
    rest = [n for n in names if n not in h5 and n not in js]
    print(f"Products of `{args.new}` against `{args.base}` (scripts/compare_products.py).\n")
    print(markdown_table(PRODUCT_COLUMNS, [product_row(args.base, args.new, n) for n in h5]))
    print()
    print(markdown_table(REPORT_COLUMNS, [report_row(args.base, args.new, n) for n in js]))
    if rest:
        print()
        print(markdown_table(("file", "bytes", "sha256"), [file_row(args.base, args.new, n) for n in rest]))


if __name__ == "__main__":
    main()
