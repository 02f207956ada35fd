"""A consolidated sample keeps its lid through every export that read_particles reads
back: the container tag carries the lid's height (``lid=``) beside the box, whose corners
are the side walls where the consolidation left them, so the file is analysed up to the
lid (not up to max(z + r)), with the particles that press on the lid counted as its
contacts (wall id -6). Written, read back and analysed, the sample gives the original
Pack's phi, Z and wall contacts."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest
from scenes import small_scene

import granpack as gp
from granpack.analysis import MicrostructureWarning
from granpack.analysis.container import ContainerTag
from granpack.cli import main
from granpack.contacts import LID_ID
from granpack.io import export
from granpack.io.lammps_input import lid_height

# every container a consolidation closes, with the mode that moves its side walls where
# it has side walls (isotropic), and the periodic cell's only mode (oedometric)
CASES = {
    "3d-box-isotropic": (3, "box", "isotropic"),
    "3d-cylinder-isotropic": (3, "cylinder", "isotropic"),
    "3d-periodic": (3, "periodic", "oedometric"),
    "2d-box-isotropic": (2, "box", "isotropic"),
    "2d-periodic": (2, "periodic", "oedometric"),
}
# every export that read_particles reads back, by the file read
FORMATS = {
    "lammps-data": "p.data",
    "xyz": "p.xyz",
    "yade": "p.txt",
    "csv": "p.particles.csv",
    "parquet": "p.particles.parquet",
    "kratos": "p.mdpa",
    "gsd": "p.gsd",
}


@pytest.fixture(scope="module", params=list(CASES))
def sample(request) -> gp.Pack:
    """A small deposit (50 to 70 particles) consolidated to 10 kPa (under a second)."""
    dim, container, mode = CASES[request.param]
    with warnings.catch_warnings():
        # the small deposits have not quite come to rest; the consolidation settles them
        warnings.simplefilter("ignore", gp.UnsettledPackWarning)
        deposit = gp.generate(small_scene(dim, container=container))
    pack = gp.consolidate(deposit, 1e4, mode)
    # the check means something: the lid holds contacts, and the highest particle's top
    # lies apart from the lid (so max(z + r) would give another phi)
    assert np.count_nonzero(pack.contacts.j == LID_ID) > 0
    top = float(np.max(pack.positions[:, -1] + pack.radii))
    assert (
        abs(top - pack.record("consolidate").table()["height"])
        > 1e-6 * pack.record("consolidate").table()["height"]
    )
    return pack


def _analysis(subject) -> gp.Microstructure:
    # small samples have an empty core window: that warning is not what these tests check
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MicrostructureWarning)
        return gp.microstructure(subject)


def _lid_contacts(m_system: gp.analysis.System) -> np.ndarray:
    c = m_system.contacts
    return np.sort(c.i[c.j == LID_ID])


def _same_sample(p, pack: gp.Pack, rel: float) -> None:
    """`p` (read back) analyses as `pack`: phi, Z, the wall contacts, the lid's."""
    m0, m = _analysis(pack), _analysis(p)
    assert m.container == m0.container
    assert m.phi == pytest.approx(m0.phi, rel=rel, abs=0)
    assert m.phi == pytest.approx(
        pack.record("consolidate").table()["phi"], rel=max(rel, 1e-12), abs=0
    )
    assert m.container_volume == pytest.approx(m0.container_volume, rel=rel, abs=0)
    assert m.z == m0.z
    assert m.n_contacts == m0.n_contacts and m.n_wall_contacts == m0.n_wall_contacts
    s0, s = gp.analysis.System.from_any(pack), gp.analysis.System.from_any(p)
    assert s.container.lid and s.h_top == s0.h_top
    np.testing.assert_array_equal(_lid_contacts(s), _lid_contacts(s0))
    lid0, lid = (x.contacts.select(x.contacts.j == LID_ID) for x in (s0, s))
    o0, o = (np.sort(x.overlap) for x in (lid0, lid))
    np.testing.assert_allclose(
        o, o0, rtol=0, atol=rel * pack.record("consolidate").table()["height"]
    )
    np.testing.assert_allclose(m.fabric, m0.fabric, rtol=0, atol=max(rel, 1e-12))


@pytest.mark.parametrize("fmt", list(FORMATS))
def test_a_consolidated_sample_read_back_is_analysed_up_to_its_lid(sample, fmt, tmp_path):
    export(sample, tmp_path / FORMATS[fmt].replace(".particles", ""), fmt)
    p = gp.read_particles(tmp_path / FORMATS[fmt])
    assert p.lid == lid_height(sample) == sample.record("consolidate").table()["height"]
    # the side walls where the consolidation left them: the box's corners
    assert p.box is not None
    np.testing.assert_array_equal(p.box[1][:-1], sample.scene.base)
    # gsd holds positions and radii in float32 (2^-24 relative): phi to 1e-6 there
    _same_sample(p, sample, 1e-6 if fmt == "gsd" else 1e-12)


