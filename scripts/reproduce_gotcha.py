"""Gotcha (AFRL, pass 1 HH, 0-4 deg): pfa2 (plain and two-step) against backprojection on the same ground grid.

Reads results/gotcha/image_bp.h5, image_pfa.h5 (plain, distortion corrected) and image_pfa_two_step.h5
(made by `make reproduce-gotcha`), writes PNG quicklooks and results/gotcha/summary.md: per PFA image the
normalised cross-correlation of the magnitudes with the backprojection's, the positions of its ten
brightest points against the backprojection's (sub-pixel peaks by parabolic interpolation), in pixels,
and the image entropy of both. The measures are `sarproc evaluate` on these images without truth
(`--reference image_bp.h5` for the PFA images; sarproc.quality.image_measures.measure_image), written
beside them as measures_*.json; this script runs it and tabulates the JSON.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from sarproc.product.io import read_product
from sarproc.product.model import Product


def measures(image: Path, reference: Path | None = None) -> dict:
    """`sarproc evaluate` on an image without truth (with --reference: against that image), its JSON."""
    out = image.with_name(f"measures_{image.stem.removeprefix('image_')}.json")
    ref = ["--reference", str(reference)] if reference is not None else []
    subprocess.run(
        [sys.executable, "-m", "sarproc", "evaluate", str(image), *ref, "-o", str(out), "--overwrite", "-q"], check=True
    )
    return json.loads(out.read_text())


def quicklook(img: Product, path: Path, title: str) -> None:
    db = 20 * np.log10(np.abs(img.data) / np.abs(img.data).max() + 1e-12)
    a, r = img.coords["azimuth"], img.coords["range"]
    plt.figure(figsize=(6, 5.4))
    plt.imshow(
        db.T,
        origin="lower",
        cmap="gray",
        vmin=-45,
        vmax=0,
        aspect="equal",
        extent=(a[0], a[-1], r[0] - r[len(r) // 2], r[-1] - r[len(r) // 2]),
    )
    plt.xlabel("azimuth x' (m)")
    plt.ylabel("ground range y' from the centre (m)")
    plt.title(title)
    plt.colorbar(label="dB")
    plt.tight_layout()
    plt.savefig(path, dpi=110)
    plt.close()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--dir", type=Path, default=Path("results/gotcha"))
    args = ap.parse_args()
    bp_path = args.dir / "image_bp.h5"
    bp = measures(bp_path)
    files = [("plain (distortion corrected)", "image_pfa.h5"), ("two-step", "image_pfa_two_step.h5")]
    images = [(label, args.dir / name) for label, name in files if (args.dir / name).exists()]
    shape = bp["shape"]
    lines = [
        "# Gotcha: pfa2 against backprojection",
        "",
        f"{shape[0]} x {shape[1]} pixels of {bp['spacing']['azimuth']:.3f} m x "
        f"{bp['spacing']['range']:.3f} m; backprojection's entropy "
        f"{bp['entropy']:.4f} nats. Peaks: the ten brightest PFA points, offset PFA - BP (pixels).",
        "",
        "| pfa2 | same grid | NCC of magnitudes | max d_az (px) | max d_rg (px) | entropy (nats) | sub-images |",
        "| --- | --- | --- | --- | --- | --- | --- |",
    ]
    results = []
    for label, path in images:
        m = measures(path, bp_path)
        rows = [(*p["pixel"], *p["offset"], p["level_db"]) for p in m["points"]]
        results.append((label, read_product(path), {**m, "rows": rows}))
    for label, img, c in results:
        lines.append(
            f"| {label} | {c['same_grid']} | {c['ncc']:.4f} | {max(abs(r[2]) for r in c['rows']):.3f} | "
            f"{max(abs(r[3]) for r in c['rows']):.3f} | {c['entropy']:.4f} | "
            f"{img.attrs.get('subimages', 1)} |"
        )
    for label, _img, c in results:
        lines += [
            "",
            f"{label}:",
            "",
            "| pixel (az, rg) | d_az (px) | d_rg (px) | level (dB) |",
            "| --- | --- | --- | --- |",
        ]
        lines += [f"| ({i}, {j}) | {da:+.3f} | {dr:+.3f} | {lv:.1f} |" for i, j, da, dr, lv in c["rows"]]
    quicklook(read_product(bp_path), args.dir / "image_bp.png", "Gotcha pass 1 HH 0-4 deg: backprojection")
    for (label, img, _), name in zip(results, ("image_pfa.png", "image_pfa_two_step.png")):
        quicklook(img, args.dir / name, f"Gotcha pass 1 HH 0-4 deg: pfa2 {label}")
    lines += ["", "![pfa](image_pfa.png) ![bp](image_bp.png)", ""]
    (args.dir / "summary.md").write_text("\n".join(lines))
    print("\n".join(lines))


if __name__ == "__main__":
    main()
