"""Files for and from other codes, without running them: YADE text and extended XYZ read
and written, contact files read by read_contacts (and every bad one refused naming its
line), the containers in the exports (periodic cell, cylinder), analyze --contacts.
Where LAMMPS and LIGGGHTS are installed, they run the periodic and cylinder snippets."""

from __future__ import annotations

import dataclasses
import json
import math
import subprocess

import numpy as np
import pytest
from scenes import small_scene

import granpack as gp
from granpack.cli import main
from granpack.io import export
from granpack.io.lammps import read_lammps_data
from granpack.io.lammps_input import lammps_restitution, liggghts_restitution, tsuji_alpha

meshio = pytest.importorskip("meshio")


@pytest.fixture(scope="module", params=[2, 3], ids=["2d", "3d"])
def pack(request) -> gp.Pack:
    return gp.generate(small_scene(request.param))


@pytest.fixture(scope="module")
def pack3d() -> gp.Pack:
    return gp.generate(small_scene(3))


# -- YADE and extended XYZ -------------------------------------------------------------------
def test_yade_and_xyz_exports_read_back_with_the_same_particles(pack, tmp_path):
    for fmt, name in (("yade", "p.txt"), ("xyz", "p.xyz")):
        (path,) = export(pack, tmp_path / name, fmt)
        p = gp.read_particles(path)
        assert p.format == fmt and p.dim == pack.dim
        np.testing.assert_array_equal(p.positions, pack.positions)
        np.testing.assert_array_equal(p.radii, pack.radii)
    assert (tmp_path / "p.txt").read_text().startswith("#format x_y_z_r\n")
    xyz = gp.read_particles(tmp_path / "p.xyz")
    np.testing.assert_array_equal(xyz.box[1], [*pack.scene.base, pack.height])
    assert xyz.periodic == (False,) * pack.dim


def test_ase_reads_the_xyz_export(pack3d, tmp_path):
    ase_io = pytest.importorskip("ase.io")
    (path,) = export(pack3d, tmp_path / "p.xyz")
    atoms = ase_io.read(path)
    np.testing.assert_array_equal(atoms.positions, pack3d.positions)
    np.testing.assert_array_equal(atoms.arrays["radius"], pack3d.radii)
    np.testing.assert_array_equal(atoms.cell.lengths(), [0.2, 0.2, pack3d.height])


def test_yade_text_with_ids_and_materials(tmp_path):
    path = tmp_path / "spheres.txt"
    path.write_text(
        "#format id_x_y_z_r_matId\n"
        "7 0.5 0.5 0.25 0.125 0\n"
        "# a comment YADE would skip\n"
        "3 0.25 0.25 0.125 0.125 1\n"
    )
    p = gp.read_particles(path)
    assert p.format == "yade" and p.dim == 3
    np.testing.assert_array_equal(p.ids, [3, 7])
    np.testing.assert_array_equal(p.positions, [[0.25, 0.25, 0.125], [0.5, 0.5, 0.25]])
    np.testing.assert_array_equal(p.radii, [0.125, 0.125])


BAD_YADE = {
    "unknown layout": ("#format x_y_z_r_q\n0 0 0 1 2\n", 1, "expected a YADE header"),
    "short row": ("#format x_y_z_r\n0 0 0 0.1\n1 1 0.1\n", 3, "expected 4 numbers"),
    "word": ("#format x_y_z_r\n0 0 0 abc\n", 2, "'abc' is not a number"),
    "zero radius": ("#format x_y_z_r\n0 0 0 0\n", 2, "radius 0.0"),
}


@pytest.mark.parametrize("name", list(BAD_YADE))
def test_bad_yade_text_names_the_line(name, tmp_path):
    text, line, words = BAD_YADE[name]
    path = tmp_path / "bad.txt"
    path.write_text(text)
    with pytest.raises(gp.FileFormatError) as info:
        gp.read_particles(path, format="yade")
    assert f"{path}:{line}:" in str(info.value) and words in str(info.value), str(info.value)


def test_bad_xyz_names_the_line(tmp_path):
    path = tmp_path / "bad.xyz"
    path.write_text("3\nProperties=species:S:1:pos:R:3:radius:R:1\nX 0 0 0 0.1\nX 1 1 1 0.1\n")
    with pytest.raises(gp.FileFormatError, match=r"bad\.xyz:5: expected 3 particle rows"):
        gp.read_particles(path)
    path.write_text("1\nProperties=species:S:1:pos:R:3\nX 0 0 0\n")
    with pytest.raises(gp.FileFormatError, match=r"bad\.xyz:2: missing property radius"):
        gp.read_particles(path)


