"""What a hostile or unlucky user meets: signals (Ctrl-C, SIGTERM, SIGKILL of the parent
alone), counts past their bounds, packs that have not settled, unphysical input,
outputs that would overwrite inputs, two runs into one folder, damaged or foreign pack
files, the umask, bad scheduler addresses and huge values in messages.

The subprocess tests use small scenes made slow on purpose (a long settle_time), and
stop them after a second or two; the whole file takes about 15 s.
"""

from __future__ import annotations

import dataclasses
import io
import json
import os
import signal
import stat
import subprocess
import sys
import time
import zipfile
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

import granpack as gp
from granpack import _core
from granpack._files import atomic_write
from granpack.cli import LOCK_NAME, main
from granpack.ensemble import MAX_PACKS, ensemble_tasks, pack_path, run_tasks
from granpack.pack import FORMAT_VERSION, fall_time, settling_issue

TINY_TOML = """\
preset = "4.1"
base = [0.2]
height = 0.06
settle_time = 0.5
"""
#: The tiny scene with a settle_time that keeps a pack busy for minutes: a run to stop.
SLOW = ["--settle-time", "60"]


def _group(pgid: int) -> list[int]:
    """Live (not zombie) processes of process group `pgid`, from /proc."""
    found = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat") as f:
                stat = f.read()
        except OSError:
            continue
        fields = stat[stat.rindex(")") + 2 :].split()
        if fields[0] not in ("Z", "X") and int(fields[2]) == pgid:
            found.append(int(entry))
    return found


def _granpack(*args: str, **kw) -> subprocess.Popen:
    """`granpack ARGS` in a new session (its own process group), output piped."""
    return subprocess.Popen(
        [sys.executable, "-m", "granpack.cli", *args],
        start_new_session=True,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        **kw,
    )


def _wait_for(predicate, timeout: float) -> bool:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if predicate():
            return True
        time.sleep(0.05)
    return predicate()


@pytest.fixture
def scene_file(tmp_path) -> Path:
    path = tmp_path / "scene.toml"
    path.write_text(TINY_TOML)
    return path


# -- signals ---------------------------------------------------------------------------------


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM], ids=["SIGKILL", "SIGTERM"])
def test_killing_the_parent_alone_leaves_no_process(scene_file, tmp_path, sig):
    """The OOM killer (SIGKILL) or a batch scheduler (SIGTERM) stops only the parent:
    its pool workers and the resource tracker must go too, within a second, and release
    its stdout/stderr (a pipe into `tee` must end). SIGTERM is a clean stop with a
    message and exit status 143."""
    out = tmp_path / "out"
    p = _granpack(
        "generate", str(scene_file), "--packs", "4", "--workers", "2", "--out", str(out),
        "--no-figures", "-q", *SLOW,
    )  # fmt: skip
    try:
        # parent, resource tracker and two workers
        assert _wait_for(lambda: len(_group(p.pid)) >= 4, 60), _group(p.pid)
        time.sleep(0.5)  # the workers are inside their packs
        os.kill(p.pid, sig)
        t0 = time.monotonic()
        gone = _wait_for(lambda: not _group(p.pid), 1.0)
        assert gone, f"alive {time.monotonic() - t0:.2f} s after the signal: {_group(p.pid)}"
        # nobody holds the pipes any more: communicate() sees end of file at once
        _, err = p.communicate(timeout=5)
    finally:
        for pid in _group(p.pid):
            os.kill(pid, signal.SIGKILL)
        if p.returncode is None:  # failed above: reap it and close its pipes
            p.kill()
            p.communicate(timeout=5)
    if sig == signal.SIGTERM:
        assert p.returncode == 128 + signal.SIGTERM
        assert b"terminated (SIGTERM)" in err and b"Traceback" not in err
        assert b"leaked semaphore" not in err
    else:
        assert p.returncode == -signal.SIGKILL


