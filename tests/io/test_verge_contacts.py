"""A peer's own contact list reads as the peer counts it, and a list of pairs that do not
touch is refused.

The DEM codes list pairs at zero force on the verge of contact: YADE keeps an
interaction whose spheres parted in the last step until its collider's next pass (and
computes the forces before it moves the spheres). Such a pair, within
`VERGE_GAP_TOLERANCE` (1e-2) of the smaller radius, is counted as listed, with a note; a pair
that carries force across a gap, or any pair farther apart, is refused. The precision
the check allows for the printed positions is read from the file's text (never fewer
than `MIN_PRINTED_DIGITS` digits), so that a lattice of whole numbers printed with %.17g
is not taken for a file printed with one digit."""

from __future__ import annotations

import numpy as np
import pytest

import granpack as gp
from granpack.analysis.inputs import (
    CONTACT_GAP_TOLERANCE,
    MIN_PRINTED_DIGITS,
    VERGE_GAP_TOLERANCE,
    written_digits,
)

R = 0.02  # m, the radius of the paper's 4.3 spheres
PAIRS = "id1 id2 fnx fny fnz ftx fty ftz -"


def box_head(n: int, item: str, box: str) -> str:
    return f"ITEM: TIMESTEP\n0\nITEM: NUMBER OF {item}\n{n}\nITEM: BOX BOUNDS ff ff ff\n{box}\n"


def atoms_dump(path, rows: list[str], box: str = "0 1\n0 1\n0 1") -> gp.ParticleFile:
    path.write_text(
        box_head(len(rows), "ATOMS", box) + "ITEM: ATOMS id x y z radius\n" + "".join(rows)
    )
    return gp.read_particles(path)


def pairs_dump(path, rows: list[str], box: str = "0 1\n0 1\n0 1") -> None:
    """A LAMMPS dump local of layout "lammps" (id1 id2 fnx fny fnz ftx fty ftz)."""
    cols = "c_a[1] c_a[2] c_b[1] c_b[2] c_b[3] c_b[4] c_b[5] c_b[6]"
    path.write_text(box_head(len(rows), "ENTRIES", box) + f"ITEM: ENTRIES {cols}\n" + "".join(rows))


def full(v: float) -> str:
    return f"{v:.17g}"


def yade_spheres(path, x, r, ids) -> gp.ParticleFile:
    """YADE's ``id_x_y_z_r_matId`` text at full precision."""
    rows = "".join(
        f"{i} {' '.join(map(full, a))} {full(b)} 0\n" for i, a, b in zip(ids, x, r, strict=True)
    )
    path.write_text("#format id_x_y_z_r_matId\n" + rows)
    return gp.read_particles(path)


def interactions(path, rows) -> None:
    """YADE's interactions as a script writes them: id1 id2, the normal and shear force,
    the penetration depth."""
    path.write_text(
        "# id1 id2 fnx fny fnz ftx fty ftz penetrationDepth\n"
        + "".join(
            " ".join(repr(v) if isinstance(v, float) else str(v) for v in row) + "\n"
            for row in rows
        )
    )


def three_spheres(gap: float) -> tuple[np.ndarray, np.ndarray]:
    """Spheres 5 (at the origin), 6 touching it with an overlap of 1e-4 R along x, and 7
    `gap` (m) from 5 along y."""
    x = np.array(
        [[0.5, 0.5, 0.5], [0.5 + 2 * R - 1e-4 * R, 0.5, 0.5], [0.5, 0.5 + 2 * R + gap, 0.5]]
    )
    return x, np.full(3, R)


@pytest.mark.parametrize("rel_gap", [3e-6, 6.5e-6, 6.7e-4, 0.5 * VERGE_GAP_TOLERANCE])
def test_a_listed_pair_at_zero_force_on_the_verge_counts_as_the_peer_counts_it(tmp_path, rel_gap):
    x, r = three_spheres(rel_gap * R)
    p = yade_spheres(tmp_path / "spheres.txt", x, r, [5, 6, 7])
    assert p.digits == 17
    interactions(
        tmp_path / "inter.txt",
        [(5, 6, -0.3, 0.0, 0.0, 0.0, 0.01, 0.0, 2e-6), (5, 7, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, -1e-7)],
    )
    c = gp.read_contacts(tmp_path / "inter.txt", p, columns=PAIRS)
    assert len(c) == 2 and c.timestep is None
    np.testing.assert_array_equal(c.contacts.force_normal, [0.3, 0.0])
    (note,) = [n for n in c.notes if "without force" in n]
    assert note.startswith("1 listed contact without force") and f"{rel_gap * R:.3g} m" in note
    # the analysis counts both, as YADE does: Z = 2 N_c / N_p
    q = p.with_contacts(c)
    assert len(q.contacts) == 2
    # the same table as arrays, without a file
    q2 = p.with_contacts(c.contacts)
    assert any("without force" in n for n in q2.notes)


def test_a_pair_that_carries_force_across_the_same_gap_is_refused(tmp_path):
    x, r = three_spheres(3e-6 * R)
    p = yade_spheres(tmp_path / "spheres.txt", x, r, [5, 6, 7])
    interactions(tmp_path / "inter.txt", [(5, 7, 0.0, -0.2, 0.0, 0.0, 0.0, 0.0, 0.0)])
    with pytest.raises(gp.FileFormatError, match="for a contact that carries force") as info:
        gp.read_contacts(tmp_path / "inter.txt", p, columns=PAIRS)
    assert "inter.txt:2:" in str(info.value) and "ids 5 and 7" in str(info.value)


