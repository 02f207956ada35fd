"""Contacts are checked against the particles: a contact table whose ids come from another
run, step or numbering names particles that do not touch, and every way into the analysis
(read_contacts, ParticleFile.with_contacts, microstructure(contacts=...), a pack file's
stored contacts, granpack analyze --contacts) refuses it, naming the first such pair and
its gap. Contacts that touch within the printed precision of the positions still read."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

import granpack as gp
from granpack.cli import main

R = 0.01
SPACING = 0.0199  # lattice neighbours overlap by 1e-4 m
N_SIDE = (5, 4, 3)  # particles per axis: 60


def lattice(periodic: bool = False):
    """(positions, radii, box, contacts (i, j) of neighbours): a simple cubic lattice of
    touching spheres; in a periodic cell (x and y), neighbours across the seam too."""
    g = np.stack(np.meshgrid(*[np.arange(k) for k in N_SIDE], indexing="ij"), -1).reshape(-1, 3)
    x = 0.3 + g * SPACING
    x[:, 2] = R + g[:, 2] * SPACING
    r = np.full(len(x), R)
    lo = np.array([0.3 - 0.5 * SPACING, 0.3 - 0.5 * SPACING, 0.0])
    hi = lo + np.array([N_SIDE[0] * SPACING, N_SIDE[1] * SPACING, 1.0])
    index = {tuple(v): k for k, v in enumerate(g.tolist())}
    pairs = []
    for k, v in enumerate(g.tolist()):
        for ax in range(3):
            w = list(v)
            w[ax] += 1
            if periodic and ax < 2:
                w[ax] %= N_SIDE[ax]
            q = index.get(tuple(w))
            if q is not None and q != k:
                pairs.append((k, q))
    return x, r, (lo, hi), np.array(pairs)


def min_image(b, periods):
    """Difference vectors by minimum image along the finite periods."""
    if periods is None:
        return b
    per = np.asarray(periods, dtype=float)
    fin = np.isfinite(per)
    b = b.copy()
    b[:, fin] -= per[fin] * np.round(b[:, fin] / per[fin])
    return b


def atoms_dump(path: Path, x, r, box, periodic: bool = False) -> Path:
    """A LAMMPS dump custom of ids 1..N, printed with LAMMPS' default %g (6 digits)."""
    flags = "pp pp ff" if periodic else "ff ff ff"
    lines = [
        "ITEM: TIMESTEP",
        "100",
        "ITEM: NUMBER OF ATOMS",
        str(len(x)),
        f"ITEM: BOX BOUNDS {flags}",
    ]
    lines += [f"{a:g} {b:g}" for a, b in zip(*box, strict=True)]
    lines.append("ITEM: ATOMS id x y z radius")
    lines += [
        f"{k + 1} {p[0]:g} {p[1]:g} {p[2]:g} {q:g}"
        for k, (p, q) in enumerate(zip(x, r, strict=True))
    ]
    path.write_text("\n".join(lines) + "\n")
    return path


def contact_dump(path: Path, layout: str, x, pairs, ids1, ids2, periods=None) -> Path:
    """A dump local of `pairs` in `layout` (the columns of LIGGGHTS pair/gran/local or of
    LAMMPS property/local + pair/local), the particles named by ids1 and ids2, with a
    unit normal force pushing the pair apart."""
    i, j = pairs[:, 0], pairs[:, 1]
    b = min_image(x[j] - x[i], periods)
    n = b / np.linalg.norm(b, axis=1)[:, None]
    f = -n  # the force on the first particle
    rows = []
    for k in range(len(pairs)):
        fx = " ".join(f"{v:.9g}" for v in f[k])
        pos = " ".join(f"{v:.9g}" for v in (*x[i[k]], *x[j[k]]))
        if layout == "liggghts":
            rows.append(f"{pos} {ids1[k]} {ids2[k]} 0 {fx}")
        elif layout == "liggghts-full":
            rows.append(f"{pos} {ids1[k]} {ids2[k]} 0 {fx} {fx} 0 0 0 1e-4")
        else:
            rows.append(f"{ids1[k]} {ids2[k]} {fx} 0 0 0")
    ncol = {"liggghts": 12, "liggghts-full": 19, "lammps": 8}[layout]
    head = ["ITEM: TIMESTEP", "100", "ITEM: NUMBER OF ENTRIES", str(len(rows))]
    head += ["ITEM: BOX BOUNDS ff ff ff", "0 1", "0 1", "0 1"]
    head.append("ITEM: ENTRIES " + " ".join(f"c_c[{k}]" for k in range(1, ncol + 1)))
    path.write_text("\n".join(head + rows) + "\n")
    return path


