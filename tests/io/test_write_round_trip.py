"""`gp.write` is the other direction of `gp.read_particles`: every format both written and
read carries one name both ways, and a pack written and read back is analysed to the same
phi in the same container."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from scenes import small_scene

import granpack as gp
from granpack.analysis import Container, MicrostructureWarning
from granpack.io import FORMATS, WRITERS

# the formats both written and read: their names are the same strings in both tables
BOTH_WAYS = sorted(set(WRITERS) & set(FORMATS))
# the file each writes for "p" + suffix that read_particles reads (the tables write two)
READ_BACK = {"csv": "p.particles.csv", "parquet": "p.particles.parquet"}


@pytest.fixture(scope="module", params=[(3, "periodic"), (3, "cylinder"), (2, "box")])
def pack(request) -> gp.Pack:
    dim, container = request.param
    scene = small_scene(dim, container=container).replace(height=0.3 if dim == 3 else 0.2)
    return gp.generate(scene.fast())


def _phi(subject) -> float:
    # small packs have an empty core window: not what these tests check
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MicrostructureWarning)
        return gp.microstructure(subject).phi


def test_every_format_read_and_written_has_one_name_both_ways():
    # the LAMMPS data file was "lammps" one way and "lammps-data" the other
    assert "lammps-data" in BOTH_WAYS and "lammps" not in WRITERS
    assert set(BOTH_WAYS) == {"lammps-data", "yade", "xyz", "csv", "parquet", "gsd", "kratos"} | {
        "npz"
    }


@pytest.mark.parametrize("fmt", BOTH_WAYS)
def test_a_pack_written_reads_back_under_its_format_name_with_the_same_phi(pack, fmt, tmp_path):
    written = gp.write(pack, tmp_path / f"p{WRITERS[fmt].suffix}", format=fmt)
    assert all(p.is_file() for p in written)
    back = gp.read_particles(tmp_path / READ_BACK.get(fmt, f"p{WRITERS[fmt].suffix}"))
    assert back.format == fmt
    assert back.container == pack.scene.container
    # the one Container, written by the pack and read back from the file
    written_in, read_in = Container.of_pack(pack), back.to_container()
    assert (read_in.kind, read_in.radius, read_in.lid) == (
        written_in.kind,
        written_in.radius,
        written_in.lid,
    )
    assert len(back) == len(pack)
    # gsd stores positions and diameters as float32 (7 digits); the others at full precision
    rel = 1e-6 if fmt == "gsd" else 1e-12
    assert _phi(back) == pytest.approx(_phi(pack), rel=rel, abs=0)
    assert _phi(back) == pytest.approx(pack.phi, rel=rel, abs=0)


@pytest.mark.parametrize("fmt", ["lammps-data", "xyz", "gsd", "kratos", "npz"])
def test_write_takes_the_format_from_the_suffix_as_read_particles_does(pack, fmt, tmp_path):
    path = tmp_path / f"p{WRITERS[fmt].suffix}"
    gp.write(pack, path)
    assert gp.read_particles(path).format == fmt


def test_a_suffix_that_names_no_format_is_refused_before_writing(pack, tmp_path):
    with pytest.raises(gp.InvalidParameterError, match="cannot tell the export format") as e:
        gp.write(pack, tmp_path / "p.unknown")
    assert e.value.parameter == "format"
    with pytest.raises(gp.InvalidParameterError, match="choose one of") as e:
        gp.write(pack, tmp_path / "p.data", format="lammps-dump")  # read, never written
    assert e.value.parameter == "format"
    assert list(tmp_path.iterdir()) == []


def test_the_former_name_lammps_still_writes_the_data_file_and_warns_once(pack, tmp_path):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        old = gp.write(pack, tmp_path / "old" / "p.data", format="lammps")
    deprecations = [w for w in caught if issubclass(w.category, DeprecationWarning)]
    assert len(deprecations) == 1
    assert "'lammps' is now 'lammps-data'" in str(deprecations[0].message)
    new = gp.write(pack, tmp_path / "new" / "p.data", format="lammps-data")
    assert [p.name for p in old] == [p.name for p in new] == ["p.data", "in.granpack"]
    for a, b in zip(old, new, strict=True):
        assert a.read_bytes() == b.read_bytes()


def test_the_npz_written_is_the_pack_itself(pack, tmp_path):
    (path,) = gp.write(pack, tmp_path / "p.npz")
    loaded = gp.load_pack(path)
    np.testing.assert_array_equal(loaded.positions, pack.positions)
    np.testing.assert_array_equal(loaded.radii, pack.radii)
    assert loaded.scene == pack.scene
