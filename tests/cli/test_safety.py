"""Safe on shared machines and in batch systems (issue 18): special files written through, '-' for
stdin/stdout, read-only installs, every signal stops the run, concurrent writers seen at the start,
sweep without Dask, image warnings under -q. Root-only cases skip with a reason otherwise."""

from __future__ import annotations

import json
import os
import random
import shutil
import signal
import socket
import stat
import subprocess
import sys
import threading
import time
from pathlib import Path

import h5py
import numpy as np
import pytest
import yaml
from conftest import BASE_SCENE, merge

SCENE = merge(
    BASE_SCENE,
    {
        "acquisition": {"aperture_time": "0.2 s"},
        "targets": {"points": [{"name": "A"}, {"name": "B", "range": "10 m", "azimuth": "4 m"}]},
    },
)
BP = {"backproject": {"azimuth_extent": "20 m", "range_extent": "24 m"}}
# about 2 s of simulation (64 targets, 3200 pulses): long enough for a second run to start meanwhile
SLOW = merge(
    SCENE,
    {
        "acquisition": {
            "mode": "spotlight",
            "aperture_time": "8 s",
            "range_window": {"start": "1.99 km", "end": "2.03 km"},
        },
        "targets": {
            "frame": "squint",
            "points": None,
            "grid": {"azimuth_count": 8, "range_count": 8, "azimuth_spacing": "2 m", "range_spacing": "2 m"},
        },
        "simulation": {"block_pulses": 32},
    },
)
ROOT = pytest.mark.skipif(
    not hasattr(os, "geteuid") or os.geteuid() != 0, reason="needs root (mknod / running as another user)"
)
HERE = Path(__file__).parent


def dump(path: Path, mapping) -> Path:
    path.write_text(yaml.safe_dump(mapping, sort_keys=False))
    return path


def sarproc(*args, **kw) -> subprocess.CompletedProcess:
    kw.setdefault("capture_output", True)
    return subprocess.run([sys.executable, "-m", "sarproc", *map(str, args)], timeout=120, **kw)


def leftovers(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.endswith((".sarproc-tmp", ".sarproc-lock")))


def same_product(a, b) -> bool:
    with h5py.File(a) as fa, h5py.File(b) as fb:
        name = "signal" if "signal" in fa else "image"
        return (
            fa.attrs["product"] == fb.attrs["product"]
            and fa[name].shape == fb[name].shape
            and np.array_equal(fa[name][()], fb[name][()])
            and np.array_equal(fa["targets"][()], fb["targets"][()])
        )


@pytest.fixture(scope="module")
def made(tmp_path_factory):
    """scene.yaml, bp.yaml, raw.h5, image.h5 and report.json, written the ordinary way."""
    d = tmp_path_factory.mktemp("safety")
    dump(d / "scene.yaml", SCENE)
    dump(d / "bp.yaml", BP)
    for args in (
        ("simulate", d / "scene.yaml", "-o", d / "raw.h5"),
        ("backproject", d / "raw.h5", "--config", d / "bp.yaml", "-o", d / "image.h5"),
        ("evaluate", d / "image.h5", "-o", d / "report.json"),
    ):
        res = invoke(*args, "-q")
        assert res.exit_code == 0, res.output
    return d


def invoke(*args):
    """In this process (no start-up cost) where no real stdin/stdout descriptor is needed."""
    from click.testing import CliRunner

    from sarproc.cli.main import cli

    return CliRunner().invoke(cli, [str(a) for a in args])


def report_body(text: bytes) -> dict:
    doc = json.loads(text)
    doc.pop("input")
    return doc


# ---- 1. special files: written through, never replaced ----------------------------------------------------------


