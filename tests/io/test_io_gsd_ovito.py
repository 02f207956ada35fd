"""gsd files (HOOMD-blue's schema) and OVITO.

- granpack's gsd export, read by the gsd package itself (positions, diameters, box,
  dimensions) and read back by granpack in the pack's container, with the pack's Z and
  phi; the command line and ``read_particles`` take gsd; a damaged or foreign file is a
  FileFormatError that names the file, the frame and the chunk;
- OVITO (the ``ovito`` Python module) reads granpack's extended XYZ, gsd and LAMMPS data
  exports and LAMMPS' own dump of that data file, with the radii, cell and periodic flags
  right, and its CoordinationAnalysis counts granpack's contacts (across a periodic seam
  too), on small packs and on the paper's example 4.3.

The gsd and ovito packages are in the test extra; without them these tests are skipped,
or fail where GRANPACK_PEERS=required (.ci/run)."""

from __future__ import annotations

import json
import subprocess
import warnings
from pathlib import Path

import numpy as np
import pytest
from scenes import small_scene

import granpack as gp
from granpack.analysis import MicrostructureWarning
from granpack.cli import main
from granpack.io import detect_format, export
from granpack.io.gsd import GSD_MAGIC, read_gsd, write_gsd
from granpack.io.lammps import lammps_positions

CASES = [(3, "box"), (3, "periodic"), (3, "cylinder"), (2, "box"), (2, "periodic")]
IDS = [f"{d}d-{c}" for d, c in CASES]
EPS32 = 2.0**-24  # float32's unit roundoff


def _analysis(subject=None, **kw) -> gp.Microstructure:
    # small packs have an empty core window: that warning is not what these tests check
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MicrostructureWarning)
        return gp.microstructure(subject, **kw)


def _wrapped(pack: gp.Pack) -> np.ndarray:
    """The pack's centres as the exports write them: a periodic pack's wrapped into
    [0, L) (LAMMPS data, XYZ and gsd alike)."""
    return lammps_positions(pack)[:, : pack.dim]


def _shift(pack: gp.Pack) -> np.ndarray:
    lo, hi = pack.box
    out = np.zeros(3)
    out[: pack.dim] = (lo + hi) / 2.0
    return out


@pytest.fixture(scope="module", params=CASES, ids=IDS)
def pack(request) -> gp.Pack:
    """Small polydisperse packs in each container (seconds)."""
    dim, container = request.param
    scene = small_scene(dim, container=container).replace(height=0.3 if dim == 3 else 0.2)
    return gp.generate(scene.fast())


def test_a_missing_peer_package_skips_here_and_fails_where_required(monkeypatch):
    from conftest import peer_module

    monkeypatch.delenv("GRANPACK_PEERS", raising=False)
    with pytest.raises(pytest.skip.Exception, match="pip install nosuch"):
        peer_module("granpack_no_such_module", "nosuch")
    monkeypatch.setenv("GRANPACK_PEERS", "required")
    with pytest.raises(pytest.fail.Exception, match="GRANPACK_PEERS=required"):
        peer_module("granpack_no_such_module", "nosuch")
    assert peer_module("numpy", "numpy") is np


# -- the gsd export --------------------------------------------------------------------------