_INTERRUPTIBLE = """
import signal, sys, time
import numpy as np
import granpack as gp
signal.signal(signal.SIGINT, signal.default_int_handler)
what = sys.argv[1]
if what == "simulation":
    sim = gp.Simulation(dim=3, dt=1e-5, box=((0, 0, 0), (1, 1, float("inf"))))
    sim.add_particles([[0.1 * k + 0.05, 0.5, 0.05] for k in range(9)], np.full(9, 0.02))
    job = lambda: sim.run(1e4)
elif what == "generate":
    scene = gp.PackScene.preset("4.1").replace(base=(0.2,), height=0.06, settle_time=1e3)
    job = lambda: gp.generate(scene)
elif what == "triaxial":  # a triaxial test at I = 1e-7, in one call of the drive (hours)
    scene = gp.PackScene.preset("4.3").replace(seed=3, base=(0.3, 0.3), height=0.2).fast()
    sample = gp.consolidate(gp.generate(scene), 1e5, "isotropic", gravity=False, wall_friction=0)
    job = lambda: gp.triaxial(sample, inertial_number=1e-7, checks=2)
else:  # a layer past RSA saturation in a narrow box, allowed a billion attempts (minutes)
    scene = gp.PackScene.preset("4.1").replace(
        base=(0.1,), phi_layer=0.54, max_attempts=10**9, settle_time=0.0
    )
    job = lambda: gp.generate(scene)
print("started", flush=True)
t0 = time.monotonic()
try:
    job()
except KeyboardInterrupt:
    print(f"interrupted {time.monotonic() - t0:.3f}", flush=True)
"""


@pytest.mark.parametrize("what", ["simulation", "generate", "rsa", "triaxial"])
def test_ctrl_c_stops_a_long_native_call(what):
    """Simulation.run, a pack's jamming run, its random sequential addition and the
    triaxial test's drive check for signals: Ctrl-C stops a call that would run for hours
    within a fraction of a second."""
    p = subprocess.Popen(
        [sys.executable, "-c", _INTERRUPTIBLE, what], stdout=subprocess.PIPE, text=True
    )
    try:
        assert p.stdout.readline().strip() == "started"
        time.sleep(0.5)
        p.send_signal(signal.SIGINT)
        t0 = time.monotonic()
        out, _ = p.communicate(timeout=10)
        took = time.monotonic() - t0
    finally:
        p.kill()
    assert out.startswith("interrupted"), out
    assert took < 1.5, took


# -- bounds ----------------------------------------------------------------------------------


def test_runs_past_a_bound_are_refused_before_any_work():
    t0 = time.perf_counter()
    sim = gp.Simulation(dim=2, dt=1e-300)
    sim.add_particles([[0.0, 0.0]], [0.01])
    with pytest.raises(gp.GranpackError, match=r"seconds = 1.*steps per call"):
        sim.run(1.0)
    with pytest.raises(gp.GranpackError, match=r"invalid n = .*\[0, 10000000000\]"):
        sim.step(_core.MAX_STEPS_PER_CALL + 1)
    with pytest.raises(gp.GranpackError, match=r"settle_time = 1e\+12 s.*steps per layer"):
        gp.PackScene(settle_time=1e12)
    with pytest.raises(gp.GranpackError, match=r"max_attempts = .*\[1, 1000000000\]"):
        gp.PackScene(max_attempts=2**63)
    with pytest.raises(gp.GranpackError, match=r"max_layers = .*\[1, 1000000\]"):
        gp.PackScene(max_layers=10**12)
    with pytest.raises(gp.GranpackError, match=rf"n_packs = .*\[1, {MAX_PACKS}\]"):
        ensemble_tasks(gp.PackScene(), 10**20, "unused")
    assert sim.steps == 0 and sim.time == 0.0
    assert time.perf_counter() - t0 < 1.0