# -- contact files -----------------------------------------------------------------------------
PARTICLES = """ITEM: TIMESTEP
100
ITEM: NUMBER OF ATOMS
3
ITEM: BOX BOUNDS ff ff ff
0 1
0 1
0 1
ITEM: ATOMS id x y z radius
10 0.5 0.5 0.5 0.1
20 0.5 0.5 0.68 0.1
30 0.68 0.5 0.5 0.1
"""


def local_dump(rows: list[str], step: int = 100, n: int | None = None) -> str:
    cols = " ".join(f"c_pg[{k}]" for k in range(1, 13))
    head = [
        "ITEM: TIMESTEP",
        str(step),
        "ITEM: NUMBER OF ENTRIES",
        str(len(rows) if n is None else n),
    ]
    head += ["ITEM: BOX BOUNDS ff ff ff", "0 1", "0 1", "0 1", f"ITEM: ENTRIES {cols}"]
    return "\n".join(head + rows) + "\n"


# pos (6), id1 id2 periodic, force on id1: 10-20 along +z pushes 10 down, with a shear
ROWS = [
    "0.5 0.5 0.5 0.5 0.5 0.68 10 20 0 0.25 0 -2.0",
    "0.5 0.5 0.5 0.68 0.5 0.5 10 30 0 -1.0 0 0",
]


@pytest.fixture
def particles(tmp_path):
    path = tmp_path / "atoms.dump"
    path.write_text(PARTICLES)
    return gp.read_particles(path)


def test_read_contacts_turns_forces_into_the_contact_table(particles, tmp_path):
    path = tmp_path / "pairs.dump"
    path.write_text(local_dump(ROWS))
    found = gp.read_contacts(path, particles)
    c = found.contacts
    assert found.layout == "liggghts" and found.timestep == 100 and len(found) == 2
    np.testing.assert_array_equal(c.i, [0, 0])
    np.testing.assert_array_equal(c.j, [1, 2])
    np.testing.assert_allclose(c.normal, [[0, 0, 1], [1, 0, 0]])
    np.testing.assert_allclose(c.force_normal, [2.0, 1.0])
    # the tangential force on j: the opposite of the shear on i
    np.testing.assert_allclose(c.force_tangential, [[-0.25, 0, 0], [0, 0, 0]])
    np.testing.assert_allclose(c.overlap, [0.02, 0.02])
    m = gp.microstructure(particles.with_contacts(found), core_margin=0.0)
    assert m.has_forces and m.n_contacts == 2 and m.z == pytest.approx(4 / 3)


def _refused(tmp_path, particles, text, line, words, **kw):
    path = tmp_path / "pairs.dump"
    path.write_text(text)
    with pytest.raises(gp.FileFormatError) as info:
        gp.read_contacts(path, particles, **kw)
    message = str(info.value)
    assert (f"{path}:{line}:" if line else str(path)) in message, message
    assert words in message, message


def test_bad_contact_files_are_refused_naming_the_line(particles, tmp_path):
    unknown = ROWS[0].replace(" 20 0 ", " 99 0 ")
    _refused(tmp_path, particles, local_dump([unknown, ROWS[1]]), 10, "id2 = 99 names no particle")
    _refused(tmp_path, particles, local_dump(ROWS, n=3), 12, "expected 3 entries")
    _refused(tmp_path, particles, local_dump([ROWS[0], ROWS[1][:-4]]), 11, "expected 12 values")
    _refused(tmp_path, particles, local_dump([ROWS[0].replace("-2.0", "x")]), 10, "'x' is not")
    _refused(tmp_path, particles, local_dump(ROWS, step=5), 2, "timestep 5, the particles")
    _refused(tmp_path, particles, PARTICLES, 3, "a dump of atoms")
    narrow = [" ".join(r.split()[6:9]) for r in ROWS]
    five = local_dump(narrow).replace(
        " ".join(f"c_pg[{k}]" for k in range(1, 13)), "c_a[1] c_a[2] c_a[3]"
    )
    _refused(tmp_path, particles, five, 9, "name none of the layouts")


def test_read_contacts_bad_arguments(particles, tmp_path):
    path = tmp_path / "pairs.dump"
    path.write_text(local_dump(ROWS))
    for kw, name in (({"layout": "pfc"}, "layout"), ({"columns": "id1 fx"}, "columns")):
        with pytest.raises(gp.InvalidParameterError) as info:
            gp.read_contacts(path, particles, **kw)
        assert info.value.parameter == name
    cols = "- - - - - - id1 id2 - fx fy fz"
    assert len(gp.read_contacts(path, particles, columns=cols)) == 2


def test_analyze_with_contacts_prints_the_forces(particles, tmp_path, capsys):
    path = tmp_path / "pairs.dump"
    path.write_text(local_dump(ROWS))
    argv = ["analyze", str(particles.path), "--contacts", str(path), "--json"]
    assert main(argv) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["contacts_layout"] == "liggghts" and d["has_forces"] is True
    assert d["n_contacts"] == 2 and d["f0"] > 0
    bad = tmp_path / "bad.dump"
    bad.write_text(local_dump([ROWS[0].replace(" 10 20 ", " 10 77 ")]))
    assert main(["analyze", str(particles.path), "--contacts", str(bad)]) == 2
    assert "names no particle" in capsys.readouterr().err


