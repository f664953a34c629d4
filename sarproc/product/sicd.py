"""Focused 2D images to SICD (NGA.STND.0024, version 1.4.0) through NGA's sarkit, and back.

A sarproc image lies on a plane grid of the scene frame (frames.py); SICD describes such a grid as
Grid/Type PLANE with the row and column unit vectors in ECF. SICD rows run along range (away from the
radar) and columns along azimuth, with the grid normal (row x col) pointing away from the Earth; for a
scene left of the track that means the azimuth axis is reversed. So the SICD pixel array is
``image.T`` with its columns flipped when needed: :func:`sicd_pixels` and :func:`image_from_sicd` do
and undo exactly this, nothing else (pixels are complex64 -> RE32F_IM32F, bit for bit).

Spatial frequency: DeltaKCOAPoly is where the pixels' spectrum is centred along each axis (measured
on the data: backprojection keeps the carrier phase exp(+j 2 pi (2 f_c / c) R), so its spectrum sits at
(2 f_c / c) u_los . u_axis folded by the pixel spacing; a basebanded image sits at 0), and KCtr the
rest of (2 f_c / c) u_los . u_axis at the scene reference point. Both are constants: the line of
sight turns slowly across the image.

The times and the Earth placement come from :mod:`sarproc.product.geolocation`. sarkit is imported
only inside the functions (optional extra ``sarproc[formats]``).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from sarproc import __version__
from sarproc.product.errors import InputError
from sarproc.product.frames import frame_from_spec
from sarproc.product.geolocation import Placement, ecf_to_geodetic, utc_datetime
from sarproc.product.metadata import C
from sarproc.product.model import Product

SICD_NS = "urn:SICD:1.4.0"
KAPFAC = 0.88589   # -3 dB width x bandwidth of a uniformly weighted response (SICD's 0.886, sarkit's 0.8859)
MODE_TYPE = {"spotlight": "SPOTLIGHT", "stripmap": "STRIPMAP", "sliding_spotlight": "DYNAMIC STRIPMAP"}


def require_sarkit():
    try:
        import sarkit  # noqa: F401
        import sarkit.verification  # noqa: F401
    except ImportError:
        raise InputError("SICD/CPHD need NGA's sarkit (Python >= 3.11): pip install 'sarproc[formats]'") from None


def pulse_times(product: Product) -> np.ndarray:
    """Azimuth times of the pulses, s: the raw axis, or (for images) the simulator's centred PRF grid."""
    if "azimuth_time" in product.coords:
        return np.asarray(product.coords["azimuth_time"], float)
    n = len(product.aux["platform_position"])
    return (np.arange(n) - (n - 1) / 2.0) / product.radar.prf


def fit_position_poly(t: np.ndarray, ecf: np.ndarray, max_order: int = 5) -> tuple[np.ndarray, float]:
    """Least-squares polynomial (order+1, 3) of ECF positions over time; also the worst residual, m."""
    order = int(min(max_order, len(t) - 1))
    scale = max(float(np.abs(t).max()), 1e-9)
    coefs = np.polynomial.polynomial.polyfit(t / scale, ecf, order)
    coefs = coefs / scale ** np.arange(order + 1)[:, None]      # back to powers of seconds
    resid = float(np.abs(np.polynomial.polynomial.polyval(t, coefs).T - ecf).max())
    return coefs, resid


@dataclasses.dataclass(frozen=True)
class SicdGrid:
    """The image grid as SICD sees it: unit vectors (ECF), spacings, reference pixel, column flip."""

    u_row: np.ndarray
    u_col: np.ndarray
    ss_row: float
    ss_col: float
    scp_pixel: tuple[int, int]
    scp_scene: np.ndarray
    flip_cols: bool
    shape: tuple[int, int]


