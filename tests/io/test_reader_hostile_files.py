"""What the particle and contact readers do with files a careless or hostile user gives
them: compressed dumps, 64-bit ids, a dump still being written, mixed scaled columns,
ragged CSV rows, non-numeric Parquet columns, a path that is no path, random bytes under
a binary suffix, and a gsd export with a changed byte. Every case reads what the file
holds or is refused with a typed error that names the file (and the line)."""

from __future__ import annotations

import gzip
import warnings
from pathlib import Path

import numpy as np
import pytest

import granpack as gp
from granpack.io.registry import detect_format

BIG = 2**53  # the first integer a float64 cannot tell from its neighbour


def dump(rows: list[str], step: int = 0, columns: str = "id x y z radius", box=(0, 1)) -> str:
    lo, hi = box
    head = (
        f"ITEM: TIMESTEP\n{step}\nITEM: NUMBER OF ATOMS\n{len(rows)}\n"
        f"ITEM: BOX BOUNDS ff ff ff\n{lo} {hi}\n{lo} {hi}\n{lo} {hi}\nITEM: ATOMS {columns}\n"
    )
    return head + "".join(r + "\n" for r in rows)


ROWS = ["1 0.1 0.1 0.1 0.05", "2 0.2 0.1 0.1 0.05", "3 0.5 0.5 0.5 0.05"]


def local(rows: list[str], step: int = 0) -> str:
    """A LAMMPS dump local (layout "lammps": id1 id2 fnx fny fnz ftx fty ftz)."""
    return (
        f"ITEM: TIMESTEP\n{step}\nITEM: NUMBER OF ENTRIES\n{len(rows)}\n"
        "ITEM: BOX BOUNDS ff ff ff\n0 1\n0 1\n0 1\n"
        "ITEM: ENTRIES c_ids[1] c_ids[2] c_f[1] c_f[2] c_f[3] c_f[4] c_f[5] c_f[6]\n"
        + "".join(r + "\n" for r in rows)
    )


# -- compressed files ---------------------------------------------------------------------


def test_a_gzip_dump_reads_as_the_plain_dump(tmp_path):
    text = dump(ROWS) + dump(ROWS[:2], step=10)
    (tmp_path / "a.dump").write_text(text)
    (tmp_path / "a.dump.gz").write_bytes(gzip.compress(text.encode()))
    # LAMMPS' dump_modify append with gzip: one member per write, joined
    joined = gzip.compress(dump(ROWS).encode()) + gzip.compress(dump(ROWS[:2], step=10).encode())
    (tmp_path / "b.dump.gz").write_bytes(joined)
    plain = gp.read_particles(tmp_path / "a.dump", snapshot=0)
    for name in ("a.dump.gz", "b.dump.gz"):
        assert detect_format(tmp_path / name) == "lammps-dump"
        p = gp.read_particles(tmp_path / name, snapshot=0)
        assert p.n_snapshots == 2 and p.notes == ()
        np.testing.assert_array_equal(p.positions, plain.positions)
        np.testing.assert_array_equal(p.ids, [1, 2, 3])
        assert len(gp.read_particles(tmp_path / name)) == 2


def test_a_gzip_dump_local_reads_as_contacts(tmp_path):
    (tmp_path / "a.dump").write_text(dump(ROWS))
    p = gp.read_particles(tmp_path / "a.dump")
    (tmp_path / "pairs.dump.gz").write_bytes(
        gzip.compress(local(["1 2 -0.5 0 0 0 0.1 0"]).encode())
    )
    c = gp.read_contacts(tmp_path / "pairs.dump.gz", p)
    assert len(c) == 1 and c.contacts.force_normal[0] == 0.5


def test_a_gzip_stream_cut_short_reads_its_complete_snapshots(tmp_path):
    packed = gzip.compress((dump(ROWS) + dump(ROWS, step=10)).encode())
    # a stream cut before its end, as a dump that gzip is still writing
    (tmp_path / "cut.dump.gz").write_bytes(packed[: len(packed) - 12])
    p = gp.read_particles(tmp_path / "cut.dump.gz")
    assert (p.n_snapshots, p.timestep) == (1, 0)
    assert any("incomplete" in n and "gzip stream" in n for n in p.notes)
    # one snapshot only: nothing complete to read
    one = gzip.compress(dump(ROWS).encode())
    (tmp_path / "one.dump.gz").write_bytes(one[:-12])
    with pytest.raises(gp.FileFormatError, match="one.dump.gz.*incomplete"):
        gp.read_particles(tmp_path / "one.dump.gz")