def test_cli_counts_past_their_bound_are_usage_errors(scene_file, tmp_path, capsys):
    out = tmp_path / "out"
    for option in (["--packs", "99999999999999999999"], ["--workers", "100000"]):
        with pytest.raises(SystemExit) as exc:
            main(["generate", str(scene_file), "--out", str(out), *option])
        assert exc.value.code == 2
        assert "must lie in [1, " in capsys.readouterr().err
    assert main(["generate", str(scene_file), "--out", str(out), "--settle-time", "1e12"]) == 2
    assert "steps per layer" in capsys.readouterr().err
    assert not (out / "packs").exists()  # refused before any pack was started


# -- silent nonsense ---------------------------------------------------------------------------


def test_unphysical_gravity_is_refused():
    for g in (-2.0, 0.0):
        with pytest.raises(gp.GranpackError, match=r"invalid gravity = .*\(0, inf\]"):
            gp.PackScene(gravity=g)


def test_a_pack_that_has_not_settled_warns():
    short = gp.PackScene.preset("4.1").replace(
        base=(0.3,), height=0.12, h_layer=0.04, settle_time=0.1, seed=5
    )
    assert fall_time(short) == pytest.approx(0.2)
    with pytest.warns(
        gp.UnsettledPackWarning, match=r"settle_time = 0.1 s is shorter than the 0.2 s"
    ):
        pack = gp.generate(short)
    assert settling_issue(pack) is not None
    # settle_time past the fall time, but the last layer still bounces: its kinetic
    # energy gives it away
    landing = gp.PackScene.preset("4.1").replace(base=(0.3,), height=0.2, settle_time=0.35)
    with pytest.warns(gp.UnsettledPackWarning, match="still move"):
        gp.generate(landing)
    # a settled pack does not warn (pytest turns any warning into an error)
    settled = gp.generate(short.replace(settle_time=1.0))
    assert settling_issue(settled) is None


def test_strong_drag_lengthens_the_fall_time():
    # terminal speed m g / c_D = 0.084 m/s for r = 0.01 m (sphere mass): 1.2 s through a
    # 0.1 m slab
    scene = gp.PackScene(drag=0.1, inertia_2d="sphere")
    assert fall_time(scene) == pytest.approx(0.1 / (4 / 3 * np.pi * 1e-6 * 1000 * 2 / 0.1))
    # the scene alone decides: its packs are not looked at
    assert "drag = 0.1 N s/m" in settling_issue(SimpleNamespace(scene=scene))


def test_the_cli_notes_an_unsettled_pack(scene_file, tmp_path, capsys):
    out = tmp_path / "out"
    rc = main(
        ["generate", str(scene_file), "--out", str(out), "--no-figures", "--settle-time", "0.1"]
    )
    assert rc == 0
    err = capsys.readouterr().err
    assert "granpack: note: unsettled pack: settle_time = 0.1 s is shorter" in err
    assert "(#0)" in err and "Traceback" not in err


def test_analysis_refuses_what_is_no_pack():
    x2 = np.array([[0.0, 0.0], [0.001, 0.0]])
    with pytest.raises(gp.GranpackError, match=r"particles 0 and 1 overlap by 0.199 m, more than"):
        gp.microstructure(positions=x2, radii=[0.1, 0.1])
    with pytest.raises(gp.GranpackError, match="centres coincide"):
        gp.microstructure(positions=[[0.5, 0.5], [0.5, 0.5]], radii=[0.1, 0.1])
    # a container whose volume would overflow: named by the coordinates' bound
    with pytest.raises(gp.GranpackError, match=r"positions\[0\] = \[1e\+308, 1.0\]: coordinates"):
        gp.microstructure(positions=[[1e308, 1.0], [-1e308, 1.0]], radii=[0.1, 0.1])
    with pytest.raises(gp.GranpackError, match=r"radii\[0\] = 1e-320"):
        gp.microstructure(positions=[[0.0, 0.0], [1.0, 0.0]], radii=[1e-320, 1e-320])
    with pytest.raises(gp.GranpackError, match=r"radii\[0\] = 1e\+200"):
        gp.microstructure(positions=[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]], radii=[1e200, 1e200])
    x = np.array([[0.0, 0.0], [0.19, 0.0], [0.5, 0.0]])
    normal = [[1.0, 0.0], [1.0, 0.0]]
    with pytest.raises(gp.GranpackError, match="joins particle 1 to itself"):
        gp.microstructure(
            positions=x, radii=[0.1] * 3, contacts={"i": [0, 1], "j": [1, 1], "normal": normal}
        )
    with pytest.raises(gp.GranpackError, match=r"pair \(0, 1\) is listed more than once"):
        gp.microstructure(
            positions=x, radii=[0.1] * 3, contacts={"i": [0, 1], "j": [1, 0], "normal": normal}
        )
    m = gp.microstructure(positions=x, radii=[0.1] * 3, core_margin=0.0)  # a 0.01 m overlap: valid
    assert m.n_contacts == 1


