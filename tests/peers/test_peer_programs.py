"""granpack's exports run in LAMMPS and LIGGGHTS themselves, and what they write comes back.

- ``in.granpack`` (the export's input snippet) runs in LAMMPS (3D, 2D with each mass
  convention) and LIGGGHTS (3D); their ``compute contact/atom`` summed is 2 N_c of the
  pack, and their masses are granpack's;
- a LAMMPS ``write_dump`` of that state, read by read_particles: the same positions and
  contacts;
- LIGGGHTS ``compute pair/gran/local`` and LAMMPS ``compute pair/local`` dumps read by
  read_contacts: the f0, a^n, a^t the test computes by hand from the same numbers, and
  normal forces close to granpack's own for the same overlaps.

The programs are the Debian packages ``lammps`` (29Sep2021) and ``liggghts`` (3.8);
``.ci/run`` installs them. Each run is a few steps on a pack of tens of particles."""

from __future__ import annotations

import math
import subprocess

import numpy as np
import pytest
from peer_runs import run
from scenes import small_scene

import granpack as gp
from granpack.io import export
from granpack.io.lammps import read_lammps_data

CORE = 0.02  # a core window that fits in the small packs (m)


@pytest.fixture(scope="module")
def pack3d() -> gp.Pack:
    return gp.generate(small_scene(3))


@pytest.fixture(scope="module", params=["sphere", "disc"])
def pack2d(request) -> gp.Pack:
    return gp.generate(small_scene(2, inertia_2d=request.param))


def mass(pack: gp.Pack) -> np.ndarray:
    r = pack.radii
    rho = pack.scene.material.density
    if pack.dim == 2 and pack.scene.inertia_2d == "disc":
        return rho * math.pi * r**2
    return rho * 4.0 / 3.0 * math.pi * r**3


def n_pairs(pack: gp.Pack) -> int:
    return int((pack.contacts.j >= 0).sum())


AFTER = """write_dump all custom state.dump id type x y z radius mass modify format float %.17g
print "CONTACTS $(c_contacts)"
"""
# LIGGGHTS 3.8 takes a format line, not "format float"
AFTER_LIGGGHTS = """write_dump all custom state.dump id type x y z radius mass modify format \
"%d %d %.17g %.17g %.17g %.17g %.17g"
print "CONTACTS $(c_contacts)"
"""


def _contacts_printed(log: str) -> float:
    line = next(ln for ln in log.splitlines() if ln.startswith("CONTACTS "))
    return float(line.split()[1])


def _check_state(pack: gp.Pack, state) -> None:
    assert state.dim == pack.dim
    np.testing.assert_array_equal(state.ids, np.arange(1, len(pack) + 1))
    np.testing.assert_array_equal(state.positions, pack.positions)
    np.testing.assert_array_equal(state.radii, pack.radii)
    m = gp.microstructure(state, core_margin=CORE)
    assert m.n_contacts == n_pairs(pack)


def test_lammps_runs_the_snippet_with_the_same_contacts_and_masses(lmp, tmp_path, pack3d, pack2d):
    for pack in (pack3d, pack2d):
        written = export(pack, tmp_path / "pack.data", "lammps-data")
        assert [p.name for p in written] == ["pack.data", "in.granpack"]
        log = run(lmp, tmp_path, "include in.granpack\n" + AFTER)
        assert _contacts_printed(log) == 2 * n_pairs(pack)
        state = gp.read_particles(tmp_path / "state.dump")
        raw = np.loadtxt(tmp_path / "state.dump", skiprows=9)
        raw = raw[np.argsort(raw[:, 0])]
        np.testing.assert_allclose(raw[:, 6], mass(pack), rtol=1e-14)
        _check_state(pack, state)
        # and a step of the run: the snippet's physics runs
        run(lmp, tmp_path, "variable steps index 1\ninclude in.granpack\n")


def test_liggghts_runs_the_snippet_with_the_same_contacts_and_masses(liggghts, tmp_path, pack3d):
    pack = pack3d
    written = export(pack, tmp_path / "pack.data", "liggghts")
    assert "atom_style      granular" in written[1].read_text()
    log = run(liggghts, tmp_path, "include in.granpack\n" + AFTER_LIGGGHTS)
    assert _contacts_printed(log) == 2 * n_pairs(pack)
    raw = np.loadtxt(tmp_path / "state.dump", skiprows=9)
    raw = raw[np.argsort(raw[:, 0])]
    np.testing.assert_allclose(raw[:, 6], mass(pack), rtol=1e-14)
    _check_state(pack, gp.read_particles(tmp_path / "state.dump"))
    run(liggghts, tmp_path, "variable steps index 1\ninclude in.granpack\n")