def test_other_compressions_and_gzip_of_other_formats_are_refused_by_name(tmp_path):
    zstd = tmp_path / "a.dump.zst"
    zstd.write_bytes(b"\x28\xb5\x2f\xfd" + bytes(40))
    with pytest.raises(gp.FileFormatError, match="zstd-compressed") as info:
        gp.read_particles(zstd, format="lammps-dump")
    assert info.value.path == zstd
    with pytest.raises(gp.FileFormatError, match="zstd-compressed"):
        gp.read_particles(zstd)
    table = tmp_path / "p.csv.gz"
    table.write_bytes(gzip.compress(b"x,y,z,r\n0.1,0.1,0.1,0.05\n"))
    with pytest.raises(gp.FileFormatError, match="gzip-compressed file read as csv"):
        gp.read_particles(table)
    broken = tmp_path / "broken.dump.gz"
    broken.write_bytes(b"\x1f\x8b\x08\x00" + bytes(range(60)))
    with pytest.raises(gp.FileFormatError, match="broken.dump.gz"):
        gp.read_particles(broken, format="lammps-dump")


# -- 64-bit ids ---------------------------------------------------------------------------


@pytest.mark.parametrize("base", [BIG - 1, BIG, 2**62, 2**63 - 4])
def test_64_bit_ids_read_exactly_and_never_merge(tmp_path, base):
    rows = [f"{base + k} {x} 0.1 0.1 0.05" for k, x in enumerate(("0.1", "0.3", "0.5"))]
    (tmp_path / "a.dump").write_text(dump(rows[::-1]))
    p = gp.read_particles(tmp_path / "a.dump")
    assert p.ids.tolist() == [base, base + 1, base + 2]
    np.testing.assert_array_equal(p.positions[:, 0], [0.1, 0.3, 0.5])
    (tmp_path / "a.txt").write_text(
        "#format id_x_y_z_r_matId\n" + "".join(f"{r} 0\n" for r in rows[::-1])
    )
    assert gp.read_particles(tmp_path / "a.txt").ids.tolist() == p.ids.tolist()
    (tmp_path / "a.csv").write_text(
        "id,x,y,z,r\n" + "".join(r.replace(" ", ",") + "\n" for r in rows[::-1])
    )
    assert gp.read_particles(tmp_path / "a.csv").ids.tolist() == p.ids.tolist()
    # contacts name the particles by the same ids: the pair (base + 1, base + 2) touches
    # the right particles (0.2 m apart, radii 0.1 would touch; here 0.05: 0.1 apart)
    rows2 = [f"{base + k} {x} 0.1 0.1 0.05" for k, x in enumerate(("0.1", "0.2", "0.3"))]
    (tmp_path / "b.dump").write_text(dump(rows2))
    q = gp.read_particles(tmp_path / "b.dump")
    (tmp_path / "pairs.dump").write_text(local([f"{base + 1} {base + 2} -1 0 0 0 0 0"]))
    c = gp.read_contacts(tmp_path / "pairs.dump", q).contacts
    assert (int(c.i[0]), int(c.j[0])) == (1, 2)


def test_ids_beyond_64_bits_are_refused_naming_the_line(tmp_path):
    rows = ["1 0.1 0.1 0.1 0.05", f"{2**64} 0.3 0.1 0.1 0.05"]
    (tmp_path / "a.dump").write_text(dump(rows))
    with pytest.raises(gp.FileFormatError, match=r"a.dump:11: id .* too large"):
        gp.read_particles(tmp_path / "a.dump")


# -- a dump still being written -----------------------------------------------------------


