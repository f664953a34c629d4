"""HDF5 product I/O: the one place that reads and writes files (see ARCHITECTURE.md).

Writes are atomic: everything goes to a temporary file in the target directory that is
renamed over the output only when complete; on any error it is removed. An output that is
the input, or that exists without ``overwrite``, is refused before any work is done.
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import json
import os
import tempfile
from pathlib import Path

import h5py
import numpy as np

from sarproc import __version__
from sarproc.product.errors import InputError
from sarproc.product.metadata import FORMAT_VERSION, RadarMetadata
from sarproc.product.model import DATA_NAME, PRODUCT_KINDS, TARGET_DTYPE, UNITS, Product

LONG_NAMES = {"azimuth_time": "azimuth (slow) time from aperture centre", "range_time": "range (fast) time since transmit",
              "channel": "receive channel index", "azimuth": "azimuth position", "range": "range position",
              "elevation": "elevation angle"}


def history_entry(command: str, params: dict | None = None) -> dict:
    """One provenance record: command, version, UTC time and the resolved parameters."""
    return {"command": command, "sarproc_version": __version__,
            "utc": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
            "parameters": params or {}}


def check_output_path(output, inputs=(), overwrite: bool = False) -> Path:
    """Refuse to write over an input, or over an existing file without ``overwrite``."""
    out = Path(output)
    for inp in inputs:
        inp = Path(inp)
        if inp.exists() and out.exists() and os.path.samefile(inp, out):
            raise InputError(f"{out}: output is the input file; refusing to write over an input")
        if inp.resolve() == out.resolve():
            raise InputError(f"{out}: output is the input file; refusing to write over an input")
    if out.exists() and not overwrite:
        raise InputError(f"{out}: output exists; pass --overwrite to replace it")
    if out.exists() and out.is_dir():
        raise InputError(f"{out}: output is a directory")
    if not out.parent.exists():
        raise InputError(f"{out}: output directory {out.parent} does not exist")
    return out


@contextlib.contextmanager
def atomic_path(output: Path):
    """Yield a temporary path next to ``output``; rename it over ``output`` on success."""
    output = Path(output)
    fd, tmp = tempfile.mkstemp(prefix=f".{output.name}.", suffix=".tmp", dir=output.parent)
    os.close(fd)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)  # mkstemp's 0600 would hide outputs from other users
    try:
        yield Path(tmp)
        os.replace(tmp, output)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise


def _write_header(f: h5py.File, product_kind: str, radar: RadarMetadata, targets, history):
    f.attrs["product"] = product_kind
    f.attrs["sarproc_format"] = FORMAT_VERSION
    f.attrs["history"] = json.dumps(history)
    g = f.create_group("radar")
    for k, v in radar.to_attrs().items():
        g.attrs[k] = v
    t = np.asarray(targets, dtype=TARGET_DTYPE)
    dset = f.create_dataset("targets", data=t)
    # A labelled 'target' axis keeps netCDF readers (xarray/h5netcdf) from inventing phony dims.
    scale = f.create_dataset("target", data=np.arange(len(t), dtype=np.int64))
    scale.make_scale("target")
    dset.dims[0].attach_scale(scale)


def _write_scales(f: h5py.File, dset, dims, coords):
    for i, d in enumerate(dims):
        vals = np.asarray(coords[d])
        sc = f.create_dataset(d, data=vals.astype(np.float64) if d != "channel" else vals.astype(np.int64))
        sc.attrs["units"] = UNITS.get(d, "1")
        sc.attrs["long_name"] = LONG_NAMES.get(d, d)
        sc.make_scale(d)
        dset.dims[i].attach_scale(sc)
        dset.dims[i].label = d


def _chunks(shape):
    # About 4 MiB complex64 chunks, whole rows along the last axis.
    row = shape[-1]
    rows = max(1, min(int(np.prod(shape[:-1])), (4 << 20) // (8 * max(row, 1))))
    lead = [1] * (len(shape) - 1)
    if len(shape) >= 2:
        lead[-1] = min(shape[-2], rows)
    return tuple(lead) + (row,)


def _write_attrs(obj, attrs: dict):
    for k, v in attrs.items():
        if isinstance(v, (dict, list)) and not (isinstance(v, list) and v and isinstance(v[0], (int, float))):
            v = json.dumps(v)
        obj.attrs[k] = v


class ProductWriter:
    """Stream a product's data in blocks along its first non-channel axis, atomically.

    Use as a context manager; the file appears at ``output`` only if the block exits cleanly.
    """

    def __init__(self, output, kind, dims, coords, radar, targets, *, attrs=None, aux=None,
                 history=(), dtype=np.complex64, inputs=(), overwrite=False):
        if kind not in PRODUCT_KINDS:
            raise ValueError(f"unknown product kind {kind!r}")
        self.output = check_output_path(output, inputs, overwrite)
        self.kind, self.dims, self.coords = kind, tuple(dims), coords
        self.shape = tuple(len(coords[d]) for d in self.dims)
        self._args = (radar, targets, list(history), attrs or {}, aux or {}, dtype)

    def __enter__(self):
        self._ctx = atomic_path(self.output)
        tmp = self._ctx.__enter__()
        radar, targets, history, attrs, aux, dtype = self._args
        self.file = h5py.File(tmp, "w")
        _write_header(self.file, self.kind, radar, targets, history)
        self.dset = self.file.create_dataset(DATA_NAME[self.kind], shape=self.shape, dtype=dtype,
                                             chunks=_chunks(self.shape))
        _write_attrs(self.dset, attrs)
        _write_scales(self.file, self.dset, self.dims, self.coords)
        if aux:
            g = self.file.create_group("aux")
            for k, v in aux.items():
                g.create_dataset(k, data=np.asarray(v))
        return self

    def write(self, index, block):
        self.dset[index] = block

    def __exit__(self, exc_type, exc, tb):
        self.file.close()
        return self._ctx.__exit__(exc_type, exc, tb)


def write_product(output, product: Product, *, inputs=(), overwrite=False) -> Path:
    """Write ``product`` to ``output`` atomically."""
    with ProductWriter(output, product.kind, product.dims, product.coords, product.radar, product.targets,
                       attrs=product.attrs, aux=product.aux, history=product.history,
                       dtype=np.complex64 if np.iscomplexobj(product.data) else product.data.dtype,
                       inputs=inputs, overwrite=overwrite) as w:
        w.write(Ellipsis, product.data)
    return Path(output)


def _attr_value(v):
    if isinstance(v, bytes):
        v = v.decode()
    if isinstance(v, str) and v[:1] in "[{":
        try:
            return json.loads(v)
        except json.JSONDecodeError:
            return v
    if isinstance(v, np.generic):
        return v.item()
    if isinstance(v, np.ndarray) and v.ndim == 1 and v.dtype.kind in "fiu":
        return v.tolist()  # the same list an in-memory product carries
    return v


def read_product(path, kinds=None, *, load=True, check_finite=True) -> Product:
    """Read a product; see :func:`_read_product`. Low-level HDF5 errors become InputError."""
    try:
        return _read_product(path, kinds, load=load, check_finite=check_finite)
    except (OSError, RuntimeError, KeyError, TypeError) as exc:
        raise InputError(f"{path}: damaged or non-conforming product: {exc}") from None


def _read_product(path, kinds=None, *, load=True, check_finite=True) -> Product:
    """Read a product; ``kinds`` restricts the accepted product types (the error names them).

    With ``load=False`` only metadata is read: ``data`` is an empty array of the right dtype
    and ``attrs['shape']`` holds the stored shape (cheap inspection of big files).
    """
    path = Path(path)
    if not path.exists():
        raise InputError(f"{path}: file not found")
    if path.is_dir():
        raise InputError(f"{path}: is a directory, expected an HDF5 product")
    if not h5py.is_hdf5(path):
        raise InputError(f"{path}: not an HDF5 file")
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise InputError(f"{path}: cannot open as HDF5: {exc}") from None
    with f:
        kind = _attr_value(f.attrs.get("product"))
        if kind is None:
            raise InputError(f"{path}: missing root attribute 'product' (not a sarproc product)")
        if kind not in PRODUCT_KINDS:
            raise InputError(f"{path}: root attribute 'product' is {kind!r}, not a known product type")
        if kinds is not None and kind not in kinds:
            raise InputError(f"{path}: product type is {kind!r}; this stage needs {' or '.join(map(repr, kinds))}")
        fmt = _attr_value(f.attrs.get("sarproc_format"))
        if fmt is None:
            raise InputError(f"{path}: missing root attribute 'sarproc_format'")
        if str(fmt) != FORMAT_VERSION:
            raise InputError(f"{path}: sarproc_format {fmt!r} is not supported (expected {FORMAT_VERSION!r})")
        history = _attr_value(f.attrs.get("history", "[]"))
        if not isinstance(history, list):
            raise InputError(f"{path}: root attribute 'history' is not a JSON list")
        if "radar" not in f:
            raise InputError(f"{path}: missing group 'radar'")
        radar = RadarMetadata.from_attrs(f["radar"].attrs, where=f"{path}: radar")
        name = DATA_NAME[kind]
        if name not in f:
            raise InputError(f"{path}: missing dataset {name!r}")
        dset = f[name]
        dims, coords = [], {}
        for i, dim in enumerate(dset.dims):
            if len(dim) == 0:
                raise InputError(f"{path}: dataset {name!r} axis {i} has no dimension scale attached")
            scale = dim[0]
            dname = scale.name.lstrip("/")
            dims.append(dname)
            coords[dname] = scale[()]
        if "targets" not in f:
            raise InputError(f"{path}: missing dataset 'targets'")
        targets = np.asarray(f["targets"][()])
        missing = [n for n in TARGET_DTYPE.names if n not in (targets.dtype.names or ())]
        if missing:
            raise InputError(f"{path}: dataset 'targets' lacks field(s) {missing}")
        targets = targets.astype(TARGET_DTYPE)
        attrs = {k: _attr_value(v) for k, v in dset.attrs.items()
                 if k not in ("DIMENSION_LIST", "REFERENCE_LIST", "CLASS", "NAME")}
        aux = {k: v[()] for k, v in f["aux"].items()} if "aux" in f else {}
        if load:
            data = dset[()]
            if check_finite and not np.all(np.isfinite(data)):
                bad = int(np.count_nonzero(~np.isfinite(data)))
                raise InputError(f"{path}: dataset {name!r} contains {bad} NaN or Inf value(s)")
        else:
            data = np.empty((0,) * dset.ndim, dtype=dset.dtype)
            attrs["shape"] = dset.shape
    if not load:
        coords_l = {d: c for d, c in coords.items()}
        prod = Product.__new__(Product)
        prod.__dict__.update(kind=kind, data=data, dims=tuple(dims), coords=coords_l, radar=radar,
                             targets=targets, attrs=attrs, aux=aux, history=history)
        return prod
    return Product(kind=kind, data=data, dims=tuple(dims), coords=coords, radar=radar, targets=targets,
                   attrs=attrs, aux=aux, history=history)