def test_a_consolidated_pack_file_read_back_keeps_its_lid_and_forces(sample, tmp_path):
    p = gp.read_particles(sample.save(tmp_path / "p.npz"))
    assert p.lid == sample.record("consolidate").table()["height"]
    _same_sample(p, sample, 1e-12)
    m0, m = _analysis(sample), _analysis(p)
    assert m.f0 == pytest.approx(m0.f0, rel=1e-12)
    np.testing.assert_allclose(m.stress, m0.stress, rtol=1e-12, atol=0)


def test_the_lid_contacts_found_in_a_file_are_the_engines(sample, tmp_path):
    # a file holds no contacts: the analysis finds the lid's as the engine lists them (the
    # same particles, overlaps, normals and branches)
    export(sample, tmp_path / "p.txt", "yade")
    s = gp.analysis.System.from_any(gp.read_particles(tmp_path / "p.txt"))
    engine = sample.contacts.select(sample.contacts.j == LID_ID)
    found = s.contacts.select(s.contacts.j == LID_ID)
    order0, order = np.argsort(engine.i), np.argsort(found.i)
    np.testing.assert_array_equal(found.i[order], engine.i[order0])
    np.testing.assert_allclose(found.overlap[order], engine.overlap[order0], rtol=1e-9, atol=0)
    np.testing.assert_array_equal(found.normal[order], engine.normal[order0])
    np.testing.assert_allclose(found.branch[order], engine.branch[order0], rtol=1e-12, atol=0)
    assert np.all(found.force_normal == 0.0)  # geometry only: a file gives no forces


def test_a_deposit_s_export_says_no_lid(tmp_path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", gp.UnsettledPackWarning)
        deposit = gp.generate(small_scene(2))
    for fmt, name in FORMATS.items():
        export(deposit, tmp_path / name.replace(".particles", ""), fmt)
        p = gp.read_particles(tmp_path / name)
        assert p.lid is None, fmt
        s = gp.analysis.System.from_any(p)
        assert not s.container.lid
        assert s.h_top == pytest.approx(deposit.height, rel=1e-6)


def test_the_tag_carries_the_lid(tmp_path):
    text = ContainerTag("box", None, [0.0, 0.0], [0.3, 0.125], lid=0.125).words()
    assert text.endswith("lid=0.125")
    tag = ContainerTag.parse(text, tmp_path / "f", 1, 2)
    assert tag is not None and tag.lid == 0.125
    container = tag.to_container()
    assert container.lid and container.hi[-1] == 0.125 and -6 in container.wall_ids()
    assert ContainerTag.parse("container=periodic", tmp_path / "f", 1, 2).lid is None


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("container=box lid=abc", "lid='abc' is not a number"),
        ("container=box lid=nan", "must be a finite height"),
        ("container=box lo=0,0 hi=1,1 lid=0", "must lie above the floor"),
        ("container=box lo=0,0 hi=1,1 lid=0.5", "must be the top of the box"),
    ],
)
def test_a_wrong_lid_is_refused_naming_the_line(text, match, tmp_path):
    with pytest.raises(gp.FileFormatError, match=match):
        ContainerTag.parse(text, tmp_path / "f", 3, 2)


def test_a_file_without_a_tag_is_told_its_lid(sample, tmp_path, capsys):
    # a dump LAMMPS writes has no tag: its top is open unless the caller gives the lid
    lid = sample.record("consolidate").table()["height"]
    m0 = _analysis(sample)
    kind = gp.analysis.System.from_any(sample).container
    where: dict = {"box": sample.box, "container": kind.kind}
    if kind.radius is not None:
        where["cylinder_radius"] = kind.radius
    arrays = {"positions": sample.positions, "radii": sample.radii, **where}
    open_top = _analysis(gp.analysis.System.from_any(None, **arrays))
    assert open_top.phi < m0.phi and open_top.n_wall_contacts < m0.n_wall_contacts
    told = _analysis(gp.analysis.System.from_any(None, lid=lid, **arrays))
    assert told.phi == pytest.approx(m0.phi, rel=1e-12)
    assert (told.z, told.n_wall_contacts) == (m0.z, m0.n_wall_contacts)
    # the command line: --lid, and a file's lid kept when --box replaces its box
    path = tmp_path / "p.txt"
    export(sample, path, "yade")
    lo, hi = sample.box
    box = [repr(float(v)) for pair in zip(lo, hi, strict=True) for v in pair]
    for argv in (["--lid", repr(lid)], ["--box", *box]):
        assert main(["analyze", str(path), "--json", *argv]) == 0
        out = json.loads(capsys.readouterr().out)
        assert out["phi"] == pytest.approx(m0.phi, rel=1e-12), argv
        assert out["n_wall_contacts"] == m0.n_wall_contacts


@pytest.mark.parametrize(
    ("lid", "match"),
    [(float("nan"), "lid = nan: must be finite"), (-0.01, "above the floor"), (0.02, "centre")],
)
def test_a_wrong_lid_argument_is_refused_naming_it(lid, match):
    x = np.array([[0.05, 0.01], [0.05, 0.03]])
    with pytest.raises(gp.InvalidParameterError, match=match) as err:
        gp.microstructure(positions=x, radii=np.full(2, 0.01), lid=lid)
    assert err.value.parameter == "lid"