@ROOT
def test_device_node_is_written_through_not_replaced(made, tmp_path):
    dev = tmp_path / "null"
    os.mknod(dev, stat.S_IFCHR | 0o666, os.makedev(1, 3))  # the twin of /dev/null
    for args in (
        ("evaluate", made / "image.h5", "-o", dev, "--overwrite"),
        ("simulate", made / "scene.yaml", "-o", dev, "--overwrite"),
        ("simulate", made / "scene.yaml", "-o", dev),
    ):  # a device is not "an existing output"
        res = sarproc(*args, "-q")
        assert res.returncode == 0, res.stderr
        st = os.lstat(dev)
        assert stat.S_ISCHR(st.st_mode) and st.st_rdev == os.makedev(1, 3)
    assert leftovers(tmp_path) == []


def test_dev_null_and_dev_stdout_survive_overwrite(made):
    before = {p: os.lstat(p) for p in ("/dev/null", "/dev/stdout")}
    res = sarproc("simulate", made / "scene.yaml", "-o", "/dev/null", "--overwrite", "-q")
    assert res.returncode == 0 and res.stdout == b"", res.stderr
    res = sarproc("simulate", made / "scene.yaml", "-o", "/dev/stdout", "--overwrite")
    assert res.returncode == 0, res.stderr
    for p, st in before.items():
        now = os.lstat(p)
        assert (now.st_mode, now.st_ino, now.st_rdev) == (st.st_mode, st.st_ino, st.st_rdev), p
    # the bytes on stdout are the product, and nothing else (the summary line went to stderr)
    assert res.stdout[:8] == b"\x89HDF\r\n\x1a\n" and b"simulate: 2 targets" in res.stderr
    out = made / "from_stdout.h5"
    out.write_bytes(res.stdout)
    assert same_product(out, made / "raw.h5")


def test_fifo_gets_the_product(made, tmp_path):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    got = {}

    def reader():
        with open(fifo, "rb") as fh:
            got["bytes"] = fh.read()

    t = threading.Thread(target=reader)
    t.start()
    res = sarproc("backproject", made / "raw.h5", "--config", made / "bp.yaml", "-o", fifo, "--overwrite", "-q")
    t.join(30)
    assert res.returncode == 0, res.stderr
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)
    (tmp_path / "image.h5").write_bytes(got["bytes"])
    assert same_product(tmp_path / "image.h5", made / "image.h5")
    assert leftovers(tmp_path) == []


def test_unix_socket_gets_the_report(made, tmp_path):
    path = tmp_path / "sock"
    server = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    server.bind(str(path))
    server.listen(1)
    got = {}

    def serve():
        conn, _ = server.accept()
        with conn:
            chunks = []
            while chunk := conn.recv(65536):
                chunks.append(chunk)
        got["bytes"] = b"".join(chunks)

    t = threading.Thread(target=serve)
    t.start()
    res = sarproc("evaluate", made / "image.h5", "-o", path, "-q")
    t.join(30)
    server.close()
    assert res.returncode == 0, res.stderr
    assert report_body(got["bytes"]) == report_body((made / "report.json").read_bytes())


def test_symlinked_output_replaces_its_target_and_the_link_stays(made, tmp_path):
    target = tmp_path / "real.json"
    target.write_text("old")
    link = tmp_path / "link.json"
    link.symlink_to(target)
    res = invoke("evaluate", made / "image.h5", "-o", link, "--overwrite", "-q")
    assert res.exit_code == 0, res.output
    assert link.is_symlink() and os.readlink(link) == str(target)
    assert report_body(target.read_bytes()) == report_body((made / "report.json").read_bytes())
    dangling = tmp_path / "dangling.json"
    dangling.symlink_to(tmp_path / "new.json")
    assert invoke("evaluate", made / "image.h5", "-o", dangling, "-q").exit_code == 0
    assert dangling.is_symlink() and (tmp_path / "new.json").is_file()
    assert invoke("evaluate", made / "image.h5", "-o", link, "-q").exit_code == 2  # exists: --overwrite needed


# ---- 2. '-' is stdout / stdin ------------------------------------------------------------------------------------