def test_gsd_holds_the_pack_as_the_gsd_package_reads_it(gsd_hoomd, pack, tmp_path):
    path = write_gsd(pack, tmp_path / "p.gsd")
    assert path.read_bytes()[:8] == GSD_MAGIC
    n, dim = len(pack), pack.dim
    lo, hi = pack.box
    with gsd_hoomd.open(path) as traj:
        assert len(traj) == 1
        frame = traj[0]
    box = frame.configuration.box
    assert frame.configuration.dimensions == dim
    lengths = np.zeros(3)
    lengths[:dim] = hi - lo
    np.testing.assert_array_equal(box, np.array([*lengths, 0, 0, 0], dtype=np.float32))
    p = frame.particles
    assert p.N == n and p.types == ["A"]
    np.testing.assert_array_equal(p.typeid, np.zeros(n))
    assert p.position.dtype == np.float32 and p.diameter.dtype == np.float32
    np.testing.assert_array_equal(p.diameter, (2.0 * pack.radii).astype(np.float32))
    # HOOMD's box is centred on the origin: undo the centring
    x = p.position.astype(np.float64) + _shift(pack)
    np.testing.assert_allclose(x[:, :dim], _wrapped(pack), rtol=0, atol=EPS32 * max(lengths))
    if dim == 2:
        assert np.all(p.position[:, 2] == 0.0)
    half = box[:dim] / 2
    assert np.all(np.abs(p.position[:, :dim]) <= half)
    v = np.zeros((n, 3))
    v[:, :dim] = pack.velocities
    np.testing.assert_array_equal(p.velocity, v.astype(np.float32))
    # the container and the exact box, for granpack
    log = frame.log
    assert f"container={pack.scene.container}" in str(log["granpack/container"])
    np.testing.assert_array_equal(log["granpack/lo"], lo)
    np.testing.assert_array_equal(log["granpack/hi"], hi)
    np.testing.assert_array_equal(log["granpack/shift"], _shift(pack))


def test_gsd_read_back_keeps_the_container_and_the_structure(gsd_hoomd, pack, tmp_path):
    written = export(pack, tmp_path / "p.gsd")  # the format from the suffix
    assert written == [tmp_path / "p.gsd"]
    assert detect_format(written[0]) == "gsd"
    p = gp.read_particles(written[0])
    kind = pack.scene.container
    assert (p.format, p.dim, len(p)) == ("gsd", pack.dim, len(pack))
    assert p.container == kind and p.notes == ()
    assert p.cylinder_radius == (pack.scene.base[0] / 2 if kind == "cylinder" else None)
    assert p.periodic == (kind == "periodic",) * (pack.dim - 1)
    np.testing.assert_array_equal(p.box[0], pack.box[0])  # the box exactly
    np.testing.assert_array_equal(p.box[1], pack.box[1])
    # centres and radii to float32's precision
    scale = float(np.max(pack.box[1]))
    np.testing.assert_allclose(p.positions, _wrapped(pack), rtol=0, atol=EPS32 * scale)
    np.testing.assert_allclose(p.radii, pack.radii, rtol=EPS32, atol=0)
    # the analysis of the read-back is that of the float32-rounded centres and radii ...
    m = _analysis(p)
    assert m.container == kind and m.container_source == "file"
    lo, hi = pack.box
    shift = _shift(pack)[: pack.dim]
    x32 = (_wrapped(pack) - shift).astype(np.float32).astype(np.float64) + shift
    r32 = (2.0 * pack.radii).astype(np.float32).astype(np.float64) / 2.0
    told = {"cylinder_radius": p.cylinder_radius} if kind == "cylinder" else {}
    m32 = _analysis(positions=x32, radii=r32, box=(lo, hi), container=kind, **told)
    assert (m.n_contacts, m.n_wall_contacts, m.z) == (m32.n_contacts, m32.n_wall_contacts, m32.z)
    assert m.phi == pytest.approx(m32.phi, rel=1e-12, abs=0)
    # ... which rounding moves by at most 7e-9 m here: the pack's contacts, Z and phi
    m0 = _analysis(pack)
    assert (m.n_contacts, m.z) == (m0.n_contacts, m0.z)
    assert m.phi == pytest.approx(m0.phi, rel=1e-6, abs=0)