def test_liggghts_refuses_a_2d_pack(tmp_path, pack2d):
    with pytest.raises(gp.InvalidParameterError, match="no 2D granular model"):
        export(pack2d, tmp_path / "pack.data", "liggghts")
    assert not (tmp_path / "pack.data").exists()


# -- contact forces ----------------------------------------------------------------------------
def _by_hand(pos, ids, id1, id2, force):
    """f0, a^n, a^t of the bin-free estimator, from the dump's numbers (3D)."""
    k1 = np.searchsorted(ids, id1)
    k2 = np.searchsorted(ids, id2)
    b = pos[k2] - pos[k1]
    n = b / np.linalg.norm(b, axis=1)[:, None]
    fi_n = np.sum(force * n, axis=1)
    fn = np.maximum(-fi_n, 0.0)
    ft = -(force - fi_n[:, None] * n)
    m = len(n)
    fab = n.T @ n / m
    a_r = 7.5 * (fab - np.eye(3) / 3)
    w = 1.0 + np.einsum("ci,ij,cj->c", n, a_r, n)
    xn = (n * (fn / w)[:, None]).T @ n / m
    f0 = np.trace(xn)
    xt = (ft / w[:, None]).T @ n / m
    xt = 0.5 * (xt + xt.T)
    xt -= np.trace(xt) / 3 * np.eye(3)
    return f0, 7.5 * (xn / f0 - np.eye(3) / 3), 5.0 * xt / f0, fn


def _last_snapshot(path) -> np.ndarray:
    lines = path.read_text().splitlines()
    start = max(k for k, ln in enumerate(lines) if ln.startswith("ITEM: ENTRIES")) + 1
    return np.array([ln.split() for ln in lines[start:]], dtype=np.float64)


def _pair_normal_forces(pack: gp.Pack, k1, k2) -> np.ndarray:
    c = pack.contacts.particle_pairs()
    table = {(int(a), int(b)): f for a, b, f in zip(c.i, c.j, c.force_normal, strict=True)}
    pairs = zip(k1.tolist(), k2.tolist(), strict=True)
    return np.array([table.get((a, b), table.get((b, a), np.nan)) for a, b in pairs])


LIGGGHTS_PAIRS = """compute         pairs all pair/gran/local pos id force
dump            pairs all local 1 pairs.dump {cols}
dump_modify     pairs format "{fmt}"
run             1
"""


def test_liggghts_pair_forces_give_the_hand_computed_f0_an_at(liggghts, tmp_path, pack3d):
    pack = pack3d
    export(pack, tmp_path / "pack.data", "liggghts")
    snippet = (tmp_path / "in.granpack").read_text()
    cols = " ".join(f"c_pairs[{k}]" for k in range(1, 13))
    extra = LIGGGHTS_PAIRS.format(cols=cols, fmt=" ".join(["%.17g"] * 12))
    # the compute must come before the first run
    text = snippet.replace("run             ${steps}", extra) + AFTER_LIGGGHTS
    run(liggghts, tmp_path, text)
    particles = gp.read_particles(tmp_path / "state.dump")
    found = gp.read_contacts(tmp_path / "pairs.dump", particles)
    # two snapshots (steps 0 and 1): the one of the particles' step is read
    assert found.n_snapshots == 2 and found.timestep == particles.timestep == 1
    assert found.layout == "liggghts" and len(found) == n_pairs(pack)
    m = gp.microstructure(particles.with_contacts(found), core_margin=CORE)
    rows = _last_snapshot(tmp_path / "pairs.dump")
    f0, a_n, a_t, fn = _by_hand(
        particles.positions, particles.ids, rows[:, 6], rows[:, 7], rows[:, 9:12]
    )
    assert m.has_forces and m.n_contacts == len(found)
    assert m.f0 == pytest.approx(f0, rel=1e-12)
    np.testing.assert_allclose(m.a_n, a_n, rtol=0, atol=1e-12)
    np.testing.assert_allclose(m.a_t, a_t, rtol=0, atol=1e-12)
    # the same law: LIGGGHTS' normal forces are granpack's for the same overlaps, to the
    # share of the damping and the step between them
    mine = _pair_normal_forces(pack, found.contacts.i, found.contacts.j)
    loaded = mine > 1e-3 * np.max(mine)
    np.testing.assert_allclose(fn[loaded], mine[loaded], rtol=0.05)


LAMMPS_PAIRS = """compute         ids all property/local patom1 patom2 cutoff radius
compute         pl all pair/local fx fy fz p1 p2 p3 cutoff radius
dump            pairs all local 1 pairs.dump c_ids[1] c_ids[2] c_pl[1] c_pl[2] c_pl[3] \
c_pl[4] c_pl[5] c_pl[6]
dump_modify     pairs format float %.17g
run             0
"""


