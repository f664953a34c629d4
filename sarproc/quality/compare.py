"""Two sets of products compared (`sarproc compare BASE NEW`): the same products made by two trees or settings.

Reads only. Files are paired by name (BASE/x against NEW/x). For each HDF5 product: the signal
(sarproc.product.io.read_product) as difference power over signal power in dB (10 log10 sum|new - base|^2 /
sum|base|^2; -inf: identical) and the largest difference over the largest magnitude; every other dataset and
attribute compared exactly (those that differ named; root 'history' holds times and versions, so it is named
apart). For each evaluate report (JSON): the largest absolute difference of any number, per metric family (the
last key of its path: irw, pslr_db, position, ...), and any non-number that differs. For each Markdown file (the
reproductions' summaries, evaluate's printed reports): its tables paired by header and their rows by first cell,
the cells that differ and the largest difference per numeric column. For every file: whether the sha256 agree;
other files (SICD, CPHD): the bytes that differ. The signal is read in blocks of rows, so a raw product of
several GB is compared in ~1 GB. Each ``*_row`` gives one row of its table (``*_COLUMNS``).
"""

from __future__ import annotations

import hashlib
import json
import math
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from sarproc.product.io import read_product
from sarproc.product.model import DATA_NAME

BLOCK_BYTES = 64 << 20  # complex64 input per block (x 6 in complex128 work arrays)
SKIPPED_SUFFIXES = (".done.json", ".png", ".log", ".yaml", ".yml")


