"""SICD exports through both NGA readers' checks: sarkit's ``sicdcheck`` and sarpy's validity check.

For each ``NAME=IMAGE.h5`` given: ``sarproc export-sicd`` as SICD 1.4.0 and 1.3.0 into ``--out``
(NAME_1.4.0.nitf, ...), then per file ``sicdcheck -v`` (text: NAME_VERSION_sicdcheck.txt, the export's
own sarkit report: NAME_VERSION_sarkit.json) and sarpy's ``sicd_consistency`` check (NAME_VERSION_sarpy.json,
needs ``pip install sarpy``), and how well DeltaKCOAPoly describes the pixels: the spectral centre measured
about the brightest points (targets, or the image's brightest local maxima) against DeltaKCOAPoly there.
Writes ``--out``/sicd_readers.md (the table) and .json. Used by ``make formats-readers``.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

import numpy as np

from sarproc.formats.sicd import local_support_offsets, read_sicd, sarpy_check
from sarproc.quality.image_measures import bright_points

VERSIONS = ("1.4.0", "1.3.0")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("images", nargs="+", help="NAME=IMAGE.h5")
    ap.add_argument("--out", type=Path, default=Path("results/formats"))
    ap.add_argument("--config", help="geolocation YAML passed to export-sicd")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    bindir = Path(sys.executable).parent
    rows = []
    for spec in args.images:
        name, image = spec.split("=", 1)
        for version in VERSIONS:
            stem = args.out / f"{name}_{version}"
            nitf = Path(f"{stem}.nitf")
            cmd = [
                sys.executable,
                "-m",
                "sarproc",
                "export-sicd",
                image,
                "-o",
                str(nitf),
                "--overwrite",
                "--sicd-version",
                version,
                "--check-report",
                f"{stem}_sarkit.json",
            ]
            if args.config:
                cmd += ["--config", args.config]
            subprocess.run(cmd, check=True)
            check = subprocess.run(
                [str(bindir / "sicdcheck"), "-v", "--no-color", str(nitf)], capture_output=True, text=True
            )
            Path(f"{stem}_sicdcheck.txt").write_text(check.stdout + check.stderr)
            sarkit = json.loads(Path(f"{stem}_sarkit.json").read_text())
            try:
                sarpy = sarpy_check(nitf)
            except Exception as exc:  # sarpy not installed: say so in the table
                sarpy = {"sarpy": None, "valid": None, "errors": [str(exc)], "warnings": []}
            Path(f"{stem}_sarpy.json").write_text(json.dumps(sarpy, indent=1) + "\n")
            tree, pixels = read_sicd(nitf)
            offsets = np.abs(
                local_support_offsets(
                    tree, pixels, bright_points(np.abs(pixels), n=10, separation=20, edge=16, floor=0.1)
                )
            )
            rows.append(
                {
                    "image": name,
                    "version": version,
                    "sicdcheck_rc": check.returncode,
                    "sarkit_passed": sarkit["n_passed"],
                    "sarkit_errors": sarkit["errors"],
                    "sarkit_warnings": sarkit["warnings"],
                    "sarpy": sarpy["sarpy"],
                    "sarpy_valid": sarpy["valid"],
                    "sarpy_errors": sarpy["errors"],
                    "sarpy_warnings": sarpy["warnings"],
                    "worst_offset_row": float(offsets[:, 0].max()),
                    "worst_offset_col": float(offsets[:, 1].max()),
                }
            )
    (args.out / "sicd_readers.json").write_text(json.dumps(rows, indent=1) + "\n")
    lines = [
        "| image | SICD | sicdcheck passed / errors / warnings | sarpy valid / errors / warnings | "
        "worst abs(measured - DeltaKCOA) / BW, row, col |",
        "|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['image']} | {r['version']} | {r['sarkit_passed']} / {len(r['sarkit_errors'])} / "
            f"{len(r['sarkit_warnings'])} ({', '.join(r['sarkit_warnings'])}) | {r['sarpy_valid']} / "
            f"{len(r['sarpy_errors'])} / {len(r['sarpy_warnings'])} | "
            f"{r['worst_offset_row']:.4f}, {r['worst_offset_col']:.4f} |"
        )
    errors = sorted({e.splitlines()[0] for r in rows for e in r["sarpy_errors"]})
    lines += ["", f"sarpy {rows[0]['sarpy']}; its error messages: " + ("; ".join(errors) if errors else "none"), ""]
    (args.out / "sicd_readers.md").write_text("\n".join(lines))
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