LAYOUTS = ["liggghts", "liggghts-full", "lammps"]


@pytest.mark.parametrize("periodic", [False, True], ids=["box", "periodic"])
@pytest.mark.parametrize("layout", LAYOUTS)
def test_a_correct_contact_file_reads_and_gives_the_lattice_coordination(
    tmp_path, layout, periodic
):
    x, r, box, pairs = lattice(periodic)
    p = gp.read_particles(atoms_dump(tmp_path / "atoms.dump", x, r, box, periodic))
    periods = np.array([*(box[1] - box[0])[:2], np.inf]) if periodic else None
    path = contact_dump(
        tmp_path / "pairs.dump", layout, x, pairs, pairs[:, 0] + 1, pairs[:, 1] + 1, periods
    )
    found = gp.read_contacts(path, p)
    assert found.layout == layout and len(found) == len(pairs)
    m = gp.microstructure(p.with_contacts(found), core_margin=0.0)
    assert m.n_contacts == len(pairs) and m.has_forces
    assert m.z == pytest.approx(2 * len(pairs) / len(x))


@settings(
    max_examples=40,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.filter_too_much],
)
@given(
    layout=st.sampled_from(LAYOUTS),
    periodic=st.booleans(),
    how=st.sampled_from(["shuffled", "offset"]),
    seed=st.integers(0, 2**32 - 1),
    offset=st.integers(1, 59),
)
def test_contacts_with_ids_of_another_numbering_are_refused(
    tmp_path_factory, layout, periodic, how, seed, offset
):
    """Every id exists and every pair is of two particles: only the geometry tells that
    the ids are another numbering's, and read_contacts refuses the file by it."""
    tmp = tmp_path_factory.mktemp("c")
    x, r, box, pairs = lattice(periodic)
    n = len(x)
    if how == "shuffled":
        perm = np.random.default_rng(seed).permutation(n)
    else:
        perm = (np.arange(n) + offset) % n
    i2, j2 = perm[pairs[:, 0]], perm[pairs[:, 1]]
    periods = np.array([*(box[1] - box[0])[:2], np.inf]) if periodic else np.full(3, np.inf)
    b = min_image(x[j2] - x[i2], periods)
    # the lattice's distances: touching (1e-4 m overlap), or apart by 8e-3 m or more
    apart = np.linalg.norm(b, axis=1) > 2 * R
    assume(apart.any())
    p = gp.read_particles(atoms_dump(tmp / "atoms.dump", x, r, box, periodic))
    # the rows are written with the true geometry's forces, the ids of the other numbering
    path = contact_dump(tmp / "pairs.dump", layout, x, pairs, i2 + 1, j2 + 1)
    with pytest.raises(gp.FileFormatError) as info:
        gp.read_contacts(path, p)
    k = int(np.argmax(apart))
    message = str(info.value)
    assert info.value.path == path
    assert f"{path}:{10 + k}:" in message, message
    assert f"particle ids {i2[k] + 1} and {j2[k] + 1} do not touch" in message, message
    gap = np.linalg.norm(b[k]) - 2 * R
    assert f"{gap:.6g} m apart" in message, message
    assert f"{int(apart.sum())} of {len(pairs)} contacts" in message or apart.sum() == 1