@pytest.mark.parametrize(
    "cut, why",
    [
        (lambda t: t[: t.index("ITEM: ATOMS", t.index("TIMESTEP\n20"))], "ends inside it"),
        (lambda t: t[: t.rindex("3 0.5")], "ends inside it"),
        (lambda t: t[: t.rindex("0.5 0.05")], "holds 3 of its 5 fields"),
    ],
    ids=["in-header", "between-rows", "in-a-row"],
)
def test_a_dump_still_being_written_reads_its_complete_snapshots(tmp_path, cut, why):
    text = dump(ROWS) + dump(ROWS[:2], step=10) + dump(ROWS, step=20)
    path = tmp_path / "run.dump"
    path.write_text(cut(text))
    p = gp.read_particles(path)
    assert (p.n_snapshots, p.snapshot, p.timestep, len(p)) == (2, 1, 10, 2)
    (note,) = p.notes
    assert "last snapshot (from line 24) is incomplete" in note and why in note
    assert gp.read_particles(path, snapshot=0).timestep == 0
    with pytest.raises(gp.FileFormatError, match="out of range"):
        gp.read_particles(path, snapshot=2)


def test_a_broken_snapshot_before_the_last_is_still_refused(tmp_path):
    bad = dump(ROWS).replace("NUMBER OF ATOMS\n3", "NUMBER OF ATOMS\n4")
    path = tmp_path / "bad.dump"
    path.write_text(bad + dump(ROWS, step=10))
    with pytest.raises(gp.FileFormatError, match="bad.dump:"):
        gp.read_particles(path)
    # one snapshot that stops short has nothing complete to give
    path.write_text(dump(ROWS)[:-20])
    with pytest.raises(gp.FileFormatError, match="bad.dump:"):
        gp.read_particles(path)


# -- mixed scaled and unscaled coordinates -----------------------------------------------


def test_each_axis_reads_its_own_scaled_or_unscaled_column(tmp_path):
    rows = ["1 0.1 0.2 0.25 0.05", "2 0.3 0.2 0.75 0.05"]
    path = tmp_path / "mixed.dump"
    path.write_text(dump(rows, columns="id x y zs radius", box=(-1, 3)))
    p = gp.read_particles(path)
    # z = lo + zs (hi - lo); x and y as written
    np.testing.assert_array_equal(p.positions, [[0.1, 0.2, 0.0], [0.3, 0.2, 2.0]])
    assert any("zs (a fraction of the box)" in n for n in p.notes)
    path.write_text(dump(rows, columns="id xs y zu radius", box=(-1, 3)))
    p = gp.read_particles(path)
    np.testing.assert_allclose(p.positions[:, 0], [-0.6, 0.2], rtol=0, atol=1e-15)
    np.testing.assert_array_equal(p.positions[:, 2], [0.25, 0.75])
    path.write_text(dump(rows, columns="id xs ys zs radius", box=(0, 2)))
    p = gp.read_particles(path)
    np.testing.assert_array_equal(p.positions, [[0.2, 0.4, 0.5], [0.6, 0.4, 1.5]])
    assert p.notes == ()


# -- tables -------------------------------------------------------------------------------


@pytest.mark.parametrize("extra", [",7", ",7,8"])
def test_a_csv_row_with_an_extra_field_is_named_by_its_line(tmp_path, extra):
    path = tmp_path / "p.csv"
    path.write_text(
        "# granpack export\nx,y,z,r\n0.1,0.1,0.1,0.05\n\n0.3,0.1,0.1,0.05" + extra + "\n"
    )
    with pytest.raises(gp.FileFormatError, match=r"p.csv:5: expected 4 fields") as info:
        gp.read_particles(path)
    assert info.value.path == path


def test_non_numeric_parquet_columns_are_refused(tmp_path):
    pl = pytest.importorskip("polars")
    base = {"x": [0.1, 0.3], "y": [0.1, 0.1], "z": [0.1, 0.1]}
    for name, col, kind in [
        ("bool", {"r": [True, True]}, "Boolean"),
        ("text", {"r": ["0.05", "0.05"]}, "String"),
        ("list", {"radius": [[0.05], [0.05]]}, "List"),
    ]:
        path = tmp_path / f"{name}.parquet"
        pl.DataFrame({**base, **col}).write_parquet(path)
        with pytest.raises(gp.FileFormatError, match=f"holds {kind}"):
            gp.read_particles(path)
    pl.DataFrame(
        {**base, "r": [1, 2], "id": pl.Series([BIG + 1, BIG], dtype=pl.Int64)}
    ).write_parquet(tmp_path / "int.parquet")
    p = gp.read_particles(tmp_path / "int.parquet")
    assert p.radii.tolist() == [2.0, 1.0] and p.ids.tolist() == [BIG, BIG + 1]


