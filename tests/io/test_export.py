"""Export: VTK (.vtu) read back with meshio, LAMMPS data read back with a parser, CSV and
Parquet read back with polars; the same particles and contacts come back."""

from __future__ import annotations

import math

import numpy as np
import polars as pl
import pytest
from scenes import small_scene

import granpack as gp
from granpack.io import export
from granpack.io.lammps import read_lammps_data, write_lammps

meshio = pytest.importorskip("meshio")


@pytest.fixture(scope="module", params=[2, 3], ids=["2d", "3d"])
def pack(request) -> gp.Pack:
    # sphere mass in 2D: the LAMMPS density column is then the material's
    p = gp.generate(small_scene(request.param, inertia_2d="sphere"))
    # The checks below need both kinds of contacts to mean anything.
    assert (p.contacts.j >= 0).sum() > 5 and (p.contacts.j < 0).sum() > 2
    return p


def _pad3(a):
    a = np.asarray(a)
    if a.ndim == 1:
        return np.column_stack([np.zeros_like(a), np.zeros_like(a), a])
    return np.column_stack([a, np.zeros((a.shape[0], 3 - a.shape[1]))])


def test_vtk_round_trip_particles_and_contact_lines(pack, tmp_path):
    path = export(pack, tmp_path / "p.vtu", "vtk")[0]
    mesh = meshio.read(path)
    n, m, d = len(pack), len(pack.contacts), pack.dim
    c = pack.contacts
    assert [b.type for b in mesh.cells] == ["vertex", "line"]
    assert len(mesh.cells[0].data) == n and len(mesh.cells[1].data) == m
    # Particles: the first n points, every value bit for bit (binary float64).
    np.testing.assert_array_equal(mesh.points[:n, :d], pack.positions)
    if d == 2:
        assert np.all(mesh.points[:, 2] == 0.0)
    pd = mesh.point_data
    np.testing.assert_array_equal(pd["radius"][:n], pack.radii)
    np.testing.assert_array_equal(pd["diameter"][:n], 2 * pack.radii)
    np.testing.assert_array_equal(pd["layer"][:n], pack.layer)
    np.testing.assert_array_equal(pd["velocity"][:n], _pad3(pack.velocities))
    np.testing.assert_array_equal(pd["spin"][:n], _pad3(pack.spins))
    counts = np.bincount(c.i, minlength=n) + np.bincount(c.j[c.j >= 0], minlength=n)
    np.testing.assert_array_equal(pd["n_contacts"][:n], counts)
    np.testing.assert_array_equal(pd["id"][:n], np.arange(n))
    # Contacts: line i -> j, or i -> contact point on the wall.
    lines = mesh.cells[1].data
    np.testing.assert_array_equal(lines[:, 0], c.i)
    pp = c.j >= 0
    np.testing.assert_array_equal(lines[pp, 1], c.j[pp])
    np.testing.assert_allclose(
        mesh.points[lines[~pp, 1], :d], pack.positions[c.i[~pp]] + c.branch[~pp], rtol=0, atol=1e-15
    )
    cd = {k: v[1] for k, v in mesh.cell_data.items()}
    np.testing.assert_array_equal(cd["force_normal"], c.force_normal)
    np.testing.assert_array_equal(cd["force_tangential"], _pad3(c.force_tangential))
    np.testing.assert_array_equal(cd["normal"], _pad3(c.normal))
    np.testing.assert_array_equal(cd["j"], c.j)
    np.testing.assert_array_equal(cd["kind"], np.where(pp, 1, 2))
    np.testing.assert_allclose(
        cd["force"], _pad3(c.force_normal[:, None] * c.normal + c.force_tangential), rtol=1e-15
    )
    assert np.all(mesh.cell_data["kind"][0] == 0)