def test_dash_reads_yaml_from_stdin_and_writes_products_to_stdout(made, tmp_path):
    # scene from stdin, product to stdout: the same product as from and to files
    res = sarproc("simulate", "-", "-o", "-", input=(made / "scene.yaml").read_bytes())
    assert res.returncode == 0, res.stderr
    assert not Path("-").exists() and not (tmp_path / "-").exists()
    (tmp_path / "raw.h5").write_bytes(res.stdout)
    assert same_product(tmp_path / "raw.h5", made / "raw.h5")
    # config from stdin, product into a pipe
    res = sarproc("backproject", made / "raw.h5", "--config", "-", "-o", "-", input=(made / "bp.yaml").read_bytes())
    assert res.returncode == 0, res.stderr
    (tmp_path / "image.h5").write_bytes(res.stdout)
    assert same_product(tmp_path / "image.h5", made / "image.h5")
    # the report on stdout is JSON alone: the table and the summary go to stderr, so do -v's logs
    res = sarproc("evaluate", made / "image.h5", "-o", "-", "-v")
    assert res.returncode == 0, res.stderr
    assert report_body(res.stdout) == report_body((made / "report.json").read_bytes())
    assert b"| target | axis |" in res.stderr and b"evaluate: plan" in res.stderr
    # a bad scene on stdin is named as such
    from click.testing import CliRunner

    from sarproc.cli.main import cli

    res = CliRunner().invoke(cli, ["simulate", "-", "-o", str(tmp_path / "x.h5")], input=b"radar: [1, 2\n")
    assert res.exit_code == 2 and "-: not valid YAML" in res.output, res.output


# ---- 5. concurrent writers are seen at the start -----------------------------------------------------------------