def test_contacts_touching_within_the_printed_precision_still_read(tmp_path):
    """Pairs that barely touch, their positions printed with six digits: the rounding
    moves the printed surfaces apart by far more than 1e-6 of a radius, which the check
    allows for, counting the digits the file printed."""
    rng = np.random.default_rng(5)
    m = 300
    a = rng.uniform(0.2, 0.8, (m, 3)) + np.arange(m)[:, None] * np.array([1.0, 0.0, 0.0])
    u = rng.normal(size=(m, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    b = a + u * 2 * R * (1 - 1e-8)
    x = np.empty((2 * m, 3))
    x[0::2], x[1::2] = a, b
    r = np.full(2 * m, R)
    box = (x.min(axis=0) - 1, x.max(axis=0) + 1)
    p = gp.read_particles(atoms_dump(tmp_path / "atoms.dump", x, r, box))
    printed = np.linalg.norm(p.positions[1::2] - p.positions[0::2], axis=1) - 2 * R
    assert printed.max() > 1e-6 * R  # the six digits alone put some surfaces apart
    pairs = np.column_stack([np.arange(0, 2 * m, 2), np.arange(1, 2 * m, 2)])
    path = contact_dump(
        tmp_path / "pairs.dump", "liggghts", x, pairs, pairs[:, 0] + 1, pairs[:, 1] + 1
    )
    assert len(gp.read_contacts(path, p)) == m


def test_contacts_of_single_precision_positions_still_touch():
    """Positions stored as float32 (7 digits): barely touching pairs move apart by up to
    half a float32 unit per coordinate, which the check allows for."""
    rng = np.random.default_rng(8)
    m = 300
    a = rng.uniform(0.2, 0.8, (m, 3)) + np.arange(m)[:, None] * np.array([0.1, 0.0, 0.0])
    u = rng.normal(size=(m, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    x = np.empty((2 * m, 3))
    x[0::2], x[1::2] = a, a + u * 2 * R * (1 - 1e-9)
    x = x.astype(np.float32).astype(float)
    r = np.full(2 * m, R)
    gaps = np.linalg.norm(x[1::2] - x[0::2], axis=1) - 2 * R
    assert gaps.max() > 1e-6 * R
    pairs = {"i": np.arange(0, 2 * m, 2), "j": np.arange(1, 2 * m, 2), "normal": u}
    m_ = gp.microstructure(positions=x, radii=r, contacts=pairs, core_margin=0.0)
    assert m_.n_contacts == m


def test_analyze_with_contacts_of_another_run_exits_with_the_message(tmp_path, capsys):
    x, r, box, pairs = lattice()
    atoms = atoms_dump(tmp_path / "atoms.dump", x, r, box)
    perm = np.random.default_rng(0).permutation(len(x))
    bad = contact_dump(
        tmp_path / "other.dump", "liggghts", x, pairs, perm[pairs[:, 0]] + 1, perm[pairs[:, 1]] + 1
    )
    assert main(["analyze", str(atoms), "--contacts", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "other.dump" in err and "do not touch" in err and "m apart" in err, err
    good = contact_dump(
        tmp_path / "pairs.dump", "lammps", x, pairs, pairs[:, 0] + 1, pairs[:, 1] + 1
    )
    assert main(["analyze", str(atoms), "--contacts", str(good), "--json"]) == 0


def test_arrays_given_to_the_analysis_are_checked(tmp_path):
    x, r, box, pairs = lattice()
    perm = np.random.default_rng(1).permutation(len(x))
    m = len(pairs)
    good = {"i": pairs[:, 0], "j": pairs[:, 1], "normal": np.tile([1.0, 0, 0], (m, 1))}
    gp.microstructure(positions=x, radii=r, contacts=good, box=box, core_margin=0.0)
    bad = dict(good, i=perm[pairs[:, 0]], j=perm[pairs[:, 1]])
    with pytest.raises(gp.InvalidParameterError, match="do not touch") as info:
        gp.microstructure(positions=x, radii=r, contacts=bad, box=box)
    assert info.value.parameter == "contacts"
    assert "m apart" in str(info.value)
    # with_contacts takes granpack.Contacts: arrays are named as such
    p = gp.read_particles(atoms_dump(tmp_path / "atoms.dump", x, r, box))
    zeros = np.zeros((m, 3))
    c = gp.Contacts(
        i=bad["i"],
        j=bad["j"],
        normal=bad["normal"],
        overlap=np.zeros(m),
        force_normal=np.ones(m),
        force_tangential=zeros,
        branch=zeros,
    )
    with pytest.raises(gp.InvalidParameterError, match="invalid contacts: contact"):
        p.with_contacts(c)


def test_with_contacts_of_other_particles_names_the_contact_file(tmp_path):
    x, r, box, pairs = lattice()
    p = gp.read_particles(atoms_dump(tmp_path / "atoms.dump", x, r, box))
    path = contact_dump(
        tmp_path / "pairs.dump", "liggghts", x, pairs, pairs[:, 0] + 1, pairs[:, 1] + 1
    )
    found = gp.read_contacts(path, p)
    # the same ids, another arrangement: the particles of a later step, say
    shuffled = x[np.random.default_rng(2).permutation(len(x))]
    moved = gp.read_particles(atoms_dump(tmp_path / "later.dump", shuffled, r, box))
    with pytest.raises(gp.FileFormatError, match="do not touch") as info:
        moved.with_contacts(found)
    assert info.value.path == path and "pairs.dump" in str(info.value)


def _box_pack(dim: int, container: str = "box") -> gp.Pack:
    if dim == 3:
        scene = gp.PackScene(
            dim=3,
            base=(0.12, 0.12),
            height=0.05,
            r_mean=0.006,
            phi_layer=0.3,
            settle_time=0.35,
            container=container,
            seed=2,
        )
    else:
        scene = gp.PackScene(
            dim=2, base=(0.3,), height=0.06, r_mean=0.006, container=container, seed=2
        )
    return gp.generate(scene, progress=False)


@pytest.mark.filterwarnings("ignore")
@pytest.mark.parametrize(
    "dim,container", [(3, "box"), (3, "periodic"), (3, "cylinder"), (2, "box"), (2, "periodic")]
)
def test_a_pack_files_contacts_are_checked_walls_too(tmp_path, dim, container):
    pack = _box_pack(dim, container)
    c = pack.contacts
    gp.microstructure(pack)  # the engine's own contacts touch, across the seam too
    path = pack.save(tmp_path / "pack.npz")
    pf = gp.read_particles(path)
    gp.microstructure(pf)
    pf.with_contacts(pf.contacts)
    # a particle pair renumbered: refused, naming the pack file
    pp = np.flatnonzero(c.j >= 0)
    far = int(np.argmax(pack.positions[:, -1]))
    i = c.i.copy()
    k = next(
        k
        for k in pp
        if far not in (c.i[k], c.j[k])
        and np.linalg.norm(pack.positions[far] - pack.positions[c.j[k]]) > 4 * pack.radii.max()
    )
    i[k] = far
    tampered = dataclasses.replace(pack, contacts=dataclasses.replace(c, i=i))
    bad = tampered.save(tmp_path / "bad.npz")
    with pytest.raises(gp.FileFormatError, match="do not touch") as info:
        gp.microstructure(gp.read_particles(bad))
    assert info.value.path == bad and "bad.npz" in str(info.value)
    with pytest.raises(gp.InvalidParameterError, match="invalid pack.contacts"):
        gp.microstructure(tampered)
    # a floor contact moved to the highest particle: the wall is checked too
    floor = np.flatnonzero(c.j == -1)
    i = c.i.copy()
    i[floor[0]] = far
    lifted = dataclasses.replace(pack, contacts=dataclasses.replace(c, i=i))
    with pytest.raises(
        gp.InvalidParameterError, match=r"does not touch the floor wall \(wall id -1\)"
    ):
        gp.microstructure(lifted)
    # a side wall's contact (the cylinder's, or x = lo) moved to the particle farthest from it
    side = np.flatnonzero(c.j == -2)
    if side.size:
        x = pack.positions
        if container == "cylinder":
            axis = np.asarray(pack.scene.base) / 2
            away = int(np.argmin(np.linalg.norm(x[:, :2] - axis, axis=1)))
            words = "does not touch the cylinder wall"
        else:
            away = int(np.argmax(x[:, 0]))
            words = "does not touch the x = lo wall"
        i = c.i.copy()
        i[side[0]] = away
        moved = dataclasses.replace(pack, contacts=dataclasses.replace(c, i=i))
        with pytest.raises(gp.InvalidParameterError, match=words):
            gp.microstructure(moved)


@pytest.mark.filterwarnings("ignore::granpack.analysis.MicrostructureWarning")
def test_a_wall_the_container_does_not_have_is_refused():
    x, r, box, pairs = lattice()
    lo, hi = box
    q = 0  # touches the floor and the x = lo and y = lo walls of a tight box
    x = x.copy()
    tight = (lo, hi)
    m = {"i": np.array([q]), "j": np.array([-2]), "normal": np.array([[-1.0, 0, 0]])}
    gp.microstructure(positions=x, radii=r, contacts=m, box=tight, core_margin=0.0)
    with pytest.raises(gp.InvalidParameterError, match="the periodic container does not have"):
        gp.microstructure(positions=x, radii=r, contacts=m, box=tight, periodic=[True, True])
    x2, r2 = x[:, [0, 2]], r
    m2 = {"i": np.array([q]), "j": np.array([-4]), "normal": np.array([[0.0, -1.0]])}
    with pytest.raises(gp.InvalidParameterError, match="wall id -4, which the box container"):
        gp.microstructure(positions=x2, radii=r2, contacts=m2, box=(lo[[0, 2]], hi[[0, 2]]))


def test_contacts_across_a_periodic_vertical_side_are_named_as_such(tmp_path):
    """A fully periodic dump (pp pp pp): read_contacts takes the pairs across the vertical
    seam by the file's minimum image; the analysis bounds the vertical axis, so
    with_contacts refuses them, saying why."""
    x, r, box, pairs = lattice(periodic=True)
    lo, hi = box
    hi = hi.copy()
    hi[2] = lo[2] + N_SIDE[2] * SPACING + R - 0.5 * SPACING
    lo = lo.copy()
    lo[2] = R - 0.5 * SPACING
    g = np.round((x - x.min(axis=0)) / SPACING).astype(int)
    top = np.flatnonzero(g[:, 2] == N_SIDE[2] - 1)
    across = np.array(
        [(k, int(np.flatnonzero((g[:, :2] == g[k, :2]).all(1) & (g[:, 2] == 0))[0])) for k in top]
    )
    path = tmp_path / "atoms.dump"
    atoms_dump(path, x, r, (lo, hi), periodic=True)
    path.write_text(path.read_text().replace("pp pp ff", "pp pp pp"))
    p = gp.read_particles(path)
    periods = hi - lo
    both = np.vstack([pairs, across])
    found = gp.read_contacts(
        contact_dump(
            tmp_path / "pairs.dump", "liggghts", x, both, both[:, 0] + 1, both[:, 1] + 1, periods
        ),
        p,
    )
    assert len(found) == len(both)
    with pytest.raises(gp.FileFormatError, match="across the file's periodic z side"):
        p.with_contacts(found)