def test_lammps_pair_local_read_by_read_contacts(lmp, tmp_path, pack3d):
    pack = pack3d
    export(pack, tmp_path / "pack.data", "lammps-data")
    snippet = (tmp_path / "in.granpack").read_text()
    text = snippet.replace("run             ${steps}", LAMMPS_PAIRS) + AFTER
    run(lmp, tmp_path, text)
    particles = gp.read_particles(tmp_path / "state.dump")
    found = gp.read_contacts(tmp_path / "pairs.dump", particles)
    assert found.layout == "lammps" and len(found) == n_pairs(pack)
    rows = _last_snapshot(tmp_path / "pairs.dump")
    f0, a_n, a_t, fn = _by_hand(
        particles.positions, particles.ids, rows[:, 0], rows[:, 1], rows[:, 2:5] + rows[:, 5:8]
    )
    m = gp.microstructure(particles.with_contacts(found), core_margin=CORE)
    assert m.f0 == pytest.approx(f0, rel=1e-12)
    np.testing.assert_allclose(m.a_n, a_n, rtol=0, atol=1e-12)
    np.testing.assert_allclose(m.a_t, a_t, rtol=0, atol=1e-12)
    mine = _pair_normal_forces(pack, found.contacts.i, found.contacts.j)
    loaded = mine > 1e-3 * np.max(mine)
    np.testing.assert_allclose(fn[loaded], mine[loaded], rtol=0.05)


CONTAINER_SCENES = {
    "periodic 3d": small_scene(3, container="periodic"),
    "periodic 2d": small_scene(2, container="periodic"),
    "cylinder": small_scene(3, container="cylinder"),
}


def _step0_contacts(program: str, run_dir) -> float:
    done = subprocess.run(
        [program, "-in", "in.granpack", "-log", "log.run"],
        cwd=run_dir,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-2000:]
    lines = (run_dir / "log.run").read_text().splitlines()
    k = max(n for n, ln in enumerate(lines) if ln.split()[:1] == ["Step"])
    return float(lines[k + 1].split()[3])


@pytest.mark.parametrize("name", list(CONTAINER_SCENES))
def test_peers_count_the_contacts_of_packs_made_in_each_container(name, lmp, liggghts, tmp_path):
    # the engine's periodic and cylinder packs: LAMMPS (and LIGGGHTS in 3D) find the
    # same particle-particle contacts, across the seam too
    pack = gp.generate(CONTAINER_SCENES[name])
    export(pack, tmp_path / "pack.data", "lammps-data")
    assert _step0_contacts(lmp, tmp_path) == 2 * n_pairs(pack)
    if pack.dim == 3:
        export(pack, tmp_path / "pack.data", "liggghts")
        assert _step0_contacts(liggghts, tmp_path) == 2 * n_pairs(pack)


def test_lammps_write_data_of_the_4_3_pack_reads_back(lmp, tmp_path, example_4_3):
    # LAMMPS reads granpack's data export of example 4.3 and writes it again with its own
    # write_data (image flags on every Atoms row, a Velocities section); granpack reads
    # that back with the pack's ids, positions, radii, velocities and box, bit for bit
    pack = example_4_3
    export(pack, tmp_path / "pack.data", "lammps-data")
    run(
        lmp,
        tmp_path,
        "units si\natom_style sphere\nboundary p p f\nread_data pack.data\n"
        "pair_style zero 1.0\npair_coeff * *\nwrite_data out.data\n",
    )
    text = (tmp_path / "out.data").read_text()
    atoms = text.split("Atoms # sphere")[1].split("Velocities")[0]
    assert {len(row.split()) for row in atoms.splitlines() if row.strip()} == {10}
    p = gp.read_particles(tmp_path / "out.data")
    assert p.format == "lammps-data" and p.dim == 3 and len(p) == len(pack)
    np.testing.assert_array_equal(p.ids, np.arange(1, len(pack) + 1))
    np.testing.assert_array_equal(p.positions, pack.positions)
    np.testing.assert_array_equal(p.radii, pack.radii)
    np.testing.assert_array_equal(p.box[0], pack.box[0])
    np.testing.assert_array_equal(p.box[1], pack.box[1])
    data = read_lammps_data(tmp_path / "out.data")
    np.testing.assert_array_equal(data["velocities"], pack.velocities)
    # LAMMPS' own file carries no container: the analysis says it assumed the box
    m = gp.microstructure(p, core_margin=0.05)
    assert (m.container, m.container_source) == ("box", "assumed")
    assert m.n_contacts == gp.microstructure(pack, core_margin=0.05).n_contacts