def test_second_writer_stops_at_once_naming_the_first(tmp_path):
    slow = dump(tmp_path / "slow.yaml", SLOW)
    out = tmp_path / "raw.h5"
    first = subprocess.Popen(
        [sys.executable, "-m", "sarproc", "simulate", str(slow), "-o", str(out), "--no-progress"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    try:
        # paused once it holds the output's lock and has said who it is (from the output check to the publishing:
        # the whole run, not only its write, which the compiled simulator finishes in milliseconds)
        lock = tmp_path / ".raw.h5.sarproc-lock"
        end = time.monotonic() + 60
        while time.monotonic() < end and first.poll() is None and not (lock.exists() and lock.read_text().strip()):
            time.sleep(0.005)
        first.send_signal(signal.SIGSTOP)  # frozen mid-run, holding its lock, however slow the second is
        assert first.poll() is None, "the first run ended before it could be paused: make it slower"
        start = time.monotonic()
        second = sarproc("simulate", slow, "-o", out, "--overwrite")
        took = time.monotonic() - start
        err = second.stderr.decode()
        assert second.returncode == 2, err
        assert f"another sarproc run is writing this output (pid {first.pid} " in err
        assert "sarproc simulate" in err and str(slow) in err and "Traceback" not in err
        assert took < 10  # start-up and the checks, no compute
        # SIGKILL leaves no stale lock: the next run writes
        first.kill()
        first.wait()
    finally:
        if first.poll() is None:
            first.kill()
        first.communicate()
    res = sarproc("simulate", made_scene(tmp_path), "-o", out, "--overwrite", "-q")
    assert res.returncode == 0, res.stderr
    assert leftovers(tmp_path) == []


def made_scene(tmp_path: Path) -> Path:
    return dump(tmp_path / "scene.yaml", SCENE)


# ---- 4. every signal stops the run -------------------------------------------------------------------------------


def test_every_signal_stops_the_run_or_lands_after_publishing(made, tmp_path):
    """36 deliveries (SIGTERM, SIGINT, SIGHUP) at random moments of simulate and backproject runs: each
    ends 128 + N with nothing left, or 0 with the complete output."""
    # a 4x longer aperture than SCENE in small blocks: the compute, not the publishing, fills most of each run
    # (with the compiled echo kernel SCENE's own simulation is over in a few blocks)
    long_scene = merge(SCENE, {"acquisition": {"aperture_time": "2 s"}, "simulation": {"block_pulses": 8}})
    scene = dump(tmp_path / "scene.yaml", long_scene)
    commands = {
        "simulate": lambda out: ["simulate", str(scene), "-o", str(out), "-q"],
        "backproject": lambda out: [
            "backproject",
            str(tmp_path / "warm_simulate_0.h5"),  # the first unsignalled run's raw product
            "--config",
            str(made / "bp.yaml"),
            "-o",
            str(out),
            "-q",
        ],
    }
    # the unsignalled runs' products (run first, in order) are the references
    refs = {"simulate": tmp_path / "warm_simulate_0.h5", "backproject": tmp_path / "warm_backproject_0.h5"}
    # two unsignalled runs of each first: kernels loaded, run time measured
    runs = [{"key": c, "args": commands[c](tmp_path / f"warm_{c}_{k}.h5")} for k in range(2) for c in commands]
    rng = random.Random(18)
    sigs = [signal.SIGTERM, signal.SIGINT, signal.SIGHUP]
    plan = []
    for i in range(36):
        c = list(commands)[i % 2]
        plan.append((c, tmp_path / f"out_{i}.h5", sigs[i % 3]))
        # up to 1.15 x the run time: some land after the run, and must change nothing
        runs.append(
            {
                "key": c,
                "args": commands[c](tmp_path / f"out_{i}.h5"),
                "signal": int(sigs[i % 3]),
                "fraction": rng.uniform(0, 1.15),
            }
        )
    (tmp_path / "runs.json").write_text(json.dumps(runs))
    res = subprocess.run(
        [sys.executable, str(HERE / "signal_driver.py"), str(tmp_path / "runs.json")],
        capture_output=True,
        text=True,
        timeout=300,
    )
    results = [json.loads(x) for x in res.stdout.splitlines()]
    assert len(results) == len(runs), res.stderr[-3000:]
    assert all(r["code"] == 0 for r in results[:4]), res.stderr[-3000:]
    results = results[4:]
    outcome = {"stopped": 0, "completed": 0}
    for (c, out, sig), r in zip(plan, results):
        where = (c, sig.name, r, res.stderr[-2000:])
        if r["code"] == 0:
            assert out.exists() and same_product(out, refs[c]), where
            outcome["completed"] += 1
        else:
            assert r["code"] == 128 + sig, where
            assert not out.exists(), where
            outcome["stopped"] += 1
    assert "Traceback" not in res.stderr
    assert leftovers(tmp_path) == []
    assert outcome["stopped"] >= 18, outcome  # most land inside the run


def test_signal_whose_exception_is_swallowed_still_stops_the_run(made, tmp_path, monkeypatch):
    """A library that catches the handler's exception (as HDF5 does inside its callbacks) cannot hide the
    signal: the run still ends 128 + N and publishes nothing."""
    from click.testing import CliRunner

    from sarproc.cli.main import cli
    from sarproc.product import io, run

    real_write = io.ProductWriter.write
    calls = []

    def write_swallowing(self, index, block):
        calls.append(1)
        if len(calls) == 2:
            try:
                os.kill(os.getpid(), signal.SIGTERM)
                time.sleep(0.05)  # the handler runs here and raises ...
            except run.Interrupted:
                pass  # ... and the "library" swallows it
        return real_write(self, index, block)

    monkeypatch.setattr(io.ProductWriter, "write", write_swallowing)
    scene = dump(tmp_path / "scene.yaml", merge(SCENE, {"simulation": {"block_pulses": 8}}))
    res = CliRunner().invoke(cli, ["simulate", str(scene), "-o", str(tmp_path / "raw.h5")])
    assert res.exit_code == 128 + signal.SIGTERM, res.output
    assert "interrupted by SIGTERM" in res.output
    assert not (tmp_path / "raw.h5").exists() and leftovers(tmp_path) == []


# ---- 3. read-only install, unwritable HOME -----------------------------------------------------------------------


@pytest.fixture
def shared_tmp():
    """A folder another user can reach (pytest's own live under a 0700 folder of root's)."""
    import tempfile

    d = Path(tempfile.mkdtemp(prefix="sarproc-ro-", dir="/tmp"))
    os.chmod(d, 0o755)
    yield d
    subprocess.run(["chmod", "-R", "u+w", str(d)], check=False)
    shutil.rmtree(d, ignore_errors=True)


@ROOT
def test_read_only_install_as_another_user(shared_tmp):
    if shutil.which("setpriv") is None:
        pytest.skip("needs setpriv (util-linux) to run as another user")
    import sarproc

    tmp_path = shared_tmp

    install = tmp_path / "install"
    shutil.copytree(Path(sarproc.__file__).parent, install / "sarproc", ignore=shutil.ignore_patterns("__pycache__"))
    subprocess.run(["chmod", "-R", "a-w", str(install)], check=True)
    work = tmp_path / "work"
    work.mkdir()
    os.chmod(work, 0o777)
    scene = dump(work / "scene.yaml", SCENE)
    os.chmod(scene, 0o644)
    # nobody, reading everything (the interpreter may live under /root) but writing nowhere it does not own
    user = [
        "setpriv",
        "--reuid=nobody",
        "--regid=nogroup",
        "--clear-groups",
        "--inh-caps=+dac_read_search",
        "--ambient-caps=+dac_read_search",
        "env",
        "-i",
        "HOME=/nonexistent",
        "PATH=/usr/bin:/bin",
        f"PYTHONPATH={install}",
    ]
    # a writable temporary directory: kernels cached there; one whose cache folder is someone else's: uncached
    import pwd

    taken = work / "tmp2" / f"sarproc-numba-cache-{pwd.getpwnam('nobody').pw_uid}"
    taken.mkdir(parents=True)
    (work / "tmp").mkdir()
    (work / "tmp2").chmod(0o1777)
    os.chmod(work / "tmp", 0o1777)
    # the failure came from every command; preprocess compiles few kernels (simulate's take longer)
    assert invoke("simulate", scene, "-o", work / "raw.h5", "-q").exit_code == 0
    os.chmod(work / "raw.h5", 0o644)
    res = subprocess.run(
        [
            *user,
            f"TMPDIR={work / 'tmp'}",
            sys.executable,
            "-m",
            "sarproc",
            "-v",
            "preprocess",
            str(work / "raw.h5"),
            "-o",
            str(work / "pre.h5"),
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert res.returncode == 0, res.stderr[-2000:]
    assert res.stderr.count("compiled kernels are cached in") == 1, res.stderr[-2000:]
    # every compiled kernel is decorated (and failed) at import; compiling them all takes minutes
    load = (
        "import logging; logging.basicConfig(level=logging.INFO); import sarproc.focus.backprojection_kernel, "
        "sarproc.focus.squint_deramp.fine_focus, sarproc.simulation.echo_kernel"
    )
    for tmpdir, said in (
        (work / "tmp", "compiled kernels are cached in"),
        (work / "tmp2", "compiled kernels are not cached"),
    ):
        res = subprocess.run(
            [*user, f"TMPDIR={tmpdir}", sys.executable, "-c", load], capture_output=True, text=True, timeout=300
        )
        assert res.returncode == 0, res.stderr[-2000:]
        assert res.stderr.count(said) == 1, res.stderr[-2000:]
    assert list((work / "tmp").glob("sarproc-numba-cache-*/*"))  # the kernels were cached there
    assert not list(install.rglob("__pycache__"))  # the install was not written


def test_every_cached_kernel_uses_the_fallback():
    """A kernel decorated cache=True bypasses the read-only fallback and fails there at import."""
    import re

    import sarproc

    offenders = [
        str(p)
        for p in Path(sarproc.__file__).parent.rglob("*.py")
        if re.search(r"njit\([^)]*cache=True", p.read_text())
    ]
    assert offenders == [], "use cache=CACHE from sarproc.dsp.kernel_cache"


# ---- 7. sweep without Dask; image warnings under -q --------------------------------------------------------------

HIDE_DASK = """
import sys
class _NoDask:
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in ("dask", "distributed"):
            raise ImportError("No module named " + repr(name))
        return None
sys.meta_path.insert(0, _NoDask())
from sarproc.cli.main import main
main()
"""


def test_sweep_runs_serially_without_dask(tmp_path):
    dump(tmp_path / "one.yaml", merge(SCENE, {"backproject": BP["backproject"]}))
    sweep = dump(
        tmp_path / "sweep.yaml",
        {
            "scenes": {"one": "one.yaml"},
            "focus": "backproject",
            "grid": {"backproject.upsample": [1, 2]},
            "output": "out",
        },
    )
    res = subprocess.run(
        [sys.executable, "-c", HIDE_DASK, "sweep", str(sweep), "--table", "-"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert res.returncode == 0, res.stderr[-2000:]
    assert res.stderr.count("Dask is not installed") == 1 and "one after the other" in res.stderr
    assert "on serial" in res.stderr  # the summary goes to stderr: stdout holds the table
    assert res.stdout.startswith("| scene | backproject.upsample |") and len(res.stdout.splitlines()) == 4
    assert json.loads((tmp_path / "out" / "table.json").read_text())["runner"] == "serial"
    # an explicit scheduler still needs Dask, and says so
    res = subprocess.run(
        [sys.executable, "-c", HIDE_DASK, "sweep", str(sweep), "--scheduler", "local"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert res.returncode == 2 and "Dask is not installed" in res.stderr


def test_image_warnings_survive_q_and_only_qq_silences_them(tmp_path):
    # two targets 60 m apart are 200 Hz apart in Doppler, more than a 150 Hz PRF: ghosts (tests/simulation)
    ghosts = dump(
        tmp_path / "ghosts.yaml",
        merge(
            SCENE,
            {
                "radar": {"prf": "150 Hz"},
                "coarse_focus": {},
                "targets": {"points": [{"name": "A"}, {"name": "B", "azimuth": "60 m"}]},
            },
        ),
    )
    res = sarproc("simulate", ghosts, "-o", tmp_path / "a.h5", "-q")
    err = res.stderr.decode()
    assert res.returncode == 0 and res.stdout == b""
    assert err.count("WARNING") == 1 and "ghosts of each target appear" in err
    res = sarproc("simulate", ghosts, "-o", tmp_path / "b.h5", "-qq")
    assert res.returncode == 0 and res.stdout == b"" and res.stderr == b""


def test_signal_between_two_outputs_leaves_neither(made, tmp_path, monkeypatch):
    """evaluate -o REPORT --plot DIR stopped after the report is published, while drawing: exit 128 + N, the
    report removed again (outputs all or none), no plot folder."""
    from click.testing import CliRunner

    import sarproc.cli.evaluate as ev
    from sarproc.cli.main import cli

    def draw_interrupted(*args, **kw):
        os.kill(os.getpid(), signal.SIGHUP)
        time.sleep(1)
        raise AssertionError("the signal did not stop the run")

    monkeypatch.setattr(ev, "_draw", draw_interrupted)
    res = CliRunner().invoke(
        cli, ["evaluate", str(made / "image.h5"), "-o", str(tmp_path / "r.json"), "--plot", str(tmp_path / "plots")]
    )
    assert res.exit_code == 128 + signal.SIGHUP, res.output
    assert "interrupted by SIGHUP" in res.output and "r.json" in res.output
    assert sorted(p.name for p in tmp_path.iterdir()) == []