def image_grid(product: Product, place: Placement, tol: float = 1e-3) -> SicdGrid:
    """Check the image is a plane, orthogonal, uniformly sampled grid and describe it in ECF."""
    if product.kind != "image" or product.dims != ("azimuth", "range"):
        raise InputError(f"SICD export needs a 2D image product with dims (azimuth, range), got {product.kind} "
                         f"{product.dims}")
    frame = frame_from_spec(product.attrs["frame"])
    az, rg = (np.asarray(product.coords[d], float) for d in ("azimuth", "range"))
    for name, ax in (("azimuth", az), ("range", rg)):
        step = np.diff(ax)
        if len(ax) < 2 or not np.allclose(step, step[0], rtol=1e-9, atol=0):
            raise InputError(f"SICD export: the image's {name} axis is not uniformly sampled")
    i0, j0 = len(az) // 2, len(rg) // 2
    p0 = frame.to_xyz(az[i0], rg[j0])
    d_col = frame.to_xyz(az[i0 + 1 if i0 + 1 < len(az) else i0 - 1], rg[j0]) - p0
    d_row = frame.to_xyz(az[i0], rg[j0 + 1 if j0 + 1 < len(rg) else j0 - 1]) - p0
    d_col *= 1 if i0 + 1 < len(az) else -1
    d_row *= 1 if j0 + 1 < len(rg) else -1
    # a plane grid: every corner where the two spacing vectors put it
    for i, j in ((0, 0), (0, len(rg) - 1), (len(az) - 1, 0), (len(az) - 1, len(rg) - 1)):
        err = np.linalg.norm(frame.to_xyz(az[i], rg[j]) - (p0 + (i - i0) * d_col + (j - j0) * d_row))
        if err > tol:
            raise InputError(f"SICD export: frame {frame.name!r} is not a plane grid ({err:.3g} m off at a corner); "
                             "focus onto a planar frame (los, ground, ground_los)")
    u_row, u_col = place.vector_to_ecf(d_row / np.linalg.norm(d_row)), place.vector_to_ecf(d_col / np.linalg.norm(d_col))
    if abs(float(u_row @ u_col)) > 1e-6:
        raise InputError(f"SICD export: frame {frame.name!r} has skewed axes (cos = {float(u_row @ u_col):.3g}); "
                         "SICD PLANE grids need orthogonal rows and columns: focus onto los, ground or ground_los")
    up = place.rotation[:, 2]
    flip = float(np.cross(u_row, u_col) @ up) < 0     # SICD: row x col points away from the Earth
    col = len(az) - 1 - i0 if flip else i0
    return SicdGrid(u_row=u_row, u_col=-u_col if flip else u_col, ss_row=float(np.linalg.norm(d_row)),
                    ss_col=float(np.linalg.norm(d_col)), scp_pixel=(j0, col), scp_scene=p0, flip_cols=flip,
                    shape=(len(rg), len(az)))


def sicd_pixels(image: np.ndarray, grid: SicdGrid) -> np.ndarray:
    """(n_azimuth, n_range) image -> (NumRows = n_range, NumCols = n_azimuth) SICD array, complex64."""
    out = np.asarray(image, np.complex64).T
    return np.ascontiguousarray(out[:, ::-1] if grid.flip_cols else out)


def image_from_sicd(pixels: np.ndarray, flip_cols: bool) -> np.ndarray:
    """Inverse of :func:`sicd_pixels`."""
    return np.ascontiguousarray((pixels[:, ::-1] if flip_cols else pixels).T)


def spectral_centre(pixels: np.ndarray, axis: int, ss: float) -> float:
    """Centre of the data's spectrum along ``axis``, cycles/m in [-1/(2 SS), 1/(2 SS)) (circular mean of power)."""
    spec = np.abs(np.fft.fft(pixels, axis=axis)) ** 2
    power = spec.sum(axis=1 - axis)
    n = len(power)
    phase = np.angle(np.sum(power * np.exp(2j * np.pi * np.arange(n) / n)))
    return float(phase / (2 * np.pi * ss))


