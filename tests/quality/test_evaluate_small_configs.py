"""evaluate's reports of make targets' small products pinned to the code before it was made faster (issue 20
item 5: "same numbers as before").

tests/data/evaluate_small_configs.json holds the reports ``sarproc evaluate`` wrote, through the command line as
the make targets run it, for two of the products scripts/evaluate_speed.py times: ``make demo``'s image
(configs/demo.yaml, backproject, ``--expect``) and paper 000's small scene (configs/an2012_exp1_small.yaml,
preprocess, coarse-focus, fine-focus), both simulated with the continuous chirp as when pinned (both configs follow
the band-limited default since), as the code at the commit named in the file wrote them. This tree's reports
of the same products, made by this tree's stages, must equal them within the bounds of
tests/quality/test_evaluate_pinned.py (IRW 1e-4 relative, PSLR / ISLR 0.005 dB, residual figures 0.05 dB,
positions 0.01 cell, every flag and name identical). On the machine that wrote the file they were equal to the
bit (scripts/evaluate_speed.py's "largest relative difference" 0.0); the bounds let another CPU's last bits pass.

Written by the code before: ``PYTHONPATH=<checkout> python tests/quality/test_evaluate_small_configs.py OUT.json
COMMIT``.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from sarproc.quality.metrics import TargetReport
from sarproc.quality.summary import tolerance_score
from tests.quality.test_evaluate_pinned import differences, without_newer_fields

DATA = Path(__file__).resolve().parents[1] / "data" / "evaluate_small_configs.json"

# product: [(command, arguments)] in the product's directory; "{cfg}" is the configs directory; the last is
# evaluate, writing report.json; the expectations file is copied there (the report holds its path as given)
CHAINS: dict[str, list[list[str]]] = {
    "demo": [  # simulated continuous, as when pinned (configs/demo.yaml follows the band-limited default since)
        ["simulate", "demo_continuous.yaml", "-o", "raw.h5"],
        ["backproject", "raw.h5", "--config", "{cfg}/demo.yaml", "-o", "image.h5"],
        ["evaluate", "image.h5", "-o", "report.json", "--expect", "demo_expect.yaml"],  # the report names it
    ],
    "000 small": [
        # simulated continuous, as when pinned (an2012_exp1_small follows the band-limited default since session 36)
        ["simulate", "an2012_exp1_small_continuous.yaml", "-o", "raw.h5"],
        ["preprocess", "raw.h5", "--config", "{cfg}/an2012_exp1_small.yaml", "-o", "pre.h5"],
        ["coarse-focus", "pre.h5", "--config", "{cfg}/an2012_exp1_small.yaml", "-o", "coarse.h5"],
        ["fine-focus", "coarse.h5", "--config", "{cfg}/an2012_exp1_small.yaml", "-o", "image.h5"],
        ["evaluate", "image.h5", "-o", "report.json"],
    ],
}


def report(product: str, where: Path) -> dict:
    """The report of ``product`` made and evaluated by the sarproc on the path, each command a process."""
    import sarproc

    root = Path(sarproc.__file__).resolve().parents[1]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(root), os.environ.get("PYTHONPATH", "")])}
    where.mkdir(parents=True, exist_ok=True)
    shutil.copy(root / "configs" / "demo_expect.yaml", where)
    demo = (root / "configs" / "demo.yaml").read_text()
    (where / "demo_continuous.yaml").write_text(demo + "\nsimulation: {waveform: continuous}\n")
    small = (root / "configs" / "an2012_exp1_small.yaml").read_text()
    (where / "an2012_exp1_small_continuous.yaml").write_text(small + "\nsimulation: {waveform: continuous}\n")
    for args in CHAINS[product]:
        args = [a.replace("{cfg}", str(root / "configs")) for a in args]
        done = subprocess.run(
            [sys.executable, "-m", "sarproc", *args, "--overwrite", "-q"],
            cwd=where,
            env=env,
            capture_output=True,
            text=True,
            check=False,
        )
        assert done.returncode == 0, (args, done.stderr[-2000:])
    return json.loads((where / "report.json").read_text())


@pytest.fixture(scope="module")
def pinned() -> dict:
    return json.loads(DATA.read_text())


def test_every_small_product_is_pinned(pinned):
    assert list(pinned["reports"]) == list(CHAINS)


@pytest.mark.slow
@pytest.mark.parametrize("product", list(CHAINS))
def test_report_equals_the_code_before(pinned, product, tmp_path):
    now = report(product, tmp_path)
    assert now["residual"] is not None  # the residual's fits ran (what the speed work changes)
    # tolerance_score (added to the report in session 40, after pinning) is no figure of its own but the
    # score of the target's figures: checked against them here, then compared without it
    for t in now["targets"]:
        score = tolerance_score(TargetReport.from_dict(t))
        assert t.pop("tolerance_score") == (None if math.isnan(score) else score)
    assert differences(pinned["reports"][product], without_newer_fields(now)) == []


def _write(path: Path, commit: str) -> None:
    import tempfile

    note = (
        f"sarproc evaluate's reports by the code at {commit} (issue 20 item 5: the figures before evaluate was "
        "made faster); written by tests/quality/test_evaluate_small_configs.py"
    )
    with tempfile.TemporaryDirectory() as tmp:
        reports = {p: report(p, Path(tmp) / p.replace(" ", "_")) for p in CHAINS}
    path.write_text(json.dumps({"note": note, "reports": reports}, separators=(",", ":")) + "\n")


if __name__ == "__main__":
    _write(Path(sys.argv[1]), sys.argv[2])
