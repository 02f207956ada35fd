"""The layer loop on LAMMPS over MPI (`granpack.mpi`): one layer against granpack's
engine, the pack it gathers, rank counts, and the errors of a run that cannot go on."""

from __future__ import annotations

import os
import signal
import time
from pathlib import Path

import numpy as np
import pytest

import granpack as gp
from granpack.mpi import engine as mpi_engine
from granpack.mpi import launch
from granpack.mpi.law import LammpsMappingError

pytestmark = pytest.mark.usefixtures("lammps_mpi")


def _scene(dim: int = 3, container: str = "box", **changes) -> gp.PackScene:
    changes = {"height": 0.1, **changes}
    if dim == 2:
        return gp.PackScene.preset("4.1").replace(base=(0.3,), **changes)
    extra = {"cylinder_radius": 0.15} if container == "cylinder" else {}
    return gp.PackScene.preset("4.3").replace(
        base=(0.3, 0.3), container=container, **extra, **changes
    )


def _native(scene: gp.PackScene, x: np.ndarray, r: np.ndarray) -> gp.Simulation:
    d = scene.dim
    hi = np.full(d, np.inf)
    hi[: d - 1] = scene.base
    g = np.zeros(d)
    g[-1] = -scene.gravity
    sim = gp.Simulation(
        dim=d,
        material=scene.material,
        dt=scene.dt,
        gravity=tuple(g),
        drag=scene.drag,
        box=(tuple(np.zeros(d)), tuple(hi)),
        rotations=scene.rotations,
        container=scene.container,
        cylinder_radius=scene.cylinder_radius,
        inertia_2d=scene.inertia_2d,
    )
    sim.add_particles(x, r)
    return sim


@pytest.mark.parametrize(
    ("dim", "container"), [(3, "box"), (3, "periodic"), (3, "cylinder"), (2, "box")]
)
def test_one_layer_follows_granpacks_engine(dim, container):
    """The first layer, placed by granpack's placement and stepped by LAMMPS on one rank
    and by granpack's engine: in free fall the same to the last bits' order (1e-12 r),
    through the first impacts within 1e-3 r (measured 4e-5 to 1.4e-4 r: LAMMPS takes the
    spins' lever arm as r, granpack as r - d/2). Past that the paths part as any two
    orders of summation part in a granular bed (0.1-0.2 r median at the layer's end,
    1 s): from there the engines agree in statistics only."""
    from lammps import lammps
    from mpi4py import MPI

    scene = _scene(dim, container)
    run = mpi_engine._Run(scene, MPI.COMM_WORLD, lammps)
    try:
        placer = gp._core.LayerPlacer(scene)
        x, r = run.place(placer)
        run.add(x, r)
        sim = _native(scene, x, r)
        period = np.zeros(dim)
        if container == "periodic":
            period[: dim - 1] = scene.base
        for steps, tol in ((100, 1e-12), (900, 1e-3)):
            run.run(steps)
            sim.step(steps)
            mine = run.local()
            got = mine["x"][np.argsort(mine["id"])]
            diff = got - sim.positions
            # the same point of a periodic cell, whichever image each code keeps
            wrap = period > 0
            diff[:, wrap] -= period[wrap] * np.round(diff[:, wrap] / period[wrap])
            assert np.abs(diff).max() <= tol * r.min()
    finally:
        run.close()


def test_a_pack_on_two_ranks_is_whole_and_recorded(tmp_path):
    scene = _scene(height=0.15)
    reports = []
    pack = gp.generate(scene, engine="lammps", ranks=2, progress=reports.append)
    assert pack.engine == {"name": "lammps", "version": 20250722, "ranks": 2}
    # every particle the placement made, in its order, each with its layer
    assert [rep["layer"] for rep in reports] == list(range(len(pack.layers)))
    assert len(pack) == sum(rep["added"] for rep in pack.layers)
    assert np.all(np.diff(pack.layer) >= 0)
    assert np.bincount(pack.layer).tolist() == [rep["added"] for rep in pack.layers]
    # inside the box, on the floor, no overlap beyond a settled bed's
    r = pack.radii
    assert np.all(pack.positions[:, :2] >= r[:, None] * 0.99)
    assert np.all(pack.positions[:, :2] <= 0.3 - r[:, None] * 0.99)
    assert pack.height == pytest.approx(np.max(pack.positions[:, 2] + r))
    c = pack.contacts
    pairs = c.j >= 0
    assert np.all(c.overlap < 0.01 * r.min())
    # the pairs' forces are LAMMPS': at rest a Hertz force of the overlap, the
    # tangential force perpendicular to the normal and within the Coulomb cone
    m = scene.material
    i, j = c.i[pairs], c.j[pairs]
    r_star = r[i] * r[j] / (r[i] + r[j])
    elastic = 4.0 / 3.0 * m.e_star * np.sqrt(r_star) * c.overlap[pairs] ** 1.5
    assert np.median(c.force_normal[pairs] / elastic) == pytest.approx(1.0, abs=0.01)
    ft = c.force_tangential[pairs]
    assert np.abs(np.sum(ft * c.normal[pairs], axis=1)).max() <= 1e-9 * c.force_normal[pairs].max()
    assert np.all(np.linalg.norm(ft, axis=1) <= m.friction * c.force_normal[pairs] * (1 + 1e-9))
    # the pack file keeps the engine's record
    path = pack.save(tmp_path / "pack.npz")
    assert gp.load_pack(path).engine == pack.engine