def sicd_xml(product: Product, place: Placement, *, image_formation: str = "OTHER"):
    """The SICD XML tree of an image product (lxml ElementTree) and its grid."""
    import lxml.etree
    import sarkit.sicd as sksicd

    r = product.radar
    grid = image_grid(product, place)
    t = pulse_times(product)
    t_rel = t - t[0]                                   # SICD times run from CollectStart
    arp_ecf = place.to_ecf(product.aux["platform_position"])
    arp_poly, resid = fit_position_poly(t_rel, arp_ecf)
    if resid > 0.01:
        raise InputError(f"SICD export: the platform track is not a smooth polynomial (residual {resid:.3g} m)")
    scp_ecf = place.to_ecf(grid.scp_scene)
    scp_llh = ecf_to_geodetic(scp_ecf)
    t_coa = float(-t[0])                              # aperture centre, where the spotlight COA is
    arp_coa = np.polynomial.polynomial.polyval(t_coa, arp_poly)
    u_los = (scp_ecf - arp_coa) / np.linalg.norm(scp_ecf - arp_coa)
    time_coa = np.array([[t_coa, 0.0], [0.0, 0.0]])
    if r.mode != "spotlight":
        # beam-limited: the centre of aperture moves with the along-track position (speed v along +x)
        vx = place.rotation[:, 0] * r.velocity
        time_coa[1, 0] = float(grid.u_row @ vx) / r.velocity**2
        time_coa[0, 1] = float(grid.u_col @ vx) / r.velocity**2
    irw_az, irw_rg = (float(w) for w in product.attrs["theoretical_irw"])
    dims = {}
    pixels = sicd_pixels(product.data, grid)
    for axis, (name, u, ss, irw) in enumerate((("Row", grid.u_row, grid.ss_row, irw_rg),
                                               ("Col", grid.u_col, grid.ss_col, irw_az))):
        # where the pixels' spectrum sits (measured: backprojection keeps the carrier, a polar-format image
        # may be basebanded) and the spatial frequency it stands for, KCtr + DeltaKCOA = (2 f_c / c) u_los . u
        dk = spectral_centre(pixels, axis, ss)
        kctr = 2.0 * r.carrier_frequency / C * float(u_los @ u) - dk
        bw = KAPFAC / irw
        lo, hi = dk - bw / 2, dk + bw / 2
        if lo < -0.5 / ss or hi > 0.5 / ss:           # support wraps around the folding frequency
            lo, hi = -0.5 / ss, 0.5 / ss
        dims[name] = {"UVectECF": u, "SS": ss, "ImpRespWid": irw, "Sgn": -1, "ImpRespBW": bw, "KCtr": kctr,
                      "DeltaK1": lo, "DeltaK2": hi, "DeltaKCOAPoly": np.array([[dk]]),
                      "WgtType": {"WindowName": "UNIFORM"}}
    n_rows, n_cols = grid.shape
    collect_start = place.datetime64(float(t[0]))
    duration = len(t) / r.prf                         # the last pulse's interval included (IPPEnd = n - 1)
    f_lo, f_hi = r.carrier_frequency - r.bandwidth / 2, r.carrier_frequency + r.bandwidth / 2
    created = np.datetime64("now", "us")

    root = sksicd.ElementWrapper(lxml.etree.Element(f"{{{SICD_NS}}}SICD"))
    root["CollectionInfo"] = {"CollectorName": "sarproc simulator", "CoreName": f"sarproc_{product.kind}",
                              "CollectType": "MONOSTATIC", "RadarMode": {"ModeType": MODE_TYPE.get(r.mode, "SPOTLIGHT")},
                              "Classification": "UNCLASSIFIED"}
    root["ImageCreation"] = {"Application": f"sarproc {__version__}", "DateTime": utc_datetime(created),
                             "Profile": "sarproc export-sicd"}
    root["ImageData"] = {"PixelType": "RE32F_IM32F", "NumRows": n_rows, "NumCols": n_cols, "FirstRow": 0,
                         "FirstCol": 0, "FullImage": {"NumRows": n_rows, "NumCols": n_cols},
                         "SCPPixel": np.array(grid.scp_pixel)}
    root["GeoData"] = {"EarthModel": "WGS_84",
                       "SCP": {"ECF": scp_ecf, "LLH": np.array([*np.degrees(scp_llh[:2]), scp_llh[2]])},
                       "ImageCorners": np.zeros((4, 2))}   # projected below, once the geometry is complete
    root["Grid"] = {"ImagePlane": "SLANT" if abs(float(np.cross(grid.u_row, grid.u_col) @ place.rotation[:, 2])) < 0.999
                    else "GROUND", "Type": "PLANE", "TimeCOAPoly": time_coa, "Row": dims["Row"], "Col": dims["Col"]}
    root["Timeline"] = {"CollectStart": utc_datetime(collect_start), "CollectDuration": duration,
                        "IPP": {"@size": 1, "Set": [{"TStart": 0.0, "TEnd": duration, "IPPStart": 0,
                                         "IPPEnd": len(t) - 1, "IPPPoly": np.array([0.0, r.prf]),
                                         "@index": 1}]}}
    root["Position"] = {"ARPPoly": arp_poly}
    root["RadarCollection"] = {
        "TxFrequency": {"Min": f_lo, "Max": f_hi},
        "Waveform": {"@size": 1, "WFParameters": [{"TxPulseLength": r.pulse_duration, "TxRFBandwidth": r.bandwidth,
                                       "TxFreqStart": f_lo, "TxFMRate": r.chirp_rate, "RcvDemodType": "CHIRP",
                                       "ADCSampleRate": r.range_sampling_rate, "RcvFMRate": 0.0, "@index": 1}]},
        "TxPolarization": "V",
        "RcvChannels": {"@size": 1, "ChanParameters": [{"TxRcvPolarization": "V:V", "@index": 1}]},
    }
    root["ImageFormation"] = {"RcvChanProc": {"NumChanProc": 1, "ChanIndex": [1]}, "TxRcvPolarizationProc": "V:V",
                              "TStartProc": 0.0, "TEndProc": duration,
                              "TxFrequencyProc": {"MinProc": f_lo, "MaxProc": f_hi},
                              "ImageFormAlgo": image_formation, "STBeamComp": "NO", "ImageBeamComp": "NO",
                              "AzAutofocus": "NO", "RgAutofocus": "NO"}
    tree = root.elem.getroottree()
    scpcoa = sksicd.compute_scp_coa(tree)
    # SCPCOA belongs after ImageFormation (schema order)
    tree.getroot().find(f"{{{SICD_NS}}}ImageFormation").addnext(scpcoa)
    # image corners: the corner pixels projected (R/Rdot, SICD vol. 3) onto the SCP's height above the ellipsoid
    corners_rc = np.array([(0, 0), (0, n_cols - 1), (n_rows - 1, n_cols - 1), (n_rows - 1, 0)])
    ground, _, ok = sksicd.image_to_constant_hae_surface(tree, sksicd.rowcol_to_xrowycol(tree, corners_rc),
                                                         float(scp_llh[2]))
    if not ok:
        raise InputError("SICD export: the image corners do not project onto the ground")
    root["GeoData"]["ImageCorners"] = np.degrees(ecf_to_geodetic(ground)[:, :2])
    return tree, grid