# -- the damping maps ----------------------------------------------------------------------------
def test_restitutions_give_granpacks_damping():
    # LIGGGHTS: -sqrt(5/6) beta = xi; LAMMPS: Tsuji's alpha(e) = 2 sqrt(3/2) xi
    e = liggghts_restitution(0.1)
    beta = math.log(e) / math.sqrt(math.log(e) ** 2 + math.pi**2)
    assert -math.sqrt(5 / 6) * beta == pytest.approx(0.1, rel=1e-12)
    assert tsuji_alpha(lammps_restitution(0.1)) == pytest.approx(2 * math.sqrt(1.5) * 0.1, 1e-12)


# -- containers ----------------------------------------------------------------------------------
def _periodic(pack: gp.Pack) -> gp.Pack:
    """The pack shifted half a period along x, so that it straddles the seam."""
    x = np.array(pack.positions)
    x[:, 0] += pack.scene.base[0] / 2  # some centres now lie beyond L: the export wraps them
    return dataclasses.replace(pack, positions=x, scene=pack.scene.replace(container="periodic"))


def _cylinder(pack: gp.Pack) -> gp.Pack:
    """The particles of a 3D pack that lie inside the cylinder inscribed in its base."""
    big = pack.scene.base[0] / 2
    inside = np.hypot(pack.positions[:, 0] - big, pack.positions[:, 1] - big) + pack.radii < big
    keep = np.flatnonzero(inside)
    c = pack.contacts
    kept = np.isin(c.i, keep) & (np.isin(c.j, keep) | (c.j == -1))
    remap = np.full(len(pack), -1)
    remap[keep] = np.arange(keep.size)
    rows = c.select(kept)
    contacts = dataclasses.replace(
        rows, i=remap[rows.i], j=np.where(rows.j >= 0, remap[rows.j], -1)
    )
    scene = pack.scene.replace(container="cylinder")
    assert scene.cylinder_radius == big
    return dataclasses.replace(
        pack,
        positions=pack.positions[keep],
        radii=pack.radii[keep],
        velocities=pack.velocities[keep],
        spins=pack.spins[keep],
        layer=pack.layer[keep],
        contacts=contacts,
        scene=scene,
    )


def _min_image_pairs(x, r, period: float) -> int:
    d = x[:, None, :] - x[None, :, :]
    d[..., 0] -= period * np.round(d[..., 0] / period)
    gap = np.linalg.norm(d, axis=2) - (r[:, None] + r[None, :])
    return int(np.sum(np.triu(gap < 0, 1)))


def test_periodic_export_wraps_every_centre_and_says_so(pack, tmp_path):
    p = _periodic(pack)
    export(p, tmp_path / "pack.data", "lammps-data")
    data = read_lammps_data(tmp_path / "pack.data")
    x = data["positions"][:, 0]
    assert np.all((x >= 0) & (x < p.scene.base[0]))
    np.testing.assert_allclose(x, np.mod(p.positions[:, 0], p.scene.base[0]), rtol=0, atol=1e-15)
    snippet = (tmp_path / "in.granpack").read_text()
    assert ("boundary        p p m" if p.dim == 3 else "boundary        p m p") in snippet
    assert "wall_x" not in snippet and "floor" in snippet
    (xyz,) = export(p, tmp_path / "p.xyz")
    assert gp.read_particles(xyz).periodic == ((True, True, False) if p.dim == 3 else (True, False))


def test_container_files_draw_box_periodic_cell_and_cylinder(pack3d, tmp_path):
    for name, p, kinds in (
        ("box", pack3d, {0}),
        ("periodic", _periodic(pack3d), {0, 1}),
        ("cylinder", _cylinder(pack3d), {0}),
    ):
        files = export(p, tmp_path / f"{name}.vtu")
        assert files[1].name == f"{name}.container.vtu"
        mesh = meshio.read(files[1])
        assert set(np.concatenate(mesh.cell_data["kind"]).tolist()) == kinds
        pts = mesh.points
        assert pts[:, 2].min() == 0.0 and pts[:, 2].max() == p.height
        if name == "cylinder":
            assert [b.type for b in mesh.cells] == ["quad", "line"]
            radius = np.hypot(pts[:, 0] - 0.1, pts[:, 1] - 0.1)
            np.testing.assert_allclose(radius, 0.1, rtol=1e-12)
        else:
            assert [b.type for b in mesh.cells] == ["line"] and len(mesh.cells[0].data) == 12
            np.testing.assert_array_equal(pts.max(axis=0), [0.2, 0.2, p.height])


