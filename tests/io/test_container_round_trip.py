"""A pack keeps its container through every export that can carry it: written, read back
with read_particles and analysed, it gives the original's Z, phi and fabric (and, from a
pack file, its forces). Files that cannot say are analysed in a box that the result calls
assumed, and the command line takes --container for them."""

from __future__ import annotations

import json
import math
import warnings

import numpy as np
import pytest
from scenes import small_scene

import granpack as gp
from granpack.analysis import MicrostructureWarning
from granpack.analysis.container import ContainerTag
from granpack.cli import main
from granpack.io import export

meshio = pytest.importorskip("meshio")

CASES = [(3, "box"), (3, "periodic"), (3, "cylinder"), (2, "box"), (2, "periodic")]
# every export that read_particles reads back, by the file read
FORMATS = {
    "lammps-data": "p.data",
    "xyz": "p.xyz",
    "yade": "p.txt",
    "csv": "p.particles.csv",
    "parquet": "p.particles.parquet",
}


@pytest.fixture(scope="module", params=CASES, ids=[f"{d}d-{c}" for d, c in CASES])
def pack(request) -> gp.Pack:
    dim, container = request.param
    scene = small_scene(dim, container=container).replace(height=0.3 if dim == 3 else 0.2)
    p = gp.generate(scene.fast())
    assert len(p.contacts.particle_pairs()) > 50
    return p


def _analysis(subject, **kw) -> gp.Microstructure:
    # small packs have an empty core window: that warning is not what these tests check
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MicrostructureWarning)
        return gp.microstructure(subject, **kw)


def _same_structure(m: gp.Microstructure, m0: gp.Microstructure) -> None:
    assert m.container == m0.container
    assert m.n_contacts == m0.n_contacts and m.n_wall_contacts == m0.n_wall_contacts
    assert m.z == m0.z
    assert m.phi == pytest.approx(m0.phi, rel=1e-12, abs=0)
    assert m.container_volume == pytest.approx(m0.container_volume, rel=1e-12, abs=0)
    np.testing.assert_allclose(m.fabric, m0.fabric, rtol=0, atol=1e-12)
    np.testing.assert_allclose(m.a_r, m0.a_r, rtol=0, atol=1e-12)


@pytest.mark.parametrize("fmt", list(FORMATS))
def test_an_export_read_back_is_analysed_in_the_pack_s_container(pack, fmt, tmp_path):
    m0 = _analysis(pack)
    assert m0.container_source == "scene"
    export(pack, tmp_path / FORMATS[fmt].replace(".particles", ""), fmt)
    p = gp.read_particles(tmp_path / FORMATS[fmt])
    kind = pack.scene.container
    assert p.container == kind
    if kind == "cylinder":
        assert p.cylinder_radius == pack.scene.base[0] / 2
    m = _analysis(p)
    assert m.container_source == "file"
    _same_structure(m, m0)


def test_a_pack_file_read_back_keeps_its_container_and_forces(pack, tmp_path):
    m0 = _analysis(pack)
    p = gp.read_particles(pack.save(tmp_path / "p.npz"))
    assert p.container == pack.scene.container
    m = _analysis(p)
    _same_structure(m, m0)
    assert m.f0 == pytest.approx(m0.f0, rel=1e-12)
    np.testing.assert_allclose(m.a_n, m0.a_n, rtol=0, atol=1e-12)
    np.testing.assert_allclose(m.force_tangential_tensor, m0.force_tangential_tensor, atol=1e-12)


def test_a_file_that_cannot_say_is_analysed_in_an_assumed_box_and_says_so(pack, tmp_path):
    # plain x y (z) r text carries no container
    path = tmp_path / "p.xyzr"
    np.savetxt(path, np.column_stack([pack.positions, pack.radii]))
    p = gp.read_particles(path)
    assert p.container is None
    m = _analysis(p)
    assert (m.container, m.container_source) == ("box", "assumed")
    # told the container (and, without a box in the file, the box itself), it agrees
    kind = pack.scene.container
    kw: dict = {"container": kind, "box": pack.box}
    if kind == "cylinder":
        kw["cylinder_radius"] = pack.scene.base[0] / 2
    m_told = _analysis(None, positions=p.positions, radii=p.radii, **kw)
    assert m_told.container_source == "argument"
    _same_structure(m_told, _analysis(pack))


def test_the_command_line_says_what_it_assumed_and_takes_container(pack, tmp_path, capsys):
    path = tmp_path / "p.txt"
    export(pack, path, "yade")
    # the same file without granpack's tag line: YADE's own export.text
    plain = tmp_path / "plain.txt"
    plain.write_text(
        "".join(ln for ln in path.read_text().splitlines(True) if not ln.startswith("# "))
    )
    assert main(["analyze", str(plain), "--json"]) == 0
    out = capsys.readouterr()
    d = json.loads(out.out)
    assert (d["container"], d["container_source"]) == ("box", "assumed")
    assert "does not say its container" in out.err
    kind = pack.scene.container
    lo, hi = pack.box
    box = [str(v) for pair in zip(lo, hi, strict=True) for v in pair]
    argv = ["analyze", str(plain), "--json", "--container", kind, "--box", *box]
    if kind == "cylinder":
        argv += ["--cylinder-radius", repr(pack.scene.base[0] / 2)]
    assert main(argv) == 0
    d = json.loads(capsys.readouterr().out)
    m0 = _analysis(pack)
    assert (d["container"], d["container_source"]) == (kind, "argument")
    assert d["z"] == m0.z
    assert d["phi"] == pytest.approx(m0.phi, rel=1e-12)