def test_analyze_prints_one_line_for_overflowing_coordinates(tmp_path, capsys):
    f = tmp_path / "far.txt"
    f.write_text("1e308 1 0.1\n-1e308 1 0.1\n")
    assert main(["analyze", str(f)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("granpack analyze: error: invalid positions") and err.count("\n") == 1


# -- files -------------------------------------------------------------------------------------


def test_an_overwrite_of_an_input_is_refused(scene_file, tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["generate", str(scene_file), "--out", str(out), "--no-figures", "-q"]) == 0
    pack = pack_path(out / "packs", 0)
    before = pack.read_bytes()
    for fmt in ("vtk", "lammps-data"):
        assert main(["export", str(pack), "--format", fmt, "--out", str(pack)]) == 2
        assert "would be overwritten" in capsys.readouterr().err
    disguised = tmp_path / "pack.vtu"  # a pack whose default export name is itself
    disguised.write_bytes(before)
    assert main(["export", str(disguised), "--format", "vtk"]) == 2
    assert pack.read_bytes() == before and disguised.read_bytes() == before
    # the scene file given is the folder's scene.toml, and the resolved scene differs
    assert main(["generate", str(scene_file), "--out", str(tmp_path), "--no-figures", "-q"]) == 2
    assert "would overwrite the scene file" in capsys.readouterr().err
    assert scene_file.read_text() == TINY_TOML
    # a rerun from the folder's own record is fine: nothing would change
    record = out / "scene.toml"
    text = record.read_bytes()
    assert main(["generate", str(record), "--out", str(out), "--no-figures", "-q"]) == 0
    assert record.read_bytes() == text


def test_two_runs_into_one_folder_cannot_mix(scene_file, tmp_path, capsys):
    out = tmp_path / "out"
    first = _granpack("generate", str(scene_file), "--out", str(out), "--seed", "1", "-q", *SLOW)
    try:
        assert _wait_for(lambda: (out / LOCK_NAME).exists(), 30)
        time.sleep(0.3)
        rc = main(["generate", str(scene_file), "--out", str(out), "--seed", "2", "--no-figures"])
        err = capsys.readouterr().err
        assert first.poll() is None  # the first run still holds the folder
    finally:
        first.send_signal(signal.SIGTERM)
        first.communicate(timeout=10)
    assert rc == 2
    assert f"another granpack run (process {first.pid}) is writing into {out}" in err
    assert not list((out / "packs").glob("*.npz"))  # neither run finished a pack
    # once the first run has ended, the folder is free again
    assert main(["generate", str(scene_file), "--out", str(out), "--no-figures", "-q"]) == 0


def _doctored(path: Path, **members) -> None:
    """Rewrites the pack archive at `path` with some members replaced (npy arrays or
    raw bytes)."""
    with zipfile.ZipFile(path) as z:
        files = {name: z.read(name) for name in z.namelist()}
    for key, value in members.items():
        buf = io.BytesIO()
        np.save(buf, value)
        files[f"{key}.npy"] = buf.getvalue()
    with zipfile.ZipFile(path, "w") as z:
        for name, data in files.items():
            z.writestr(name, data)


def test_a_pack_with_damaged_arrays_is_made_again_on_rerun(tmp_path):
    scene = gp.PackScene.preset("4.1").replace(base=(0.2,), height=0.06, settle_time=0.5)
    tasks = ensemble_tasks(scene, 1, tmp_path, 3)
    [path] = run_tasks(tasks, workers=1, progress=False)
    good = gp.load_pack(path)
    damaged = good.positions.copy()
    damaged[0] = np.nan
    _doctored(path, positions=damaged)  # the scene record is intact
    with pytest.raises(gp.GranpackError, match="non-finite"):
        gp.load_pack(path)
    run_tasks(tasks, workers=1, progress=False)
    np.testing.assert_array_equal(gp.load_pack(path).positions, good.positions)


def test_not_a_pack_is_told_from_a_newer_pack(tmp_path):
    scene = gp.PackScene.preset("4.1").replace(base=(0.2,), height=0.06, settle_time=0.5)
    pack = gp.generate(scene)
    newer = pack.save(tmp_path / "newer.npz")
    meta = json.loads(np.load(newer)["meta.json"].tobytes())
    _doctored(
        newer,
        **{
            "meta.json": np.frombuffer(
                json.dumps({**meta, "version": FORMAT_VERSION + 1}).encode(), np.uint8
            )
        },
    )
    newer_words = f"pack format version {FORMAT_VERSION + 1}; this granpack reads versions up to"
    with pytest.raises(gp.GranpackError, match=newer_words):
        gp.load_pack(newer)
    foreign = tmp_path / "foreign.npz"
    np.savez(foreign, positions=pack.positions)
    with pytest.raises(gp.GranpackError, match="not a granpack pack"):
        gp.load_pack(foreign)
    # a rerun neither trusts nor replaces a pack it cannot read
    task = dataclasses.replace(ensemble_tasks(scene, 1, tmp_path, 0)[0], path=newer)
    with pytest.raises(gp.GranpackError, match="upgrade granpack.*another output folder"):
        run_tasks([task], workers=1, progress=False)


@pytest.mark.parametrize("mask", [0o002, 0o022, 0o077])
def test_written_files_respect_the_umask(tmp_path, mask):
    old = os.umask(mask)
    try:
        path = atomic_write(tmp_path / "f.bin", b"x")
    finally:
        os.umask(old)
    assert path.stat().st_mode & 0o777 == 0o666 & ~mask


def test_an_output_that_is_not_a_regular_file_is_refused(tmp_path):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    for target in (fifo, tmp_path):
        with pytest.raises(gp.GranpackError, match="not a regular file"):
            atomic_write(target, b"x")
    assert stat.S_ISFIFO(fifo.stat().st_mode) and tmp_path.is_dir()


# -- messages ----------------------------------------------------------------------------------


def test_a_bad_scheduler_address_fails_fast(scene_file, tmp_path, capsys):
    for address, text in (
        ("tcp://127.0.0.1:1", "cannot connect to the Dask scheduler"),
        ("tcp://host-without-port", "expected tcp://HOST:PORT"),
        ("tcp://127.0.0.1:99999", "expected tcp://HOST:PORT"),
    ):
        t0 = time.monotonic()
        rc = main(
            ["generate", str(scene_file), "--out", str(tmp_path / "o"), "--scheduler", address]
        )
        err = capsys.readouterr().err
        assert rc == 2 and text in err and "Traceback" not in err, err
        assert time.monotonic() - t0 < 5.0


def test_huge_values_are_not_echoed_whole(tmp_path, capsys):
    f = tmp_path / "big.toml"
    f.write_text("r_mean = [" + ", ".join(["1.0"] * 200_000) + "]\n")
    assert main(["generate", str(f), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "invalid r_mean = [1.0, 1.0" in err and len(err) < 300, len(err)
    with pytest.raises(SystemExit):
        main(["generate", "4.1", "--packs", "9" * 5000])
    assert len(capsys.readouterr().err) < 400


def test_deeply_nested_toml_is_a_granpack_error():
    with pytest.raises(gp.GranpackError, match="nested too deeply"):
        gp.PackScene.from_toml_string("r_mean = " + "[" * 5000 + "]" * 5000)