def write_sicd(path, product: Product, place: Placement, *, image_formation: str = "OTHER") -> SicdGrid:
    """Write ``product`` (a 2D image) as a SICD NITF file at ``path`` (atomically)."""
    require_sarkit()
    import sarkit.sicd as sksicd

    from sarproc.product.io import atomic_path

    tree, grid = sicd_xml(product, place, image_formation=image_formation)
    security = {"security": {"clas": "U"}}
    meta = sksicd.NitfMetadata(xmltree=tree, file_header_part={"ostaid": "sarproc", "ftitle": "sarproc SICD"} | security,
                               im_subheader_part={"isorce": "sarproc simulation"} | security,
                               de_subheader_part=security)
    with atomic_path(path) as tmp, open(tmp, "wb") as fh, sksicd.NitfWriter(fh, meta) as writer:
        writer.write_image(sicd_pixels(product.data, grid))
    return grid


def read_sicd(path) -> tuple:
    """(xml tree, pixels (NumRows, NumCols) complex64) of a SICD NITF file."""
    require_sarkit()
    import sarkit.sicd as sksicd

    with open(path, "rb") as fh, sksicd.NitfReader(fh) as reader:
        return reader.metadata.xmltree, reader.read_image()


def consistency_summary(con) -> dict:
    """What a sarkit ConsistencyChecker found: failed checks split into errors ('Need') and warnings ('Want')."""
    import contextlib
    import io

    text = io.StringIO()
    with contextlib.redirect_stdout(text):
        con.print_result(fail_detail=True, color=False, include_passed_asserts=False)
    errors, warnings = [], []
    for name, result in con.failures().items():
        severities = {d["severity"] for d in result["details"] if not d["passed"]}
        (errors if "Error" in severities else warnings).append(name)
    return {"passed": not errors, "checks": len(con.all()), "n_passed": len(con.passes()),
            "n_skipped": len(con.skips()), "errors": sorted(errors), "warnings": sorted(warnings),
            "report": text.getvalue()}


def check_sicd(path) -> dict:
    """Run sarkit's SicdConsistency (schema, NITF headers, every metadata relation) on a SICD file."""
    require_sarkit()
    import sarkit.verification as skver

    with open(path, "rb") as fh:
        con = skver.SicdConsistency.from_file(fh)
        con.check()
    return consistency_summary(con)
