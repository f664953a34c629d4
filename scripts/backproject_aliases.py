"""Which shipped scenes' backprojections warn of Doppler ghosts (docs/product.md, "Ambiguity checks").

For each scene config: `sarproc simulate`, then `sarproc backproject` with the config, through the command line;
tabulates whether backproject warned that the pulses undersample its grid's Doppler, and of targets' aliases
beyond the grid's azimuth edge whose side lobes enter it, and the warnings.

Usage: python scripts/backproject_aliases.py [--configs demo bp_squint30 ...] [--out FILE.md]
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SMALL = (
    "demo",
    "bp_squint30",
    "bp_stripmap",
    "bp_beam_edge",
    "bp_hamming",
    "an2012_exp1_small",
    "an2012_exp2_small",
    "an2012_airborne_small",
    "nie2016_small",
    "nie2016_sliding_small",
    "xu_small",
    "xu_scene",
)


def run(cwd: Path, *args: str) -> str:
    """``python -m sarproc ARGS`` from ``cwd``; its standard error."""
    command = [sys.executable, "-m", "sarproc", *args, "--overwrite", "--no-progress"]
    return subprocess.run(command, check=True, cwd=cwd, capture_output=True, text=True).stderr


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--configs", nargs="+", default=list(SMALL))
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)
    lines = ["| scene | backproject's Doppler warning | its edge-alias warning |", "|---|---|---|"]
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.configs:
            config = ROOT / "configs" / f"{name}.yaml"
            raw, image = Path(tmp) / f"{name}_raw.h5", Path(tmp) / f"{name}.h5"
            run(Path(tmp), "simulate", str(config), "-o", str(raw), "-q")
            err = run(Path(tmp), "backproject", str(raw), "--config", str(config), "-o", str(image))
            said = [
                [line.split("backproject: ", 1)[1] for line in err.splitlines() if key in line]
                for key in ("of Doppler at equal range", "aliases in or just beyond")
            ]
            lines.append(f"| {name} | {' | '.join(s[0] if s else 'none' for s in said)} |")
            print(lines[-1], flush=True)
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