# -- what is no path, and bytes that are no text -----------------------------------------


@pytest.mark.parametrize("bad", [None, 3, b"p.dump", "", ["p.dump"]])
def test_a_path_that_is_no_path_is_a_typed_error(bad, tmp_path):
    with pytest.raises(gp.InvalidParameterError, match="invalid path") as info:
        gp.read_particles(bad)
    assert info.value.parameter == "path"
    (tmp_path / "a.dump").write_text(dump(ROWS))
    p = gp.read_particles(tmp_path / "a.dump")
    with pytest.raises(gp.InvalidParameterError, match="invalid path"):
        gp.read_contacts(bad, p)


@pytest.mark.parametrize("suffix", [".npz", ".parquet", ".gsd"])
def test_random_bytes_under_a_binary_suffix_are_refused_by_that_format(tmp_path, suffix):
    rng = np.random.default_rng(0)
    path = tmp_path / f"noise{suffix}"
    for _ in range(40):
        noise = rng.integers(0, 256, int(rng.integers(1, 5000)), dtype=np.uint8).tobytes()
        # commas and letters among the bytes once made them look like a CSV header
        path.write_bytes(b"a,b" + noise)
        assert detect_format(path) == suffix[1:]
        with pytest.raises(gp.FileFormatError) as info:
            gp.read_particles(path)
        assert str(path) in str(info.value)


def test_random_bytes_without_a_suffix_are_no_text(tmp_path):
    path = tmp_path / "noise"
    path.write_bytes(b"x,y\n" + bytes(range(256)) * 4)
    with pytest.raises(gp.FileFormatError, match="not a text file"):
        gp.read_particles(path)


# -- a gsd export with a changed byte -----------------------------------------------------


def _small_pack() -> gp.Pack:
    scene = gp.PackScene.preset("4.1").replace(
        base=(0.3,), height=0.08, h_layer=0.04, settle_time=0.3, seed=5
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", gp.UnsettledPackWarning)
        return gp.generate(scene.fast())


def test_every_changed_byte_of_a_gsd_export_is_refused_or_changes_nothing(tmp_path):
    pytest.importorskip("gsd.fl")
    from granpack.io.gsd import write_gsd

    good = write_gsd(_small_pack(), tmp_path / "good.gsd").read_bytes()
    ref = gp.read_particles(tmp_path / "good.gsd")
    path = tmp_path / "bad.gsd"
    refused = same = 0
    for k in range(len(good)):
        data = bytearray(good)
        data[k] ^= 0x80 if k % 2 else 0x01  # the top bit and the bottom bit, by turns
        path.write_bytes(bytes(data))
        try:
            p = gp.read_particles(path, format="gsd")
        except gp.FileFormatError as e:
            assert str(path) in str(e)
            refused += 1
            continue
        # a byte gsd never reads (padding, unused index room, the application name)
        np.testing.assert_array_equal(p.positions, ref.positions)
        np.testing.assert_array_equal(p.radii, ref.radii)
        assert (p.container, p.box[1].tolist()) == (ref.container, ref.box[1].tolist())
        same += 1
    # the header's sizes, the index, the names and every value are guarded
    assert refused > len(good) // 4 and same > 0


def test_a_gsd_header_that_puts_the_index_beyond_the_file_is_refused(tmp_path):
    pytest.importorskip("gsd.fl")
    from granpack.io.gsd import write_gsd

    good = bytearray(write_gsd(_small_pack(), tmp_path / "good.gsd").read_bytes())
    good[23] ^= 0x10  # the index's entry count (the gsd library crashed on this one)
    (tmp_path / "bad.gsd").write_bytes(bytes(good))
    with pytest.raises(gp.FileFormatError, match="outside the file"):
        gp.read_particles(tmp_path / "bad.gsd")


def test_paths_as_str_and_pathlike_still_read(tmp_path):
    (tmp_path / "a.dump").write_text(dump(ROWS))
    assert len(gp.read_particles(str(tmp_path / "a.dump"))) == 3
    assert len(gp.read_particles(Path(tmp_path / "a.dump"))) == 3