def test_lammps_data_round_trip(pack, tmp_path):
    path = export(pack, tmp_path / "p.data")[0]
    n, d = len(pack), pack.dim
    data = read_lammps_data(path)
    np.testing.assert_array_equal(data["id"], np.arange(1, n + 1))
    np.testing.assert_array_equal(data["type"], np.ones(n))
    np.testing.assert_array_equal(data["diameter"] / 2, pack.radii)
    np.testing.assert_array_equal(data["positions"][:, :d], pack.positions)
    np.testing.assert_array_equal(data["velocities"][:, :d], pack.velocities)
    np.testing.assert_array_equal(data["spins"], _pad3(pack.spins))
    np.testing.assert_array_equal(data["density"], pack.scene.material.density)
    lo, hi = data["box"]
    # Every particle centre inside the box that LAMMPS builds from the header.
    assert np.all(data["positions"] > lo) and np.all(data["positions"] < hi)
    if d == 2:
        assert np.all(data["positions"][:, 2] == 0.0) and lo[2] < 0 < hi[2]
    np.testing.assert_allclose(hi[d - 1], pack.height, rtol=1e-15)
    np.testing.assert_allclose(hi[: d - 1], pack.scene.base)

    # The layout LAMMPS' read_data expects for atom_style sphere, checked by hand.
    text = path.read_text().splitlines()
    assert f"{n} atoms" in text and "1 atom types" in text
    k = text.index("Atoms # sphere")
    first = text[k + 2].split()
    assert len(first) == 7 and first[:2] == ["1", "1"]
    assert float(first[2]) == 2 * pack.radii[0] and float(first[4]) == pack.positions[0, 0]
    v = text.index("Velocities")
    assert len(text[v + 2].split()) == 7


def test_lammps_density_gives_the_disc_mass_for_inertia_2d_disc(tmp_path):
    pack = gp.generate(small_scene(2, inertia_2d="disc"))
    data = read_lammps_data(write_lammps(pack, tmp_path / "d.data"))
    r = data["diameter"] / 2
    lammps_mass = data["density"] * 4 / 3 * math.pi * r**3  # what read_data computes
    np.testing.assert_allclose(lammps_mass, 1000.0 * math.pi * pack.radii**2, rtol=1e-14)


def test_csv_and_parquet_round_trip(pack, tmp_path):
    d = pack.dim
    axes = "xyz"[:d]
    for fmt in ("csv", "parquet"):
        files = export(pack, tmp_path / f"p.{fmt}", fmt)
        assert [f.name for f in files] == [f"p.particles.{fmt}", f"p.contacts.{fmt}"]
        if fmt == "csv":
            # the particle table opens with the container tag, a comment line
            assert files[0].read_text().startswith(f"# granpack: dim={d} container=box ")
            parts = pl.read_csv(files[0], comment_prefix="#")
            cons = pl.read_csv(files[1])
        else:
            parts, cons = pl.read_parquet(files[0]), pl.read_parquet(files[1])
            meta = pl.read_parquet_metadata(files[0])
            assert meta["granpack"].startswith(f"dim={d} container=box ")
        assert parts.height == len(pack) and cons.height == len(pack.contacts)
        for k, a in enumerate(axes):
            np.testing.assert_array_equal(parts[a].to_numpy(), pack.positions[:, k])
            np.testing.assert_array_equal(parts[f"v{a}"].to_numpy(), pack.velocities[:, k])
            np.testing.assert_array_equal(cons[f"n{a}"].to_numpy(), pack.contacts.normal[:, k])
        np.testing.assert_array_equal(parts["radius"].to_numpy(), pack.radii)
        np.testing.assert_array_equal(parts["layer"].to_numpy(), pack.layer)
        spin = parts["w"].to_numpy() if d == 2 else parts.select("wx", "wy", "wz").to_numpy()
        np.testing.assert_array_equal(spin, pack.spins)
        np.testing.assert_array_equal(cons["fn"].to_numpy(), pack.contacts.force_normal)
        np.testing.assert_array_equal(cons["j"].to_numpy(), pack.contacts.j)


def test_export_format_errors_name_the_choices(pack, tmp_path):
    with pytest.raises(gp.GranpackError, match="vtk, lammps-data, liggghts, yade, xyz, csv"):
        export(pack, tmp_path / "p.vtu", "pdb")
    with pytest.raises(gp.GranpackError, match="cannot tell the export format"):
        export(pack, tmp_path / "p.txt")
    with pytest.raises(gp.GranpackError, match="header says"):
        bad = tmp_path / "bad.data"
        bad.write_text("comment\n\n3 atoms\n\nAtoms # sphere\n\n1 1 0.1 1000 0 0 0\n")
        read_lammps_data(bad)