def test_cylinder_snippets_use_the_cylinder_wall(pack3d, tmp_path):
    p = _cylinder(pack3d)
    export(p, tmp_path / "pack.data", "lammps-data")
    text = (tmp_path / "in.granpack").read_text()
    assert "region          can cylinder z 0.1 0.1 0.1" in text and "wall/gran/region" in text
    assert "wall_x" not in text
    export(p, tmp_path / "pack.data", "liggghts")
    text = (tmp_path / "in.granpack").read_text()
    assert "zcylinder 0.1 0.1 0.1" in text and "xplane" not in text


def _run(program, run_dir, steps: int) -> str:
    done = subprocess.run(
        [program, "-in", "in.granpack", "-var", "steps", str(steps), "-log", "log.run"],
        cwd=run_dir,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-2000:]
    return (run_dir / "log.run").read_text()


def _thermo(log: str) -> list[list[float]]:
    """The rows of the last thermo table of a log."""
    lines = log.splitlines()
    k = max(n for n, ln in enumerate(lines) if ln.split()[:1] == ["Step"])
    rows = []
    for ln in lines[k + 1 :]:
        words = ln.split()
        if not words or not words[0].isdigit():
            break
        rows.append([float(v) for v in words])
    return rows


def test_lammps_runs_periodic_and_cylinder_packs(lmp, pack, pack3d, tmp_path):
    p = _periodic(pack)
    export(p, tmp_path / "pack.data", "lammps-data")
    step0 = _thermo(_run(lmp, tmp_path, 0))[0]
    # contact/atom across the seam: the minimum-image count of the wrapped pack
    assert step0[3] == 2 * _min_image_pairs(p.positions, p.radii, p.scene.base[0])
    c = _cylinder(pack3d)
    export(c, tmp_path / "pack.data", "lammps-data")
    assert _thermo(_run(lmp, tmp_path, 10))[-1][1] == len(c)  # nobody lost


def test_liggghts_runs_periodic_and_cylinder_packs(liggghts, pack3d, tmp_path):
    for p in (_periodic(pack3d), _cylinder(pack3d)):
        export(p, tmp_path / "pack.data", "liggghts")
        rows = _thermo(_run(liggghts, tmp_path, 10))
        assert rows[-1][1] == len(p)  # nobody lost


# -- pictures of the containers -------------------------------------------------------------------
def _collections(ax):
    from matplotlib.collections import EllipseCollection

    return [c for c in ax.collections if isinstance(c, EllipseCollection)]


def test_periodic_pictures_draw_the_images_across_the_seam(pack, tmp_path):
    from granpack import plot

    p = _periodic(pack)
    fig = plot.pack_figure(p)
    ax = fig.axes[0] if p.dim == 2 else fig.axes[2]  # 3D: the horizontal slice
    x, r = np.asarray(p.positions), np.asarray(p.radii)
    periods = [(0, 0.2)]
    if p.dim == 3:  # the circles the mid-height plane cuts
        d = np.abs(x[:, 2] - 0.5 * p.height)
        cut = d < r
        x, r = x[cut][:, :2], np.sqrt(r[cut] ** 2 - d[cut] ** 2)
        periods = [(0, 0.2), (1, 0.2)]
    base, images = _collections(ax)
    np.testing.assert_allclose(base.get_offsets(), x[:, :2])
    xi, ri, ii = plot.periodic_images(x[:, :2], r, periods)
    assert len(ri) > 0
    np.testing.assert_allclose(images.get_offsets(), xi)
    # each image is its particle moved by a period, across the seam it crosses
    shift = xi - x[ii, :2]
    assert np.all(np.isclose(np.abs(shift), 0.0) | np.isclose(np.abs(shift), 0.2))
    assert plot.save(fig, tmp_path / "periodic.png").stat().st_size > 0


def test_cylinder_picture_has_the_view_and_a_horizontal_slice(pack3d, tmp_path):
    from granpack import plot

    c = _cylinder(pack3d)
    fig = plot.pack_figure(c, title="cylinder")
    assert len(fig.axes) == 3
    view, _, horizontal = fig.axes
    assert len(_collections(view)[0].get_offsets()) == len(c)
    z0 = 0.5 * c.height
    n_cut = int(np.sum(np.abs(c.positions[:, 2] - z0) < c.radii))
    assert len(_collections(horizontal)[0].get_offsets()) == n_cut
    (circle,) = horizontal.get_lines()
    xy = circle.get_xydata()
    np.testing.assert_allclose(np.hypot(xy[:, 0] - 0.1, xy[:, 1] - 0.1), 0.1, rtol=1e-12)
    assert plot.save(fig, tmp_path / "cylinder.png").stat().st_size > 0