def test_a_cylinder_without_a_box_stands_on_its_lowest_particle():
    # one layer of four spheres touching a cylinder of radius 0.2 around (0, 0)
    r = 0.05
    x = np.array([[0.15, 0.0, r], [-0.15, 0.0, r], [0.0, 0.15, r], [0.0, -0.15, r]])
    m = _analysis(None, positions=x, radii=np.full(4, r), container="cylinder", cylinder_radius=0.2)
    assert m.container == "cylinder"
    assert m.container_volume == pytest.approx(math.pi * 0.2**2 * 2 * r, rel=1e-12)
    assert m.n_wall_contacts == 0  # they touch the wall exactly: no overlap


def test_a_vtk_seam_contact_is_a_short_segment_on_both_sides(tmp_path):
    scene = small_scene(3, container="periodic").replace(height=0.3)
    pack = gp.generate(scene.fast())
    c = pack.contacts
    pp = c.j >= 0
    dx = pack.positions[c.j[pp]] - pack.positions[c.i[pp]]
    seam = np.any(np.abs(dx) > 0.5 * np.array([*pack.scene.base, np.inf]), axis=1)
    assert seam.sum() > 0  # the check means something
    mesh = meshio.read(export(pack, tmp_path / "p.vtu", "vtk")[0])
    lines = mesh.cells[1].data
    kind = mesh.cell_data["kind"][1]
    assert (kind == 1).sum() == pp.sum() and (kind == 2).sum() == (~pp).sum()
    assert (kind == 3).sum() == seam.sum()
    # no line is longer than the contact it draws: r_i + r_j for a pair
    length = np.linalg.norm(mesh.points[lines[:, 1]] - mesh.points[lines[:, 0]], axis=1)
    i, j = mesh.cell_data["i"][1], mesh.cell_data["j"][1]
    reach = pack.radii[i] + np.where(j >= 0, pack.radii[np.maximum(j, 0)], 0.0)
    assert np.all(length <= reach * (1 + 1e-12))
    # the image starts at j and points back at i's image: x_j - l
    img = kind == 3
    np.testing.assert_array_equal(lines[img, 0], j[img])


@pytest.mark.parametrize(
    ("text", "found"),
    [
        ("container=box", ("box", None)),
        ("x container=periodic y", ("periodic", None)),
        ("container=cylinder cylinder_radius=0.25", ("cylinder", 0.25)),
        # granpack's LAMMPS data title before the tag
        (
            "LAMMPS data file from granpack: (SI units, container cylinder radius 0.1)",
            ("cylinder", 0.1),
        ),
        ("LAMMPS data file from granpack: (SI units, container periodic)", ("periodic", None)),
        ("no tag here", None),
    ],
)
def test_the_container_tag_is_parsed(text, found, tmp_path):
    tag = ContainerTag.parse(text, tmp_path / "f", 1, 3)
    assert (None if tag is None else (tag.kind, tag.cylinder_radius)) == found


def test_the_tag_round_trips_its_corners(tmp_path):
    text = ContainerTag("cylinder", 0.1, [0.0, 0.0, 0.0], [0.2, 0.2, 1 / 3]).words()
    tag = ContainerTag.parse(text, tmp_path / "f", 1, 3)
    assert tag is not None and tag.hi is not None
    assert tag.hi[2] == 1 / 3


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("container=sphere", "not one of box, periodic, cylinder"),
        ("container=cylinder", "needs cylinder_radius"),
        ("container=cylinder cylinder_radius=-1", "must be finite and > 0"),
        ("container=cylinder cylinder_radius=abc", "is not a number"),
        ("container=box lo=0,0 hi=1,1,1", "must be 3 finite numbers"),
        ("container=box lo=0,0,0 hi=1,-1,1", "need hi > lo"),
    ],
)
def test_a_wrong_tag_is_refused_by_name(text, match, tmp_path):
    with pytest.raises(gp.FileFormatError, match=match):
        ContainerTag.parse(text, tmp_path / "f", 1, 3)


def test_a_wrong_tag_in_a_file_is_refused_with_its_line(tmp_path):
    path = tmp_path / "p.txt"
    path.write_text("#format x_y_z_r\n# granpack: dim=3 container=cylinder\n0 0 0.1 0.1\n")
    with pytest.raises(gp.FileFormatError, match=r"p\.txt:2: container=cylinder needs"):
        gp.read_particles(path)