@pytest.mark.parametrize("rel_gap", [2 * VERGE_GAP_TOLERANCE, 0.1, 1.0])
def test_a_pair_at_zero_force_beyond_the_verge_is_refused(tmp_path, rel_gap):
    x, r = three_spheres(rel_gap * R)
    p = yade_spheres(tmp_path / "spheres.txt", x, r, [5, 6, 7])
    interactions(tmp_path / "inter.txt", [(5, 7, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)])
    with pytest.raises(gp.FileFormatError, match="do not touch"):
        gp.read_contacts(tmp_path / "inter.txt", p, columns=PAIRS)
    c = gp.Contacts(
        i=np.array([0]),
        j=np.array([2]),
        normal=np.array([[0.0, 1.0, 0.0]]),
        overlap=np.zeros(1),
        force_normal=np.zeros(1),
        force_tangential=np.zeros((1, 3)),
        branch=np.zeros((1, 3)),
    )
    with pytest.raises(gp.InvalidParameterError, match="do not touch"):
        p.with_contacts(c)


def test_the_named_layouts_still_leave_out_pairs_without_overlap_or_force(tmp_path):
    # LAMMPS' pair/local without "cutoff radius" lists neighbours at zero force; LAMMPS
    # counts only the overlapping ones
    x, r = three_spheres(3e-6 * R)
    rows = [f"{k + 1} {' '.join(map(full, a))} {full(R)}\n" for k, a in enumerate(x)]
    p = atoms_dump(tmp_path / "atoms.dump", rows)
    pairs_dump(tmp_path / "pairs.dump", ["1 2 -0.3 0 0 0 0 0\n", "1 3 0 0 0 0 0 0\n"])
    c = gp.read_contacts(tmp_path / "pairs.dump", p)
    assert len(c) == 1 and "1 pairs without overlap or force were left out" in c.notes


# -- the printed precision, from the text ------------------------------------------------


def test_written_digits_count_the_digits_as_written():
    assert written_digits(["0.0125"]) == 3
    assert written_digits(["1.2500e-02"]) == 5
    assert written_digits(["7", "-40"]) == 2
    assert written_digits(["0.10000000000000001"]) == 17
    assert written_digits(["1", "2.5", "0.333333"]) == 6


def lattice_dump(path, spacing: float, fmt: str) -> gp.ParticleFile:
    """Unit spheres on a line, `spacing` m apart, printed with `fmt`."""
    rows = [
        f"{k + 1} {fmt % (k * spacing)} {fmt % 0.0} {fmt % 1.0} {fmt % 1.0}\n" for k in range(4)
    ]
    return atoms_dump(path, rows, LATTICE_BOX)


LATTICE_BOX = "-1 20\n-1 1\n0 2"


@pytest.mark.parametrize("fmt", ["%.17g", "%g", "%.3f"])
def test_a_lattice_of_whole_numbers_apart_is_refused_whatever_it_was_printed_with(tmp_path, fmt):
    p = lattice_dump(tmp_path / "lattice.dump", 3.0, fmt)  # surfaces 1.0 m apart
    assert p.digits >= 1
    rows = ["1 2 -1 0 0 0 0 0\n", "2 3 -1 0 0 0 0 0\n", "3 4 -1 0 0 0 0 0\n"]
    pairs_dump(tmp_path / "pairs.dump", rows, LATTICE_BOX)
    with pytest.raises(gp.FileFormatError, match=r"surfaces are 1 m apart.*3 of 3 contacts"):
        gp.read_contacts(tmp_path / "pairs.dump", p)
    # given as arrays, without a file: the values' own digits, never fewer than six
    c = gp.Contacts(
        i=np.array([0, 1]),
        j=np.array([1, 2]),
        normal=np.array([[1.0, 0, 0], [1.0, 0, 0]]),
        overlap=np.zeros(2),
        force_normal=np.ones(2),
        force_tangential=np.zeros((2, 3)),
        branch=np.zeros((2, 3)),
    )
    with pytest.raises(gp.InvalidParameterError, match="1 m apart"):
        gp.microstructure(positions=p.positions, radii=p.radii, contacts=c)


def test_a_lattice_in_contact_printed_with_few_digits_still_reads(tmp_path):
    # touching unit spheres (2.0 m apart): "0", "2", "4", "6" are exact whatever the format
    p = lattice_dump(tmp_path / "lattice.dump", 2.0, "%.17g")
    pairs_dump(tmp_path / "pairs.dump", ["1 2 -1 0 0 0 0 0\n"], LATTICE_BOX)
    assert len(gp.read_contacts(tmp_path / "pairs.dump", p)) == 1


def test_a_pack_printed_with_six_digits_keeps_its_rounded_contacts(tmp_path):
    # pairs that overlap by 1e-9 m, printed %g: their printed gap reaches a few 1e-7 m
    rng = np.random.default_rng(4)
    n = 40
    base = rng.uniform(0.1, 0.9, size=(n, 3))
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    x = np.concatenate([base, base + (2 * R - 1e-9) * d])
    ids = np.arange(1, 2 * n + 1)
    rows = [f"{k} {a[0]:g} {a[1]:g} {a[2]:g} {R:g}\n" for k, a in zip(ids, x, strict=True)]
    p = atoms_dump(tmp_path / "atoms.dump", rows)
    assert p.digits == MIN_PRINTED_DIGITS
    gaps = np.linalg.norm(p.positions[n:] - p.positions[:n], axis=1) - 2 * R
    assert np.max(gaps) > CONTACT_GAP_TOLERANCE * R  # rounding alone opens these gaps
    pairs_dump(tmp_path / "pairs.dump", [f"{k + 1} {k + n + 1} -0.5 0 0 0 0 0\n" for k in range(n)])
    assert len(gp.read_contacts(tmp_path / "pairs.dump", p)) == n