def sha256(path: Path) -> str:
    h = hashlib.sha256()
    with path.open("rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def difference_sums(base: np.ndarray, new: np.ndarray) -> tuple[float, float, float, float]:
    """(sum |new - base|^2, sum |base|^2, max |new - base|, max |base|) in float64."""
    a = np.asarray(base, dtype=np.complex128)
    d = np.asarray(new, dtype=np.complex128) - a
    return (
        float(np.vdot(d, d).real),
        float(np.vdot(a, a).real),
        float(np.max(np.abs(d), initial=0.0)),
        float(np.max(np.abs(a), initial=0.0)),
    )


def _ratios(err: float, sig: float, dmax: float, peak: float) -> tuple[float, float]:
    db = -math.inf if err == 0 else (math.inf if sig == 0 else 10 * math.log10(err / sig))
    return db, (dmax / peak if peak else dmax)


def difference_db(base: np.ndarray, new: np.ndarray) -> tuple[float, float]:
    """(difference power / signal power in dB, max |new - base| / max |base|), in float64."""
    return _ratios(*difference_sums(base, new))


def dataset_difference_db(a: h5py.Dataset, b: h5py.Dataset) -> tuple[float, float]:
    """difference_db of two same-shaped datasets, read in blocks along the first axis."""
    row_bytes = max(1, int(np.prod(a.shape[1:], dtype=np.int64)) * a.dtype.itemsize)
    step = max(1, BLOCK_BYTES // row_bytes)
    err = sig = dmax = peak = 0.0
    for i in range(0, a.shape[0] if a.ndim else 1, step):
        sl = slice(i, i + step) if a.ndim else ()
        e, s_, d, p = difference_sums(a[sl], b[sl])
        err, sig, dmax, peak = err + e, sig + s_, max(dmax, d), max(peak, p)
    return _ratios(err, sig, dmax, peak)


def dataset_peak(a: h5py.Dataset) -> float:
    """max |a| in float64, read in blocks along the first axis."""
    row_bytes = max(1, int(np.prod(a.shape[1:], dtype=np.int64)) * a.dtype.itemsize)
    step = max(1, BLOCK_BYTES // row_bytes)
    peak = 0.0
    for i in range(0, a.shape[0] if a.ndim else 1, step):
        block = np.asarray(a[slice(i, i + step) if a.ndim else ()], dtype=np.complex128)
        peak = max(peak, float(np.max(np.abs(block), initial=0.0)))
    return peak


def peak_ratio_db(base_peak: float, new_peak: float) -> float:
    """20 log10(max |new| / max |base|): -inf where new is all zero, +inf where only base is."""
    if new_peak == 0:
        return -math.inf
    return math.inf if base_peak == 0 else 20 * math.log10(new_peak / base_peak)


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
            if isinstance(oa, h5py.Dataset) and name.lstrip("/") != signal and not _same(oa[()], ob[()]):
                dsets.append(name)
    return dsets, attrs


def _fmt_db(db: float) -> str:
    return "identical" if db == -math.inf else f"{db:.1f} dB"


def _fmt_rel(rel: float) -> str:
    return "0" if rel == 0 else f"{rel:.1e} ({20 * math.log10(rel):.1f} dB)"


def compare_hdf5(base: Path, new: Path) -> dict[str, Any]:
    kind = read_product(base, load=False).kind
    new_kind = read_product(new, load=False).kind  # a readable product of its own
    signal = DATA_NAME[kind]
    with h5py.File(base, "r") as fa, h5py.File(new, "r") as fb:
        sa = fa[signal]
        row: dict[str, Any] = {"kind": kind, "shape": "x".join(map(str, sa.shape))}
        if new_kind != kind:  # no common signal dataset (an image against its raw, ...)
            row["kind"] = f"{kind} vs {new_kind}"
            row["signal"] = f"kinds differ: {kind} vs {new_kind}"
            row["rel"] = ""
            row["signal_db"] = row["max_rel"] = row["peak_db"] = None
        elif sa.shape != (sb := fb[signal]).shape:
            row["signal"] = f"shapes differ: {sa.shape} vs {sb.shape}"
            row["rel"] = ""
            row["signal_db"] = row["max_rel"] = row["peak_db"] = None
        else:
            db, rel = dataset_difference_db(sa, sb)
            row["signal"], row["rel"] = _fmt_db(db), _fmt_rel(rel)
            row["signal_db"], row["max_rel"] = db, rel  # the numbers (-inf dB: identical)
            row["peak_db"] = peak_ratio_db(dataset_peak(sa), dataset_peak(sb))
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


def markdown_tables(text: str) -> dict[tuple[str, str, int], dict[str, list[str]]]:
    """The Markdown tables of ``text``: key (heading above, header row, n-th such table) -> first cell -> cells."""
    tables: dict[tuple[str, str, int], dict[str, list[str]]] = {}
    heading, lines, i = "", text.splitlines(), 0
    while i < len(lines):
        line = lines[i].strip()
        if line.startswith("#"):
            heading = line.lstrip("# ")
        if line.startswith("|") and i + 1 < len(lines) and set(lines[i + 1].strip()) <= set("|-: "):
            header = line
            rows: dict[str, list[str]] = {}
            i += 2
            while i < len(lines) and lines[i].strip().startswith("|"):
                cells = [c.strip() for c in lines[i].strip().strip("|").split("|")]
                rows[cells[0]] = cells
                i += 1
            n = sum(1 for k in tables if k[:2] == (heading, header))
            tables[(heading, header, n)] = rows
            continue
        i += 1
    return tables


def _number(cell: str) -> float | None:
    try:
        return float(cell.replace("−", "-").split()[0].rstrip("%"))
    except (ValueError, IndexError):
        return None


def compare_markdown(base: Path, new: Path) -> dict[str, str]:
    ta, tb = markdown_tables(base.read_text()), markdown_tables(new.read_text())
    cells = differ = 0
    worst: dict[str, float] = {}
    text: list[str] = []
    for key in sorted(set(ta) & set(tb)):
        header = [c.strip() for c in key[1].strip("|").split("|")]
        for first in sorted(set(ta[key]) & set(tb[key])):
            for col, (x, y) in enumerate(zip(ta[key][first], tb[key][first], strict=False)):
                cells += 1
                if x == y:
                    continue
                differ += 1
                name = header[col] if col < len(header) else str(col)
                nx, ny = _number(x), _number(y)
                if nx is not None and ny is not None:
                    worst[name] = max(worst.get(name, 0.0), abs(ny - nx))
                else:
                    text.append(f"{first} / {name}: {x!r} -> {y!r}")
    only = [f"{k[0] or '(top)'}: {k[1][:40]}" for k in sorted(set(ta) ^ set(tb))]
    rows_only = sum(len(set(ta[k]) ^ set(tb[k])) for k in set(ta) & set(tb))
    return {
        "tables": f"{len(set(ta) & set(tb))} paired, {len(only)} unpaired, {rows_only} unpaired rows",
        "cells": f"{differ} of {cells}",
        "moved": ", ".join(f"{k} {v:.3g}" for k, v in sorted(worst.items(), key=lambda kv: -kv[1])[:8]) or "none",
        "text": "; ".join(text[:4]) + (f" (+{len(text) - 4})" if len(text) > 4 else "") or "none",
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
    "max abs diff / max abs (dB of peak)",
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


def product_record(b: Path, a: Path, name: str) -> dict[str, Any]:
    """Row ``name`` of the products' table (``"row"``) with its signal figures as numbers: ``"signal_db"``
    (difference power / signal power, dB; -inf identical), ``"max_rel"`` (max |new - base| / max |base|) and
    ``"peak_db"`` (20 log10(max |new| / max |base|)), None where the product is missing in new or the shapes
    differ."""
    if not a.exists():
        row = [name, "missing in new"] + [""] * (len(PRODUCT_COLUMNS) - 2)
        return {"row": row, "signal_db": None, "max_rel": None, "peak_db": None}
    r = compare_hdf5(b, a)
    row = [name, r["kind"], r["shape"], r["signal"], r["rel"], r["datasets"], r["attrs"], same_bytes(b, a)]
    return {"row": row, "signal_db": r["signal_db"], "max_rel": r["max_rel"], "peak_db": r["peak_db"]}


def product_row(b: Path, a: Path, name: str) -> list[str]:
    """Row ``name`` of the products' table: HDF5 product ``b`` (base) against ``a`` (new)."""
    return list(product_record(b, a, name)["row"])


def report_row(b: Path, a: Path, name: str) -> list[str]:
    if not a.exists():
        return [name, "missing in new"] + [""] * (len(REPORT_COLUMNS) - 2)
    r = compare_json(b, a)
    return [name, str(r["numbers"]), r["moved"], r["other"], same_bytes(b, a)]


MARKDOWN_COLUMNS = (
    "tables (Markdown)",
    "tables",
    "cells differing",
    "largest difference per numeric column",
    "text cells differing",
)


def markdown_row(b: Path, a: Path, name: str) -> list[str]:
    if not a.exists():
        return [name, "missing in new"] + [""] * (len(MARKDOWN_COLUMNS) - 2)
    r = compare_markdown(b, a)
    return [name, r["tables"], r["cells"], r["moved"], r["text"]]


FILE_COLUMNS = ("file", "bytes", "sha256")


def file_row(b: Path, a: Path, name: str) -> list[str]:
    if not a.exists():
        return [name, "missing in new", ""]
    return [name, compare_bytes(b, a), same_bytes(b, a)]


# each table: its columns and rows, by the files' suffix (anything else: the files' bytes)
TABLES = {
    "h5": (PRODUCT_COLUMNS, product_row),
    "json": (REPORT_COLUMNS, report_row),
    "md": (MARKDOWN_COLUMNS, markdown_row),
    "other": (FILE_COLUMNS, file_row),
}


def table_of(name: str) -> str:
    """The table file ``name`` goes in (a key of TABLES)."""
    suffix = name.rsplit(".", 1)[-1] if "." in Path(name).name else ""
    return suffix if suffix in TABLES else "other"


def paired_names(base: Path) -> list[str]:
    """The files below ``base`` (paths relative to it), figures, logs, YAML and sweep stamps skipped."""
    return sorted(
        p.relative_to(base).as_posix() for p in base.rglob("*") if p.is_file() and not p.name.endswith(SKIPPED_SUFFIXES)
    )
