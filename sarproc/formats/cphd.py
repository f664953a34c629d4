"""Raw phase history to CPHD 1.1.0 (NGA.STND.0068) through NGA's sarkit, and back.

Export (single-channel monostatic ``raw`` products): each pulse is taken to the CPHD FX domain, the
compensated phase history of the standard: its range spectrum on the full FFT grid of the range
compression (N = next_fast_len(n_range + replica length) bins at f_s / N) divided by the chirp's
spectrum (deramp), referenced to the start of its receive window, and compensated to the scene
reference point (SRP = scene centre) so that a scatterer at the SRP has the same phase at every
frequency:

    S(f) = X(f_b) / H(f_b) * exp(-j 2 pi f_b t_start) * exp(+j 2 pi f tau_srp),   f = f_c + f_b

For an echo inside its window X / H = A exp(-j 2 pi f tau), so S = A exp(-j 2 pi f (tau - tau_srp)),
the CPHD signal model. FX1/FX2 (f_c -+ B/2) mark the transmitted band; the samples outside it are
kept so that import inverts export exactly: X = S * H * (the two phases)^-1 and the raw pulse is the
first n_range samples of the inverse FFT. TOA1/TOA2 are the receive window relative to tau_srp.
Platform positions (ECF through geolocation.py) are used for transmit and receive alike (the
simulator's stop-and-go model). sarproc's own metadata (radar, targets, frame) travels in
ProductInfo/Parameter entries named ``sarproc.*`` so that a round trip is lossless; a CPHD written by
another program is imported from its standard fields alone (:func:`_foreign_raw`).
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
from collections.abc import Sequence
from typing import Any

import numpy as np

from sarproc import __version__
from sarproc.dsp.rangecomp import replica_fft_size, replica_spectrum
from sarproc.formats.geolocation import Placement, ecf_to_geodetic, utc_datetime
from sarproc.formats.sicd import (
    MODE_TYPE,
    consistency_checker,
    consistency_summary,
    pulse_times,
    require_sarkit,
    run_checks,
)
from sarproc.product import fft as sfft
from sarproc.product.errors import InputError
from sarproc.product.metadata import C, RadarMetadata
from sarproc.product.model import TARGET_DTYPE, TARGET_NAMES, TARGET_THEORY_FIELDS, Product

CPHD_NS = "http://api.nsgreg.nga.mil/schema/cphd/1.1.0"
CHANNEL = "sarproc-channel-1"
IMPORT_OVERSAMPLING = 1.25  # sampling rate over band of a pulse imported from another program's CPHD


def _targets_to_json(targets: np.ndarray) -> list:
    out = []
    for t in targets:
        row = {}
        for name in TARGET_NAMES:
            v = t[name]
            row[name] = (
                v.decode()
                if isinstance(v, bytes)
                else [float(v.real), float(v.imag)]
                if np.iscomplexobj(v)
                else float(v)
            )
        out.append(row)
    return out


def _targets_from_json(rows: list) -> np.ndarray:
    t = np.zeros(len(rows), TARGET_DTYPE)
    for i, row in enumerate(rows):
        for name in TARGET_NAMES:
            v = row.get(name, 0.0) if name in TARGET_THEORY_FIELDS else row[name]  # theory: absent in older files
            t[i][name] = v.encode() if name == "name" else complex(*v) if name == "amplitude" else v
    return t


def _cycles_phasor(cycles: np.ndarray) -> np.ndarray:
    """exp(j 2 pi cycles) with the integer part removed in float64 first."""
    return np.exp(2j * np.pi * (cycles - np.floor(cycles)))


def to_cphd_signal(
    signal: np.ndarray, radar: RadarMetadata, t_start: np.ndarray, tau_srp: np.ndarray, n_fft: int
) -> np.ndarray:
    """(n_pulses, n_range) raw -> (n_pulses, n_fft) FX-domain CPHD signal (frequency ascending), complex64."""
    fb = (np.arange(n_fft) - n_fft // 2) * (radar.range_sampling_rate / n_fft)
    h = np.fft.fftshift(replica_spectrum(radar, n_fft))
    x = np.fft.fftshift(sfft.fft(signal, n=n_fft, axis=-1, workers=-1), axes=-1)
    cycles = -fb[None, :] * t_start[:, None] + (radar.carrier_frequency + fb)[None, :] * tau_srp[:, None]
    return (x / h * _cycles_phasor(cycles)).astype(np.complex64)


def from_cphd_signal(
    fx: np.ndarray, radar: RadarMetadata, t_start: np.ndarray, tau_srp: np.ndarray, n_range: int
) -> np.ndarray:
    """Inverse of :func:`to_cphd_signal`: (n_pulses, n_fft) -> (n_pulses, n_range) raw, complex64."""
    n_fft = fx.shape[-1]
    fb = (np.arange(n_fft) - n_fft // 2) * (radar.range_sampling_rate / n_fft)
    h = np.fft.fftshift(replica_spectrum(radar, n_fft))
    cycles = fb[None, :] * t_start[:, None] - (radar.carrier_frequency + fb)[None, :] * tau_srp[:, None]
    x = np.asarray(fx, complex) * h * _cycles_phasor(cycles)
    return sfft.ifft(np.fft.ifftshift(x, axes=-1), axis=-1, workers=-1)[:, :n_range].astype(np.complex64)


def _pvp_layout(names_sizes: Sequence[tuple[str, int]]) -> tuple[dict, np.dtype, int]:
    """PVP XML entries and the matching dtype (8-byte words, in order)."""
    offset, xml, fields = 0, {}, []
    for name, size in names_sizes:
        xml[name] = {"Offset": offset, "Size": size, "dtype": np.dtype(("f8", (3,))) if size == 3 else np.dtype("f8")}
        fields.append((name, ">f8", (3,)) if size == 3 else (name, ">f8"))
        offset += size
    return xml, np.dtype(fields), offset * 8


PVP_FIELDS = [
    ("TxTime", 1),
    ("TxPos", 3),
    ("TxVel", 3),
    ("RcvTime", 1),
    ("RcvPos", 3),
    ("RcvVel", 3),
    ("SRPPos", 3),
    ("aFDOP", 1),
    ("aFRR1", 1),
    ("aFRR2", 1),
    ("FX1", 1),
    ("FX2", 1),
    ("TOA1", 1),
    ("TOA2", 1),
    ("TDTropoSRP", 1),
    ("SC0", 1),
    ("SCSS", 1),
]


def _check_exportable(raw: Product) -> None:
    """CPHD export writes one monostatic channel of raw pulses."""
    if raw.kind != "raw" or raw.dims != ("azimuth_time", "range_time"):
        raise InputError(f"CPHD export handles single-channel raw products; got {raw.kind} {raw.dims}")
    for key in ("tx_offset", "rx_offset"):
        if np.any(np.asarray(raw.aux.get(key, 0.0)) != 0):
            raise InputError(f"CPHD export: aux/{key} is not zero; only monostatic raw data are exported")


def _signal_and_pvps(raw: Product, place: Placement) -> tuple[np.ndarray, np.ndarray]:
    """The FX-domain signal array (n_pulses, n_fft) complex64 and its per-vector parameters (PVP_FIELDS):
    platform state, the scene reference point (SRP) and each pulse's saved frequencies and times of arrival."""
    r = raw.radar
    t = pulse_times(raw)
    n_pulses, n_range = raw.data.shape
    fs = r.range_sampling_rate
    gate = np.asarray(raw.aux.get("range_gate_offset", np.zeros(n_pulses)), float)
    t_start = float(raw.coords["range_time"][0]) + gate
    pos = place.to_ecf(raw.aux["platform_position"])
    vel = np.gradient(pos, t, axis=0) if n_pulses > 1 else place.vector_to_ecf([r.velocity, 0, 0])[None]
    srp = place.to_ecf(np.asarray(r.scene_center, float))
    tau_srp = 2 * np.linalg.norm(pos - srp, axis=1) / C
    n_fft = replica_fft_size(r, n_range)
    signal = to_cphd_signal(raw.data, r, t_start, tau_srp, n_fft)
    fb0 = -(n_fft // 2) * fs / n_fft

    _, pvp_dtype, _ = _pvp_layout(PVP_FIELDS)
    pvps = np.zeros(n_pulses, pvp_dtype)
    tx_time = t - t[0]  # CPHD times run from the collection start
    pvps["TxTime"], pvps["TxPos"], pvps["TxVel"] = tx_time, pos, vel
    pvps["RcvTime"], pvps["RcvPos"], pvps["RcvVel"] = tx_time + tau_srp, pos, vel
    pvps["SRPPos"] = srp
    u = (pos - srp) / np.linalg.norm(pos - srp, axis=1, keepdims=True)
    pvps["aFDOP"] = -2.0 / C * np.sum(vel * u, axis=1)  # rdot of the SRP, both ways (CPHD 1.1 eq.)
    pvps["FX1"], pvps["FX2"] = r.carrier_frequency - r.bandwidth / 2, r.carrier_frequency + r.bandwidth / 2
    pvps["TOA1"], pvps["TOA2"] = t_start - tau_srp, t_start + (n_range - 1) / fs - tau_srp
    pvps["SC0"], pvps["SCSS"] = r.carrier_frequency + fb0, fs / n_fft
    return signal, pvps


def _channel_blocks(r: RadarMetadata, pvps: np.ndarray, n_fft: int, n_range: int) -> dict[str, Any]:
    """CPHD's Data, Channel, PVP, Dwell and TxRcv blocks of the one channel (radar.polarization 'H:V', else
    CPHD's UNSPECIFIED)."""
    n_pulses = len(pvps)
    toa1, toa2 = pvps["TOA1"], pvps["TOA2"]
    toa_fixed = bool(np.all(toa1 == toa1[0]) and np.all(toa2 == toa2[0]))
    pvp_xml, _, pvp_bytes = _pvp_layout(PVP_FIELDS)
    tx_pol, rcv_pol = r.polarization.split(":") if r.polarization else ("UNSPECIFIED", "UNSPECIFIED")
    fs = r.range_sampling_rate
    channel = {
        "Identifier": CHANNEL,
        "RefVectorIndex": n_pulses // 2,
        "FXFixed": True,
        "TOAFixed": toa_fixed,
        "SRPFixed": True,
        "Polarization": {"TxPol": tx_pol, "RcvPol": rcv_pol},
        "FxC": r.carrier_frequency,
        "FxBW": r.bandwidth,
        "TOASaved": float(toa2.max() - toa1.min()),
        "DwellTimes": {"CODId": "cod", "DwellId": "dwell"},
        "TxRcv": {"TxWFId": ["tx"], "RcvId": ["rcv"]},
    }
    tx = {
        "Identifier": "tx",
        "PulseLength": r.pulse_duration,
        "RFBandwidth": r.bandwidth,
        "FreqCenter": r.carrier_frequency,
        "LFMRate": r.chirp_rate,
        "Polarization": tx_pol,
    }
    rcv = {
        "Identifier": "rcv",
        "WindowLength": n_range / fs,
        "SampleRate": fs,
        "IFFilterBW": fs,
        "FreqCenter": r.carrier_frequency,
        "Polarization": rcv_pol,
    }
    array = {
        "Identifier": CHANNEL,
        "NumVectors": n_pulses,
        "NumSamples": n_fft,
        "SignalArrayByteOffset": 0,
        "PVPArrayByteOffset": 0,
    }
    return {
        "Data": {
            "SignalArrayFormat": "CF8",
            "NumBytesPVP": pvp_bytes,
            "NumCPHDChannels": 1,
            "Channel": [array],
            "NumSupportArrays": 0,
        },
        "Channel": {
            "RefChId": CHANNEL,
            "FXFixedCPHD": True,
            "TOAFixedCPHD": toa_fixed,
            "SRPFixedCPHD": True,
            "Parameters": [channel],
        },
        "PVP": pvp_xml,
        "TxRcv": {"NumTxWFs": 1, "TxWFParameters": [tx], "NumRcvs": 1, "RcvParameters": [rcv]},
    }


def _sarproc_parameters(raw: Product, place: Placement) -> dict[str, str]:
    """ProductInfo parameters that let import invert export exactly (radar, targets, frame, time origins)."""
    return {
        "sarproc.radar": raw.radar.to_json(),
        "sarproc.targets": json.dumps(_targets_to_json(raw.targets)),
        "sarproc.frame": json.dumps(raw.attrs.get("frame")),
        "sarproc.azimuth_time0": repr(float(pulse_times(raw)[0])),
        "sarproc.range_time0": repr(float(raw.coords["range_time"][0])),
        "sarproc.placement": json.dumps({"anchor": place.anchor.tolist(), "heading": place.heading}),
        "sarproc.history": json.dumps(raw.history),
    }


def cphd_parts(raw: Product, place: Placement, sarproc_metadata: bool = True) -> tuple[Any, np.ndarray, np.ndarray]:
    """(xml tree, signal (n_pulses, n_fft) complex64, pvps) of a raw product.

    ``sarproc_metadata=False`` leaves out the ``sarproc.*`` parameters (a file as another program would see it).
    """
    import lxml.etree
    import sarkit.cphd as skcphd

    _check_exportable(raw)
    r = raw.radar
    t = pulse_times(raw)
    signal, pvps = _signal_and_pvps(raw, place)
    tx_time = pvps["TxTime"]
    ia = _image_area(raw, place)
    lat, lon, h = place.lat_lon_height
    channel = _channel_blocks(r, pvps, signal.shape[1], raw.data.shape[1])

    root = skcphd.ElementWrapper(lxml.etree.Element(f"{{{CPHD_NS}}}CPHD"))
    root["CollectionID"] = {
        "CollectorName": "sarproc simulator",
        "CoreName": "sarproc_raw",
        "CollectType": "MONOSTATIC",
        "RadarMode": {"ModeType": MODE_TYPE.get(r.mode, "SPOTLIGHT")},
        "Classification": "UNCLASSIFIED",
        "ReleaseInfo": "UNRESTRICTED",
    }
    root["Global"] = {
        "DomainType": "FX",
        "SGN": -1,
        "Timeline": {
            "CollectionStart": utc_datetime(place.datetime64(float(t[0]))),
            "TxTime1": float(tx_time[0]),
            "TxTime2": float(tx_time[-1]),
        },
        "FxBand": {"FxMin": float(pvps["FX1"][0]), "FxMax": float(pvps["FX2"][0])},
        "TOASwath": {"TOAMin": float(pvps["TOA1"].min()), "TOAMax": float(pvps["TOA2"].max())},
    }
    root["SceneCoordinates"] = {
        "EarthModel": "WGS_84",
        "IARP": {"ECF": place.origin_ecf, "LLH": np.array([math.degrees(lat), math.degrees(lon), h])},
        "ReferenceSurface": {"Planar": {"uIAX": place.rotation[:, 0], "uIAY": place.rotation[:, 1]}},
        "ImageArea": {"X1Y1": ia[0], "X2Y2": ia[1]},
        "ImageAreaCornerPoints": _corner_points(place, ia),
        "ImageGrid": _image_grid(ia, C / (2 * r.bandwidth) / 1.5),
    }
    root["Data"] = channel["Data"]
    root["Channel"] = channel["Channel"]
    root["PVP"] = channel["PVP"]
    root["Dwell"] = {
        "NumCODTimes": 1,
        "CODTime": [{"Identifier": "cod", "CODTimePoly": np.array([[float(-t[0])]])}],  # aperture centre
        "NumDwellTimes": 1,
        "DwellTime": [{"Identifier": "dwell", "DwellTimePoly": np.array([[float(tx_time[-1])]])}],
    }
    root["TxRcv"] = channel["TxRcv"]
    root["ProductInfo"] = {
        "CreationInfo": [
            {"Application": f"sarproc {__version__}", "DateTime": utc_datetime(np.datetime64("now", "us"))}
        ]
    }
    if sarproc_metadata:
        root["ProductInfo"]["Parameter"] = list(_sarproc_parameters(raw, place).items())
    assert root.elem is not None
    tree = root.elem.getroottree()
    # ReferenceGeometry from the PVPs, as sarkit's checker recomputes it (CPHD vol. 1, 6.5)
    refgeom = skcphd.compute_reference_geometry(tree, pvps)
    tree.getroot().find(f"{{{CPHD_NS}}}Dwell").addnext(refgeom)
    return tree, signal, pvps


def _image_area(raw: Product, place: Placement) -> tuple[np.ndarray, np.ndarray]:
    """Image area (m, in the IA frame about the scene centre): the targets' span plus 100 m."""
    if len(raw.targets):
        xy = np.stack([raw.targets["x"], raw.targets["y"]], 1) - np.asarray(raw.radar.scene_center)[:2]
        lo, hi = xy.min(0) - 100.0, xy.max(0) + 100.0
    else:
        lo, hi = np.array([-100.0, -100.0]), np.array([100.0, 100.0])
    return lo, hi


def _image_grid(ia: tuple[np.ndarray, np.ndarray], spacing: float) -> dict:
    """A regular grid over the image area (IARP at line 0, sample 0), 1.5 samples per slant resolution."""
    (x1, y1), (x2, y2) = ia
    # cell k spans ((k - 0.5) d, (k + 0.5) d): the first and last cells hold the area's edges
    first_line, end_line = round(x1 / spacing + 0.5), round(x2 / spacing + 0.5)
    first_sample, end_sample = round(y1 / spacing + 0.5), round(y2 / spacing + 0.5)
    return {
        "IARPLocation": np.array([0.0, 0.0]),
        "IAXExtent": {"LineSpacing": spacing, "FirstLine": first_line, "NumLines": end_line - first_line},
        "IAYExtent": {"SampleSpacing": spacing, "FirstSample": first_sample, "NumSamples": end_sample - first_sample},
    }


def _corner_points(place: Placement, ia: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    (x1, y1), (x2, y2) = ia
    pts = []
    for x, y in ((x1, y1), (x1, y2), (x2, y2), (x2, y1)):
        ecf = place.origin_ecf + x * place.rotation[:, 0] + y * place.rotation[:, 1]
        pts.append(np.degrees(ecf_to_geodetic(ecf)[:2]))
    return np.array(pts)


def write_cphd(path: str | os.PathLike, raw: Product, place: Placement, sarproc_metadata: bool = True) -> dict:
    """Write a raw product as a CPHD file (atomically); returns sizes for the summary."""
    require_sarkit()
    import sarkit.cphd as skcphd

    from sarproc.product.io import atomic_path

    tree, signal, pvps = cphd_parts(raw, place, sarproc_metadata)
    meta = skcphd.Metadata(
        xmltree=tree,
        file_header_part=skcphd.FileHeaderPart(
            additional_kvps={"CLASSIFICATION": "UNCLASSIFIED", "RELEASE_INFO": "UNRESTRICTED"}
        ),
    )
    with atomic_path(path) as tmp, open(tmp, "wb") as fh, skcphd.Writer(fh, meta) as writer:
        writer.write_signal(CHANNEL, signal)
        writer.write_pvp(CHANNEL, pvps)
    return {"vectors": signal.shape[0], "samples": signal.shape[1]}


def _params(tree: Any) -> dict:
    return {p.get("name"): p.text for p in tree.getroot().findall("{*}ProductInfo/{*}Parameter")}


def read_cphd(path: str | os.PathLike) -> Product:
    """A raw product from a CPHD file (first channel; FX domain, or TOA domain from other programs)."""
    require_sarkit()
    import sarkit.cphd as skcphd

    try:
        with open(path, "rb") as fh, skcphd.Reader(fh) as reader:
            tree = reader.metadata.xmltree
            ch = tree.getroot().findtext("{*}Data/{*}Channel/{*}Identifier")
            fx, pvps = reader.read_channel(ch)
    except (OSError, ValueError, KeyError, RuntimeError) as exc:
        raise InputError(f"{path}: cannot read as CPHD: {exc}") from None
    xh = skcphd.XmlHelper(tree)
    domain = xh.load("{*}Global/{*}DomainType")
    extra = _params(tree)
    if domain != "FX" and "sarproc.radar" in extra:
        raise InputError(f"{path}: Global/DomainType is {domain}, but sarproc writes FX-domain files only")
    if "sarproc.radar" not in extra:
        return _foreign_raw(path, xh, fx, pvps)
    radar = RadarMetadata(**_radar_kwargs(json.loads(extra["sarproc.radar"])))
    place_info = json.loads(extra["sarproc.placement"])
    iarp = xh.load("{*}SceneCoordinates/{*}IARP/{*}ECF")
    ux = xh.load("{*}SceneCoordinates/{*}ReferenceSurface/{*}Planar/{*}uIAX")
    uy = xh.load("{*}SceneCoordinates/{*}ReferenceSurface/{*}Planar/{*}uIAY")
    llh = xh.load("{*}SceneCoordinates/{*}IARP/{*}LLH")
    place = Placement(
        utc="",
        lat_lon_height=(math.radians(llh[0]), math.radians(llh[1]), llh[2]),
        heading=place_info["heading"],
        anchor=np.asarray(place_info["anchor"], float),
        origin_ecf=np.asarray(iarp, float),
        rotation=np.stack([ux, uy, np.cross(ux, uy)], axis=1),
    )
    pos_ecf = np.asarray(pvps["TxPos"], float)
    srp = np.asarray(pvps["SRPPos"], float)
    tau_srp = 2 * np.linalg.norm(pos_ecf - srp, axis=1) / C
    t_start = tau_srp + np.asarray(pvps["TOA1"], float)
    fs = radar.range_sampling_rate
    n_range = int(round((float(pvps["TOA2"][0]) - float(pvps["TOA1"][0])) * fs)) + 1
    data = from_cphd_signal(fx, radar, t_start, tau_srp, n_range)
    t0 = float(extra.get("sarproc.range_time0", t_start.min()))
    gate = t_start - t0
    tx_time = np.asarray(pvps["TxTime"], float)
    az_t0 = float(extra.get("sarproc.azimuth_time0", -(tx_time[0] + tx_time[-1]) / 2))
    coords = {"azimuth_time": tx_time + az_t0, "range_time": t0 + np.arange(n_range) / fs}
    aux = {"platform_position": place.from_ecf(pos_ecf), "tx_offset": np.zeros(3), "rx_offset": np.zeros((1, 3))}
    if np.any(np.abs(gate) > 1e-12):
        aux["range_gate_offset"] = gate
    frame = json.loads(extra.get("sarproc.frame", "null"))
    targets = _targets_from_json(json.loads(extra.get("sarproc.targets", "[]")))
    history = json.loads(extra.get("sarproc.history", "[]"))
    return Product(
        kind="raw",
        data=data,
        dims=("azimuth_time", "range_time"),
        coords=coords,
        radar=radar,
        targets=targets,
        attrs={"frame": frame} if frame else {},
        aux=aux,
        history=history,
    )


@dataclasses.dataclass(frozen=True)
class _ForeignVectors:
    """What the standard fields of a foreign CPHD say about its vectors, checked (see :func:`_foreign_raw`)."""

    domain: str  # "FX" or "TOA"
    sgn: int
    rotation: np.ndarray  # (3, 3): columns uIAX, uIAY and their normal, ECF
    ref: int  # the reference vector (RefVectorIndex, else the middle one)
    tx: np.ndarray  # (n_vec, 3) transmit positions, ECF m
    rcv: np.ndarray  # (n_vec, 3) receive positions, ECF m
    origin: np.ndarray  # the reference vector's SRP: the scene frame's origin
    shift: np.ndarray  # TOA_srp,v - TOA_O,v per vector, s
    sc0: np.ndarray
    scss: np.ndarray
    fx1: np.ndarray
    fx2: np.ndarray
    toa1: np.ndarray  # as stored (relative to each vector's SRP)
    toa2: np.ndarray
    reach: float  # twice the largest |TOA| about O: the time window the frequency grid must hold
    polarization: str | None


@dataclasses.dataclass(frozen=True)
class _PhaseHistory:
    """Phase history on one frequency grid for every vector, referenced to the scene origin O."""

    freq: np.ndarray  # (n_freq,) Hz, uniform
    samples: np.ndarray  # (n_vec, n_freq) complex
    method: str  # how the samples came to one grid (recorded in history)


def _foreign_vectors(path: str | os.PathLike, xh: Any, pvps: np.ndarray, n_vec: int) -> _ForeignVectors:
    """The collection's geometry and per-vector parameters, refused with the file and field when unusable."""
    domain = xh.load("{*}Global/{*}DomainType")
    sgn = int(xh.load("{*}Global/{*}SGN"))
    collect = xh.load("{*}CollectionID/{*}CollectType")
    if collect != "MONOSTATIC":
        raise InputError(f"{path}: CollectionID/CollectType is {collect}; only MONOSTATIC collections are imported")
    ux = xh.load("{*}SceneCoordinates/{*}ReferenceSurface/{*}Planar/{*}uIAX")
    uy = xh.load("{*}SceneCoordinates/{*}ReferenceSurface/{*}Planar/{*}uIAY")
    if ux is None or uy is None:
        raise InputError(
            f"{path}: SceneCoordinates/ReferenceSurface is not Planar; only planar image areas are imported"
        )
    for name in ("TxPos", "RcvPos", "SRPPos", "SC0", "SCSS", "FX1", "FX2", "TOA1", "TOA2"):
        v = np.asarray(pvps[name], float)
        if not np.all(np.isfinite(v)):
            bad = int(np.flatnonzero(~np.all(np.isfinite(v.reshape(len(v), -1)), axis=1))[0])
            raise InputError(f"{path}: PVP {name} of vector {bad} is not finite; every vector must be valid")
    ref = xh.load("{*}Channel/{*}Parameters/{*}RefVectorIndex")
    ref = int(ref) if ref is not None and 0 <= int(ref) < n_vec else n_vec // 2
    tx, rcv = np.asarray(pvps["TxPos"], float), np.asarray(pvps["RcvPos"], float)
    srp = np.asarray(pvps["SRPPos"], float)
    origin = srp[ref]

    def toa(point: np.ndarray) -> np.ndarray:
        return (np.linalg.norm(tx - point, axis=-1) + np.linalg.norm(rcv - point, axis=-1)) / C

    shift = toa(srp) - toa(origin[None, :])
    fx1, fx2 = np.asarray(pvps["FX1"], float), np.asarray(pvps["FX2"], float)
    toa1, toa2 = np.asarray(pvps["TOA1"], float), np.asarray(pvps["TOA2"], float)
    if not np.all(fx2 > fx1):
        bad = int(np.flatnonzero(fx2 <= fx1)[0])
        raise InputError(f"{path}: PVP FX2 <= FX1 at vector {bad}")
    lo, hi = float(fx1.max()), float(fx2.min())
    if hi <= lo:
        raise InputError(
            f"{path}: PVP FX1/FX2: the vectors' bands share no common band (max FX1 {lo:.6g} Hz >= "
            f"min FX2 {hi:.6g} Hz); such data cannot be one raw product"
        )
    pol = [xh.load(f"{{*}}Channel/{{*}}Parameters/{{*}}Polarization/{{*}}{k}") for k in ("TxPol", "RcvPol")]
    return _ForeignVectors(
        domain=domain,
        sgn=sgn,
        rotation=np.stack([ux, uy, np.cross(ux, uy)], axis=1),
        ref=ref,
        tx=tx,
        rcv=rcv,
        origin=origin,
        shift=shift,
        sc0=np.asarray(pvps["SC0"], float),
        scss=np.asarray(pvps["SCSS"], float),
        fx1=fx1,
        fx2=fx2,
        toa1=toa1,
        toa2=toa2,
        # the window about O must hold the content
        reach=2 * float(max(np.abs(toa1 + shift).max(), np.abs(toa2 + shift).max())),
        polarization=":".join(pol) if None not in pol and "UNSPECIFIED" not in pol else None,
    )


def _foreign_phase_history(path: str | os.PathLike, v: _ForeignVectors, fx: np.ndarray) -> _PhaseHistory:
    """Every vector on one frequency grid inside the common band, SGN = -1, referenced to O."""
    n_samp = fx.shape[1]
    sig = np.asarray(fx)
    sig = np.conj(sig) if v.sgn > 0 else sig
    sc0, scss, fx1, fx2, ref, domain = v.sc0, v.scss, v.fx1, v.fx2, v.ref, v.domain
    same_grid = (
        domain == "FX"
        and np.all(sc0 == sc0[0])
        and np.all(scss == scss[0])
        and np.all(fx1 == fx1[0])
        and np.all(fx2 == fx2[0])
        and v.reach * scss[0] <= 1.0
    )
    if same_grid:
        f = sc0[0] + scss[0] * np.arange(n_samp)
        band = (f >= fx1[0] - 1e-6) & (f <= fx2[0] + 1e-6)
        freq, ph, method = f[band], np.asarray(sig[:, band], complex), "FX samples in [FX1, FX2]"
    else:
        lo, hi = float(fx1.max()), float(fx2.min())
        step = float(scss.min()) if domain == "FX" else float((1.0 / (n_samp * scss)).min())
        step = min(step, 1.0 / (1.02 * max(v.reach, 1e-300)))
        # on the reference vector's grid where the spacing allows (its own samples stay where they are)
        anchor = (
            (sc0[ref] if domain == "FX" else (fx1[ref] + fx2[ref]) / 2)
            if step == (scss[ref] if domain == "FX" else 1.0 / (n_samp * scss[ref]))
            else (lo + hi) / 2
        )
        m = np.arange(math.ceil((lo - anchor) / step - 1e-6), math.floor((hi - anchor) / step + 1e-6) + 1)
        freq = anchor + m * step
        ph = _common_grid(path, domain, sig, sc0, scss, fx1, fx2, v.toa1, v.toa2, freq)
        method = f"{domain} vectors on a common grid"
    if len(freq) < 2:
        raise InputError(f"{path}: fewer than two frequency samples inside the common band [FX1, FX2]")
    if np.any(v.shift != 0):
        ph = ph * _cycles_phasor(-np.outer(v.shift, freq))
    return _PhaseHistory(freq, ph, method)


def _oversampled(ph: _PhaseHistory) -> _PhaseHistory:
    """Zeros on both sides of the band, IMPORT_OVERSAMPLING x more samples than it needs, band centred on
    the zero bin (a critically sampled pulse is the worst case for the focusers' range interpolation;
    measured on the demo's linear 8 x backprojection: -49.4 -> -50.6 dB against the original)."""
    n_band, step = len(ph.freq), float(ph.freq[1] - ph.freq[0])
    n_pad = sfft.next_fast_len(int(math.ceil(IMPORT_OVERSAMPLING * n_band)))
    left = n_pad // 2 - n_band // 2
    padded = np.zeros((len(ph.samples), n_pad), complex)
    padded[:, left : left + n_band] = ph.samples
    return _PhaseHistory(ph.freq[0] + (np.arange(n_pad) - left) * step, padded, ph.method)


def _foreign_raw(path: str | os.PathLike, xh: Any, fx: np.ndarray, pvps: np.ndarray) -> Product:
    """A CPHD written by another program: its phase history, from the standard fields alone, as Gotcha-style data.

    FX-domain CPHD is the dechirped phase history compensated to the SRP (CPHD 1.1 signal model, SGN = -1):
    S_v(f) = A exp(-j 2 pi f (TOA_p - TOA_srp,v)), TOA_x,v = (|TxPos_v - x| + |RcvPos_v - x|) / c: the model of
    the Gotcha files, so the same conversion (gotcha.py: a unit-impulse "chirp" recorded in a window that
    follows the reference point) makes a raw product pfa2 and backproject focus. Steps, vector by vector:

    - SGN = +1 files are conjugated (the image is then that of the conjugate reflectivity; recorded in history).
    - One frequency grid for all vectors: a file with one FX grid and one band (SC0, SCSS, FX1, FX2 equal
      for every vector) keeps its samples inside [FX1, FX2] as they are. Otherwise (FX1/FX2, SC0 or SCSS
      per vector, or a TOA-domain file) every vector is evaluated on a common grid over the band all vectors
      share, [max FX1, min FX2], spaced min(SCSS) (FX) or 1 / (N SCSS) (TOA), finer if the content needs it.
      FX vectors: the vector's samples, tapered (raised cosine) between its band [FX1, FX2] and the ends of
      its grid so that their periodic extension has no jump, are taken to TOA (inverse DFT about the vector's
      TOA window centre (TOA1 + TOA2) / 2) and evaluated at the new frequencies by a chirp-z transform: exact
      for the trigonometric polynomial the samples define; the taper leaves [FX1, FX2] unchanged.
      TOA vectors (range-compressed samples at dTOA_n = SC0 + n SCSS, mainlobe phase SGN fx_C dTOA,
      fx_C = (FX1 + FX2) / 2 of the vector): S(f) = SCSS sum_n x_n exp(-j 2 pi (f - fx_C) dTOA_n), the
      inverse of x(dTOA) = int S(f) exp(+j 2 pi (f - fx_C) dTOA) df over [FX1, FX2].
    - A SRP that moves (SRPPos per vector) is replaced by one point O, the SRP of the reference vector
      (Channel/Parameters/RefVectorIndex): S_v times exp(-j 2 pi f (TOA_srp,v - TOA_O,v)), exact.

    The scene frame is the CPHD's image-area frame (uIAX, uIAY, their normal) about O; the antenna phase
    centre of a vector is the mean of its transmit and receive positions (exact for stop-and-go monostatic
    data; BISTATIC collections are refused). No targets are known: give the focusers grid extents.
    """
    from sarproc.formats.gotcha import GotchaPass, gotcha_product
    from sarproc.product.io import history_entry

    v = _foreign_vectors(path, xh, pvps, fx.shape[0])
    ph = _foreign_phase_history(path, v, fx)
    padded = _oversampled(ph)
    pos = (0.5 * (v.tx + v.rcv) - v.origin) @ v.rotation  # antenna phase centres in the scene frame
    raw = gotcha_product(
        GotchaPass(padded.samples, padded.freq, pos, np.linalg.norm(pos, axis=1), [str(path)], v.polarization)
    )
    # the band is the n_band samples (half a bin more: the range filter's |f| <= B/2 keeps every one of them)
    n_band, step = len(ph.freq), float(ph.freq[1] - ph.freq[0])
    raw.radar = dataclasses.replace(raw.radar, bandwidth=(n_band + 0.5) * step)
    raw.radar.validate()
    raw.history = [
        history_entry(
            f"import-cphd {path}",
            {
                "source": "CPHD (standard fields only)",
                "domain": v.domain,
                "sgn": v.sgn,
                "conversion": ph.method,
                "fx_samples_in_band": int(n_band),
                "band_hz": [float(ph.freq[0]), float(ph.freq[-1])],
                "srp_moves": bool(np.any(v.shift != 0)),
                "conjugated": v.sgn > 0,
                "range_oversampling": len(padded.freq) / n_band,
            },
        )
    ]
    return raw


def _taper(f: np.ndarray, fx1: float, fx2: float) -> np.ndarray:
    """1 on [fx1, fx2], raised cosine to 0 at the ends of the sample grid f (no taper where there is no guard)."""
    w = np.ones(len(f))
    below, above = f < fx1, f > fx2
    if np.any(below):
        g = fx1 - f[0]
        w[below] = 0.5 - 0.5 * np.cos(np.pi * (f[below] - f[0]) / g)
    if np.any(above):
        g = f[-1] - fx2
        w[above] = 0.5 - 0.5 * np.cos(np.pi * (f[-1] - f[above]) / g)
    return w


def _common_grid(
    path: str | os.PathLike,
    domain: str,
    sig: np.ndarray,
    sc0: np.ndarray,
    scss: np.ndarray,
    fx1: np.ndarray,
    fx2: np.ndarray,
    toa1: np.ndarray,
    toa2: np.ndarray,
    freq: np.ndarray,
) -> np.ndarray:
    """Every vector's phase history (SGN = -1 form, about its own SRP) at the frequencies ``freq``
    (see _foreign_raw)."""
    import scipy.signal as ss

    n_vec, n = sig.shape
    out = np.empty((n_vec, len(freq)), complex)
    step = float(freq[1] - freq[0])
    k = np.arange(n)
    for value in np.unique(scss):  # one chirp-z kernel per sample spacing
        rows = np.flatnonzero(scss == value)
        if domain == "FX":
            dtau = 1.0 / (n * value)
            tau0 = (toa1[rows] + toa2[rows]) / 2 - (n // 2) * dtau
            f = sc0[rows, None] + value * k[None, :]
            w = np.stack([_taper(fi, a, b) for fi, a, b in zip(f, fx1[rows], fx2[rows])])
            y = sfft.ifft(sig[rows] * w * _cycles_phasor(k[None, :] * value * tau0[:, None]), axis=-1)
            f_ref, scale = sc0[rows], 1.0
        else:
            dtau, tau0 = value, sc0[rows]
            y = np.asarray(sig[rows], complex)
            f_ref, scale = (fx1[rows] + fx2[rows]) / 2, value
        # S(F0 + m dF) = sum_n y_n exp(-j 2 pi (F0 - f_ref + m dF)(tau0 + n dtau))
        d0 = freq[0] - f_ref
        y = y * _cycles_phasor(-np.outer(d0, k) * dtau)
        czt = ss.CZT(n, m=len(freq), w=np.exp(-2j * np.pi * step * dtau))
        post = _cycles_phasor(-(d0[:, None] + np.arange(len(freq))[None, :] * step) * tau0[:, None])
        out[rows] = scale * czt(y, axis=-1) * post
    if not np.all(np.isfinite(out)):
        raise InputError(f"{path}: signal array holds non-finite samples")
    return out


def _radar_kwargs(d: dict) -> dict:
    d = dict(d)
    d["scene_center"] = tuple(d["scene_center"])
    return d


def check_cphd(path: str | os.PathLike) -> dict:
    """Run sarkit's CphdConsistency (schema, header, PVPs, reference geometry, signal) on a CPHD file."""
    with open(path, "rb") as fh:
        con = consistency_checker("CPHD").from_file(fh, thorough=True)
        run_checks(con)
    return consistency_summary(con)


def cphd_header(path: str | os.PathLike) -> dict:
    """Check a CPHD file's metadata without reading its signal; {'vectors', 'samples'} of its first channel.

    Raises InputError naming the file and the XML field when it is no FX- or TOA-domain monostatic CPHD.
    """
    require_sarkit()
    import sarkit.cphd as skcphd

    try:
        with open(path, "rb") as fh, skcphd.Reader(fh) as reader:
            tree = reader.metadata.xmltree
    except (OSError, ValueError, KeyError, RuntimeError) as exc:
        raise InputError(f"{path}: cannot read as CPHD: {exc}") from None
    xh = skcphd.XmlHelper(tree)
    if xh.load("{*}Global/{*}DomainType") not in ("FX", "TOA"):
        raise InputError(f"{path}: Global/DomainType must be FX or TOA")
    if xh.load("{*}CollectionID/{*}CollectType") != "MONOSTATIC":
        raise InputError(
            f"{path}: CollectionID/CollectType is {xh.load('{*}CollectionID/{*}CollectType')}; "
            "only MONOSTATIC collections are imported"
        )
    try:
        vectors = int(xh.load("{*}Data/{*}Channel/{*}NumVectors"))
        samples = int(xh.load("{*}Data/{*}Channel/{*}NumSamples"))
    except (TypeError, ValueError) as exc:
        raise InputError(f"{path}: Data/Channel/NumVectors, NumSamples: {exc}") from None
    if vectors < 1 or samples < 1:
        raise InputError(f"{path}: Data/Channel: {vectors} vectors x {samples} samples holds no signal")
    return {"vectors": vectors, "samples": samples}
