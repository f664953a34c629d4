"""Paths a non-root user may not read or search (docs/cli.md, session 43 "rows 7c and 11"): an input in a directory
without search permission read "damaged or non-conforming product: [Errno 13] Permission denied", an output
there "<path>: Permission denied" (from pathlib, uncaught), and ``sweep -o`` into a read-only directory the same.

The suite runs as root, whom no permission stops: the tests below make the system calls fail as they do for
another user (monkeypatch), and the last ones run the real thing only where the tests do not run as root.
"""

from __future__ import annotations

import errno
import os
from pathlib import Path

import pytest
from click.testing import CliRunner

from sarproc.product.errors import InputError
from sarproc.product.io import check_output_path, read_product


def _denied_under(monkeypatch, directory: Path) -> None:
    """os.stat of anything inside ``directory`` fails as for a user without search permission on it."""
    real = os.stat

    def stat(path, *args, **kwargs):
        if Path(os.fspath(path)).parent == directory:
            raise PermissionError(errno.EACCES, os.strerror(errno.EACCES), os.fspath(path))
        return real(path, *args, **kwargs)

    monkeypatch.setattr(os, "stat", stat)


def test_an_output_in_a_directory_that_cannot_be_searched_is_refused_naming_it(tmp_path, monkeypatch):
    shut = tmp_path / "noperm"
    shut.mkdir()
    _denied_under(monkeypatch, shut)
    with pytest.raises(InputError) as caught:
        check_output_path(shut / "img.h5")
    assert str(caught.value) == (
        f"{shut / 'img.h5'}: cannot reach it: Permission denied (EACCES) on a directory of its path; "
        "choose a writable location"
    )
    assert list(shut.iterdir()) == []


def test_an_input_that_cannot_be_read_is_not_called_damaged(tmp_path, monkeypatch):
    from sarproc.product import io

    path = tmp_path / "img.h5"

    def denied(*args, **kwargs):
        raise PermissionError(errno.EACCES, os.strerror(errno.EACCES), str(path))

    monkeypatch.setattr(io, "_read_product", denied)
    with pytest.raises(InputError) as caught:
        read_product(path)
    assert str(caught.value) == f"{path}: cannot read it: Permission denied (EACCES)"


def test_a_sweep_into_a_directory_it_cannot_create_says_so(tmp_path, monkeypatch):
    from sarproc.cli.main import cli

    sweep = tmp_path / "sw.yaml"
    scene = Path(__file__).resolve().parents[2] / "configs" / "bp_stripmap.yaml"
    sweep.write_text(
        f"scenes:\n  s: {scene}\nfocus: backproject\ncases:\n  - {{backproject.upsample: 1}}\n", encoding="utf-8"
    )
    out = tmp_path / "ro" / "sw"
    real = Path.mkdir

    def mkdir(self, *args, **kwargs):
        if self == out:
            raise PermissionError(errno.EACCES, os.strerror(errno.EACCES), str(self))
        return real(self, *args, **kwargs)

    monkeypatch.setattr(Path, "mkdir", mkdir)
    done = CliRunner().invoke(cli, ["sweep", str(sweep), "-o", str(out), "--scheduler", "serial"])
    assert done.exit_code == 2, done.output
    assert f"{out}: cannot create the output directory: Permission denied; choose a writable location" in done.output
    assert not out.exists()


@pytest.mark.skipif(os.geteuid() == 0, reason="root is not stopped by permissions (the monkeypatched tests cover it)")
def test_as_a_user_the_real_permissions_give_the_same_messages(tmp_path):
    shut = tmp_path / "noperm"
    shut.mkdir()
    (shut / "img.h5").write_bytes(b"")
    shut.chmod(0o000)
    try:
        with pytest.raises(InputError, match="cannot reach it: Permission denied"):
            check_output_path(shut / "out.h5")
        with pytest.raises(InputError, match="cannot read it: Permission denied"):
            read_product(shut / "img.h5")
    finally:
        shut.chmod(0o700)