def test_the_command_line_exports_and_analyses_gsd(gsd_hoomd, pack, tmp_path, capsys):
    src = pack.save(tmp_path / "pack.npz")
    assert main(["export", str(src), "--format", "gsd", "-q"]) == 0
    out = tmp_path / "pack.gsd"  # the default name beside the pack
    assert out.read_bytes()[:8] == GSD_MAGIC
    capsys.readouterr()
    assert main(["analyze", str(out), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["format"] == "gsd" and d["container"] == pack.scene.container
    assert d["container_source"] == "file" and (d["snapshot"], d["n_snapshots"]) == (0, 1)
    assert d["z"] == _analysis(gp.read_particles(out)).z
    # a gsd file under another name is told by its magic number
    other = tmp_path / "pack.bin"
    other.write_bytes(out.read_bytes())
    assert detect_format(other) == "gsd"
    assert main(["analyze", str(other), "--format", "gsd", "--json"]) == 0


def test_a_gsd_write_is_atomic(gsd_hoomd, pack, tmp_path, monkeypatch):
    import granpack.io.gsd as gsd_io

    path = tmp_path / "p.gsd"
    path.write_bytes(b"the previous file")
    real = gsd_io._gsd_fl()

    class Stop(BaseException):
        pass

    class Cut:
        """The gsd file layer, cut off after the positions: an interrupted write."""

        def __init__(self, f):
            self.f = f

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            self.f.close()

        def write_chunk(self, name, data):
            self.f.write_chunk(name, data)
            if name == "particles/position":
                raise Stop

    class Gsd:
        version = real.version

        class fl:
            @staticmethod
            def open(**kw):
                return Cut(real.fl.open(**kw))

    monkeypatch.setattr(gsd_io, "_gsd_fl", lambda: Gsd)
    with pytest.raises(Stop):
        write_gsd(pack, path)
    assert path.read_bytes() == b"the previous file"
    assert [q.name for q in tmp_path.iterdir()] == ["p.gsd"]
    monkeypatch.undo()
    write_gsd(pack, path)
    assert len(read_gsd(path)) == len(pack)
    assert [q.name for q in tmp_path.iterdir()] == ["p.gsd"]


# -- frames, other programs' files, bad files ------------------------------------------------


def _frame(gsd_hoomd, x, d, box, dims=None, step=0):
    f = gsd_hoomd.Frame()
    f.configuration.box = box
    if dims is not None:
        f.configuration.dimensions = dims
    f.configuration.step = step
    f.particles.N = len(x)
    f.particles.position = np.asarray(x, dtype=np.float32)
    if d is not None:
        f.particles.diameter = np.asarray(d, dtype=np.float32)
    return f


X4 = np.array([[-0.3, -0.3, -0.4], [0.2, -0.3, -0.4], [-0.3, 0.25, -0.4], [0.0, 0.0, 0.3]])


def test_another_program_s_gsd_frames_read_as_a_periodic_cell(gsd_hoomd, tmp_path):
    path = tmp_path / "traj.gsd"
    with gsd_hoomd.open(path, "w") as traj:
        traj.append(_frame(gsd_hoomd, X4, [0.25] * 4, [1, 1, 1, 0, 0, 0], step=10))
        # HOOMD writes only what changed: the second frame's diameters are frame 0's
        traj.append(_frame(gsd_hoomd, X4 + 0.05, None, [1, 1, 1, 0, 0, 0], step=20))
    p = gp.read_particles(path)
    assert (p.format, p.dim, p.snapshot, p.n_snapshots, p.timestep) == ("gsd", 3, 1, 2, 20)
    np.testing.assert_allclose(p.positions, (X4 + 0.05).astype(np.float32), rtol=0, atol=0)
    np.testing.assert_array_equal(p.radii, np.full(4, 0.125))
    np.testing.assert_array_equal(p.box[0], [-0.5] * 3)
    np.testing.assert_array_equal(p.box[1], [0.5] * 3)
    assert p.periodic == (True, True, True) and p.container == "periodic"
    assert any("frame 1 of 2" in n for n in p.notes)
    assert any("periodic on every axis" in n for n in p.notes)
    first = gp.read_particles(path, snapshot=0)
    assert first.timestep == 10
    np.testing.assert_array_equal(first.positions, X4.astype(np.float32))
    # periodic horizontal axes, as any periodic file; walled on request
    m = _analysis(first)
    assert (m.container, m.container_source) == ("periodic", "file")
    assert _analysis(first, container="box").container == "box"
    # 2D: Lz = 0, z = 0
    x2 = X4.copy()
    x2[:, 2] = 0.0
    with gsd_hoomd.open(tmp_path / "flat.gsd", "w") as traj:
        traj.append(_frame(gsd_hoomd, x2, [0.25] * 4, [1, 1, 0, 0, 0, 0]))
    flat = gp.read_particles(tmp_path / "flat.gsd")
    assert flat.dim == 2 and flat.periodic == (True, True)
    np.testing.assert_array_equal(flat.positions, x2[:, :2].astype(np.float32))
    with pytest.raises(gp.FileFormatError, match="dim = 3, but frame 0 is 2D"):
        gp.read_particles(tmp_path / "flat.gsd", dim=3)


def test_a_frame_appended_by_hoomd_keeps_granpack_s_container(gsd_hoomd, pack, tmp_path):
    path = write_gsd(pack, tmp_path / "p.gsd")
    with gsd_hoomd.open(path, "r+") as traj:
        frame = traj[0]
        moved = frame.particles.position.copy()
        moved[:, pack.dim - 1] += np.float32(0.001)  # everything 1 mm up
        frame.particles.position = moved
        frame.log = {}  # a later frame names only what changed
        traj.append(frame)
    p = gp.read_particles(path)
    assert (p.snapshot, p.n_snapshots, p.container) == (1, 2, pack.scene.container)
    np.testing.assert_array_equal(p.box[1], pack.box[1])
    up = np.zeros(pack.dim)
    up[-1] = 0.001
    scale = float(np.max(pack.box[1]))
    np.testing.assert_allclose(p.positions, _wrapped(pack) + up, rtol=0, atol=2 * EPS32 * scale)
    p0 = gp.read_particles(path, snapshot=0)
    np.testing.assert_array_equal(p0.positions, read_gsd(path, snapshot=-2).positions)


def _refused(path, match: str, **kw) -> gp.FileFormatError:
    with pytest.raises(gp.FileFormatError, match=match) as info:
        gp.read_particles(path, **kw)
    e = info.value
    assert str(path) in str(e) and e.path == Path(path)
    # granpack's message alone, without the gsd or numpy error it came from
    assert e.__cause__ is None and (e.__context__ is None or e.__suppress_context__)
    return e


def test_damaged_and_foreign_gsd_files_are_refused_naming_frame_and_chunk(
    gsd_hoomd, pack, tmp_path
):
    good = write_gsd(pack, tmp_path / "good.gsd").read_bytes()
    # cut anywhere: the header, the index, the data, the last byte
    for k, n in enumerate([0, 5, 100, 300, len(good) // 2, len(good) - 1]):
        cut = tmp_path / f"cut{k}.gsd"
        cut.write_bytes(good[:n])
        _refused(cut, "not a gsd file|not a readable gsd file")
    text = tmp_path / "text.gsd"
    text.write_text("1 2 3 0.5\n" * 20)
    _refused(text, "not a gsd file")
    # a frame without diameters (HOOMD's default diameter 1 is not taken for a radius)
    path = tmp_path / "nodiam.gsd"
    with gsd_hoomd.open(path, "w") as traj:
        traj.append(_frame(gsd_hoomd, X4, None, [1, 1, 1, 0, 0, 0]))
    e = _refused(path, "frame 0, chunk particles/diameter: missing")
    assert "frame 0, chunk particles/diameter" in e.reason
    # a later frame with another number of particles does not take frame 0's diameters
    path = tmp_path / "grows.gsd"
    with gsd_hoomd.open(path, "w") as traj:
        traj.append(_frame(gsd_hoomd, X4, [0.5] * 4, [1, 1, 1, 0, 0, 0]))
        traj.append(_frame(gsd_hoomd, X4[:3], None, [1, 1, 1, 0, 0, 0]))
    _refused(path, "frame 1, chunk particles/diameter: missing")
    assert len(gp.read_particles(path, snapshot=0)) == 4
    # non-finite values, a diameter <= 0, a tilted box, an empty frame
    bad = X4.copy()
    bad[2, 1] = np.nan
    for name, x, d, box, match in [
        (
            "nan",
            bad,
            [0.5] * 4,
            [1, 1, 1, 0, 0, 0],
            "frame 0, chunk particles/position: particle 2",
        ),
        ("inf", X4, [0.5, np.inf, 0.5, 0.5], [1, 1, 1, 0, 0, 0], "particles/diameter: particle 1"),
        ("zero", X4, [0.5, 0.5, 0.0, 0.5], [1, 1, 1, 0, 0, 0], "particles/diameter: particle 2"),
        ("tilt", X4, [0.5] * 4, [1, 1, 1, 0.1, 0, 0], "configuration/box: a triclinic box"),
        ("boxnan", X4, [0.5] * 4, [1, np.nan, 1, 0, 0, 0], "configuration/box: non-finite"),
        ("empty", X4[:0], [], [2, 2, 2, 0, 0, 0], "frame 0 holds no particles"),
    ]:
        path = tmp_path / f"{name}.gsd"
        with gsd_hoomd.open(path, "w") as traj:
            traj.append(_frame(gsd_hoomd, x, d, box))
        _refused(path, match)
    # a gsd file of another schema, a frame the file does not hold, a damaged tag
    import gsd.fl as gsd_fl

    other = tmp_path / "other.gsd"
    with gsd_fl.open(str(other), "w", application="t", schema="mine", schema_version=[1, 0]) as f:
        f.write_chunk("particles/N", np.array([1], np.uint32))
        f.end_frame()
    _refused(other, "schema 'mine'")
    _refused(tmp_path / "good.gsd", "snapshot = 1 is out of range", snapshot=1)
    with pytest.raises(gp.InvalidParameterError):
        gp.read_particles(tmp_path / "good.gsd", snapshot="last")
    path = write_gsd(pack, tmp_path / "tag.gsd")
    with gsd_hoomd.open(path, "r+") as traj:
        frame = traj[0]
        frame.log = {"granpack/container": "dim=3 container=sphere"}
        traj.append(frame)
    _refused(path, "frame 1, chunk log/granpack/container: container='sphere'")


def test_a_changed_byte_gives_particles_or_a_file_format_error(gsd_hoomd, tmp_path):
    # gsd has no checksums: a changed value in the data reads as that value, anything
    # else is refused; never another error
    pack = gp.generate(small_scene(3).replace(height=0.1).fast())
    good = write_gsd(pack, tmp_path / "good.gsd").read_bytes()
    rng = np.random.default_rng(7)
    path = tmp_path / "bad.gsd"
    refused = 0
    for _ in range(60):
        data = bytearray(good)
        for k in rng.integers(0, len(data), size=int(rng.integers(1, 6))):
            data[k] = int(rng.integers(0, 256))
        path.write_bytes(bytes(data))
        try:
            p = gp.read_particles(path, format="gsd")
        except gp.FileFormatError as e:
            assert str(path) in str(e)
            refused += 1
        else:
            assert len(p) == len(pack) and np.all(p.radii > 0)
    assert refused > 0


# -- OVITO ------------------------------------------------------------------------------------

MONO = [(3, "box"), (3, "periodic"), (3, "cylinder"), (2, "box"), (2, "periodic")]


@pytest.fixture(scope="module", params=MONO, ids=[f"{d}d-{c}" for d, c in MONO])
def mono(request) -> gp.Pack:
    """Monodisperse packs (one cutoff counts every contact): example 4.3's spheres
    (r = 0.02 m) 0.15 m high, about 2000 of them; 4.1's discs (r = 0.01 m) 0.1 m high."""
    dim, container = request.param
    preset = "4.3" if dim == 3 else "4.1"
    scene = gp.PackScene.preset(preset).fast().replace(height=0.15 if dim == 3 else 0.1)
    return gp.generate(scene.replace(container=container))


def _pbc(pack: gp.Pack) -> tuple[bool, bool, bool]:
    """The pack's periodic axes, as OVITO's cell flags (2D: x, y, then z)."""
    periodic = pack.scene.container == "periodic"
    return (periodic, periodic, False) if pack.dim == 3 else (periodic, False, False)


def _ovito(ovito_io, path, radius: float, pbc=None, **kw):
    """(OVITO's data as it imported the file, OVITO's count of the pairs closer than
    2 `radius` (1 + 1e-9): the sum of its coordination numbers / 2). `radius` is the
    pack's (OVITO keeps radii in float32). `pbc` overrides the cell's flags for the count
    (the container's, where the file cannot say it)."""
    from ovito.modifiers import CoordinationAnalysisModifier

    pipeline = ovito_io.import_file(str(path), **kw)
    data = pipeline.compute()
    if pbc is not None:

        def set_pbc(frame, data):
            data.cell_.pbc = pbc

        pipeline.modifiers.append(set_pbc)
    cutoff = 2.0 * radius * (1.0 + 1e-9)
    pipeline.modifiers.append(CoordinationAnalysisModifier(cutoff=cutoff, number_of_bins=10))
    counted = pipeline.compute()
    return data, int(np.sum(counted.particles["Coordination"])) // 2


def _cell(data) -> tuple[np.ndarray, np.ndarray]:
    """(origin, edge lengths) of OVITO's orthogonal cell."""
    m = np.asarray(data.cell[...])
    assert np.all(m[:, :3] == np.diag(np.diag(m[:, :3])))
    return m[:, 3], np.diag(m[:, :3])


def _same_centres(x: np.ndarray, pack: gp.Pack) -> None:
    """OVITO's centres read from text are the pack's to a unit in the last place (its
    number parser does not always round correctly)."""
    scale = float(np.max(pack.box[1]))
    np.testing.assert_allclose(x, _wrapped(pack), rtol=0, atol=1e-15 * scale)


def _radius(pack: gp.Pack) -> float:
    r = float(pack.radii[0])
    assert np.all(pack.radii == r), "one cutoff counts the contacts of one radius"
    return r


def _radius32(pack: gp.Pack) -> float:
    """The radius a gsd file gives back: half the float32 diameter."""
    return float(np.float32(2.0 * _radius(pack))) / 2.0


def test_ovito_reads_the_xyz_export(ovito_io, mono, tmp_path):
    path = export(mono, tmp_path / "p.xyz")[0]
    data, counted = _ovito(ovito_io, path, _radius(mono))  # the file's own pbc
    n, dim = len(mono), mono.dim
    assert data.particles.count == n
    np.testing.assert_array_equal(data.particles["Radius"], mono.radii.astype(np.float32))
    _same_centres(np.asarray(data.particles["Position"])[:, :dim], mono)
    origin, lengths = _cell(data)
    lo, hi = mono.box
    np.testing.assert_array_equal(origin[:dim], lo)
    np.testing.assert_array_equal(lengths[:dim], hi - lo)
    assert tuple(data.cell.pbc) == _pbc(mono)
    assert counted == _analysis(mono).n_contacts


def test_ovito_reads_the_gsd_export(ovito_io, gsd_hoomd, mono, tmp_path):
    path = export(mono, tmp_path / "p.gsd")[0]
    data, counted = _ovito(ovito_io, path, _radius32(mono), pbc=_pbc(mono))
    n, dim = len(mono), mono.dim
    assert data.particles.count == n
    np.testing.assert_array_equal(data.particles["Radius"], np.full(n, _radius32(mono), np.float32))
    x = np.asarray(data.particles["Position"]) + _shift(mono)
    scale = float(np.max(mono.box[1]))
    np.testing.assert_allclose(x[:, :dim], _wrapped(mono), rtol=0, atol=EPS32 * scale)
    origin, lengths = _cell(data)
    lo, hi = mono.box
    np.testing.assert_allclose(lengths[:dim], hi - lo, rtol=EPS32)
    np.testing.assert_allclose(origin[:dim], -(hi - lo) / 2, rtol=EPS32)
    # a gsd cell is periodic on every axis, and OVITO says so: the count takes the
    # container's flags, which granpack's log data carries
    assert tuple(data.cell.pbc) == (True, True, True)
    assert data.cell.is2D == (dim == 2)
    assert counted == _analysis(gp.read_particles(path)).n_contacts == _analysis(mono).n_contacts


def test_ovito_reads_the_lammps_data_export(ovito_io, mono, tmp_path):
    path = export(mono, tmp_path / "p.data", "lammps-data")[0]
    # a data file carries no boundary (LAMMPS' input does): the count takes the container's
    data, counted = _ovito(ovito_io, path, _radius(mono), pbc=_pbc(mono), atom_style="sphere")
    dim = mono.dim
    assert data.particles.count == len(mono)
    np.testing.assert_array_equal(
        data.particles["Particle Identifier"], np.arange(1, len(mono) + 1)
    )
    np.testing.assert_array_equal(data.particles["Radius"], mono.radii.astype(np.float32))
    _same_centres(np.asarray(data.particles["Position"])[:, :dim], mono)
    origin, lengths = _cell(data)
    lo, hi = mono.box
    np.testing.assert_array_equal(origin[:dim], lo)
    np.testing.assert_array_equal(lengths[:dim], hi - lo)
    assert counted == _analysis(mono).n_contacts


def test_ovito_reads_lammps_dump_of_the_data_export(ovito_io, lmp, mono, tmp_path):
    export(mono, tmp_path / "pack.data", "lammps-data")
    script = (
        "include in.granpack\n"
        "write_dump all custom state.dump id type x y z radius modify format float %.17g\n"
    )
    (tmp_path / "in.test").write_text(script)
    done = subprocess.run(
        [lmp, "-in", "in.test", "-log", "log.test"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-2000:]
    path = tmp_path / "state.dump"
    dim = mono.dim
    data, counted = _ovito(ovito_io, path, _radius(mono))  # the dump's own pbc
    assert data.particles.count == len(mono)
    order = np.argsort(np.asarray(data.particles["Particle Identifier"]))
    radii = np.asarray(data.particles["Radius"])[order]
    np.testing.assert_array_equal(radii, mono.radii.astype(np.float32))
    _same_centres(np.asarray(data.particles["Position"])[order][:, :dim], mono)
    # the dump's BOX BOUNDS are LAMMPS' boundary, which in 2D is periodic along z too
    pbc = _pbc(mono)
    assert tuple(data.cell.pbc) == (pbc if dim == 3 else (pbc[0], False, True))
    if dim == 2:
        # the 2D slab is 2 r thick: along its z period a disc would touch its own image,
        # so the count takes the pack's flags
        _, counted = _ovito(ovito_io, path, _radius(mono), pbc=pbc)
    assert counted == _analysis(mono).n_contacts
    assert counted == _analysis(gp.read_particles(path)).n_contacts


def test_ovito_counts_the_contacts_of_example_4_3(ovito_io, gsd_hoomd, example_4_3, tmp_path):
    pack = example_4_3
    n_c = _analysis(pack).n_contacts
    counts = {}
    for name, r, kw in (
        ("p.xyz", _radius(pack), {}),
        ("p.data", _radius(pack), {"pbc": _pbc(pack), "atom_style": "sphere"}),
        ("p.gsd", _radius32(pack), {"pbc": _pbc(pack)}),
    ):
        path = export(pack, tmp_path / name)[0]
        _, counts[name] = _ovito(ovito_io, path, r, **kw)
    n_gsd = _analysis(gp.read_particles(tmp_path / "p.gsd")).n_contacts
    print(f"example 4.3: {len(pack)} spheres, N_c {n_c}, gsd read back {n_gsd}, OVITO {counts}")
    assert counts == {"p.xyz": n_c, "p.data": n_c, "p.gsd": n_c}
    assert n_gsd == n_c