@pytest.mark.parametrize("container", ["box", "periodic"])
def test_a_2d_pack_with_a_flat_top(container):
    scene = _scene(2, height=0.12, trim=True, container=container)
    pack = gp.generate(scene, engine="lammps", ranks=2)
    assert pack.positions.shape == (len(pack), 2)
    assert pack.spins.shape == (len(pack),)
    top = pack.positions[:, 1] + pack.radii
    assert top.max() <= 0.12 + 1e-12
    trim = pack.record("trim")
    assert trim is not None and trim.table()["removed"] > 0
    assert len(pack) == sum(rep["added"] for rep in pack.layers) - trim.table()["removed"]
    # the layers' indices survive the removal
    assert np.all(np.diff(pack.layer) >= 0) and pack.layer.max() == len(pack.layers) - 1
    if container == "periodic":
        assert np.all((pack.positions[:, 0] >= 0.0) & (pack.positions[:, 0] < 0.3))


def test_the_tangential_forces_hold_the_bed_up():
    """Each settled particle's forces balance its weight: the gathered normal and
    tangential forces (with the walls') sum to m g per particle within the bed's
    residual motion."""
    scene = _scene(height=0.15, settle_time=1.5)
    pack = gp.generate(scene, engine="lammps", ranks=1)
    c = pack.contacts
    n = len(pack)
    f = np.zeros((n, 3))
    force = c.force_normal[:, None] * c.normal + c.force_tangential
    # force on j (or the wall) is +force; on i it is -force
    np.add.at(f, c.i, -force)
    pairs = c.j >= 0
    np.add.at(f, c.j[pairs], force[pairs])
    mass = scene.material.density * 4.0 / 3.0 * np.pi * pack.radii**3
    f[:, 2] -= mass * scene.gravity
    weight = mass * scene.gravity
    # the walls' tangential forces are not gathered: particles touching a wall may lack
    # their friction, the others balance
    on_wall = np.zeros(n, dtype=bool)
    on_wall[c.i[~pairs]] = True
    ratio = np.linalg.norm(f, axis=1)[~on_wall] / weight[~on_wall]
    assert np.median(ratio) < 0.05


@pytest.mark.slow
@pytest.mark.parametrize("preset", ["4.3", "4.1"])
def test_same_statistics_as_granpacks_engine_on_one_and_two_ranks(preset):
    """Ten packs of a reduced scene with each engine (granpack's; LAMMPS on 1 and on 2
    ranks): the means of phi, phi_core, Z, |a_r| and the particle count lie within one
    standard deviation (the larger of the two ensembles') of each other. A seed's
    particle count on 1 and on 2 ranks differs by whole layers at most: the placement's
    counts are the same, and only the layer at which the height passes the target can
    differ."""
    import warnings

    if preset == "4.3":
        base = gp.PackScene.preset("4.3").replace(base=(0.3, 0.3), height=0.3)
    else:
        base = gp.PackScene.preset("4.1").replace(base=(0.4,), height=0.3)
    keys = ("phi", "phi_core", "z", "a_r_mag", "n")
    rows: dict[tuple[str, int], list[dict[str, float]]] = {}
    layers: dict[tuple[str, int], list[list[int]]] = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for engine, ranks in (("granpack", 1), ("lammps", 1), ("lammps", 2)):
            for seed in range(10):
                pack = gp.generate(base.replace(seed=seed), engine=engine, ranks=ranks)
                d = gp.microstructure(pack).to_dict()
                row = {k: float(d[k]) for k in keys[:-1]}
                row["n"] = float(len(pack))
                rows.setdefault((engine, ranks), []).append(row)
                layers.setdefault((engine, ranks), []).append([rep["added"] for rep in pack.layers])
    stats = {
        run: {k: (np.mean([x[k] for x in v]), np.std([x[k] for x in v], ddof=1)) for k in keys}
        for run, v in rows.items()
    }
    runs = list(stats)
    for a in range(len(runs)):
        for b in range(a + 1, len(runs)):
            for k in keys:
                (ma, sa), (mb, sb) = stats[runs[a]][k], stats[runs[b]][k]
                assert abs(ma - mb) <= max(sa, sb), (runs[a], runs[b], k, ma, mb, sa, sb)
    for one, two in zip(layers[("lammps", 1)], layers[("lammps", 2)], strict=True):
        common = min(len(one), len(two))
        assert one[:common] == two[:common]


# -- errors -------------------------------------------------------------------------------
def test_a_rank_killed_mid_layer_stops_the_run_with_no_pack(tmp_path):
    scene = _scene(height=0.3, settle_time=3.0)
    killed = []

    def kill_a_rank(report):
        if killed:
            return
        for pid in _job_ranks():
            os.kill(pid, signal.SIGKILL)
            killed.append(pid)
            break

    t0 = time.perf_counter()
    with pytest.raises(
        mpi_engine.LammpsRunError, match=r"during layer 1 .*no pack was written"
    ) as e:
        gp.generate(scene, engine="lammps", ranks=2, progress=kill_a_rank)
    assert killed
    assert e.value.layer == 1
    # the job ends at once, not at its natural end (every layer: tens of seconds)
    assert time.perf_counter() - t0 < 60
    assert not _job_ranks()


def test_a_callback_that_raises_stops_every_rank():
    """The caller's exception (Ctrl-C, a progress callback that raised) ends the job:
    no rank keeps running."""
    scene = _scene(height=0.3, settle_time=3.0)
    ranks: list[int] = []

    def stop(report):
        ranks.extend(_job_ranks())
        raise RuntimeError("stop here")

    with pytest.raises(RuntimeError, match="stop here"):
        gp.generate(scene, engine="lammps", ranks=2, progress=stop)
    assert len(ranks) == 2

    def alive(pid: int) -> bool:
        try:
            state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
        except OSError:
            return False
        return state != "Z"

    # the ranks end even once no longer this process's descendants
    deadline = time.monotonic() + 10
    while any(alive(p) for p in ranks) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not any(alive(p) for p in ranks)


def _job_ranks() -> list[int]:
    """The pids of the ranks (``python -m granpack.mpi``) of the MPI job this process
    started: its descendants, so that another job on the machine is left alone."""

    def parent(pid: int) -> int:
        try:
            stat = Path(f"/proc/{pid}/stat").read_text()
        except OSError:
            return 0
        return int(stat.rsplit(")", 1)[1].split()[1])

    me = os.getpid()
    pids = []
    for proc in Path("/proc").iterdir():
        if not proc.name.isdigit():
            continue
        try:
            cmd = (proc / "cmdline").read_bytes().split(b"\0")
        except OSError:
            continue
        if b"granpack.mpi" not in cmd or b"-m" not in cmd or b"mpiexec" in cmd[0]:
            continue
        up, pid = 0, int(proc.name)
        while pid > 1 and up < 6:
            pid, up = parent(pid), up + 1
            if pid == me:
                pids.append(int(proc.name))
                break
    return sorted(pids)


def test_lammps_errors_name_the_layer():
    from lammps import lammps
    from mpi4py import MPI

    scene = _scene()
    run = mpi_engine._Run(scene, MPI.COMM_WORLD, lammps)
    try:
        placer = gp._core.LayerPlacer(scene)
        run.layer = 0
        run.add(*run.place(placer))
        with pytest.raises(mpi_engine.LammpsRunError, match="layer 0") as e:
            # a particle thrown through the side wall is lost: LAMMPS stops the run
            run.command("set atom 1 vx 1000.0")
            run.run(200)
        assert e.value.layer == 0
        assert "Lost atoms" in str(e.value) or "lost" in str(e.value).lower()
    finally:
        run.close()


@pytest.mark.parametrize(
    ("kwargs", "error", "words"),
    [
        ({"engine": "yade"}, gp.InvalidParameterError, "engine"),
        ({"ranks": 2}, gp.InvalidParameterError, "ranks"),
        ({"engine": "lammps", "ranks": 0}, gp.InvalidParameterError, "ranks"),
        ({"engine": "lammps", "ranks": 1.5}, gp.InvalidParameterError, "ranks"),
        # a 0.3 m square base holds 7 x 7 columns of one diameter (0.04 m)
        ({"engine": "lammps", "ranks": 50}, gp.InvalidParameterError, r"ranks.*\b49\b"),
        (
            {"engine": "lammps", "mpiexec": "no-such-mpiexec"},
            mpi_engine.EngineUnavailableError,
            "mpiexec",
        ),
    ],
)
def test_bad_engine_settings_are_named(kwargs, error, words):
    with pytest.raises(error, match=words):
        gp.generate(_scene(), **kwargs)


def test_a_scene_the_lammps_path_cannot_map_is_named():
    with pytest.raises(LammpsMappingError, match="material.damping"):
        gp.generate(_scene(material=gp.Material(damping=0.95)), engine="lammps")
    with pytest.raises(gp.InvalidParameterError, match="engine.*density target"):
        gp.generate(_scene(target_phi=0.6), engine="lammps")


def test_missing_modules_name_the_extra(monkeypatch):
    import importlib.util

    real = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util, "find_spec", lambda name, *a: None if name == "lammps" else real(name, *a)
    )
    with pytest.raises(mpi_engine.EngineUnavailableError, match=r"granpack\[mpi\]"):
        gp.generate(_scene(), engine="lammps")


def test_no_mpiexec_names_the_extra(monkeypatch, tmp_path):
    monkeypatch.delenv(launch.MPIEXEC_ENV, raising=False)
    monkeypatch.setattr(launch.sys, "executable", str(tmp_path / "python"))
    monkeypatch.setenv("PATH", str(tmp_path))
    with pytest.raises(mpi_engine.EngineUnavailableError, match=r"mpiexec.*granpack\[mpi\]"):
        launch.mpiexec_command()
