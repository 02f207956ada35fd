"""A consolidated periodic sample tiles with its lid: the copies stand side by side under
one lid at the same height, the consolidation record (and the rest and density records)
come along, and the tiled sample is analysed up to the lid and exported with it, so that
LAMMPS continues it as it continues the original (the lid holds it; without the lid the
compressed sample bursts)."""

from __future__ import annotations

import json
import math
import re
import warnings

import numpy as np
import pytest
from peer_runs import lid_force_in, run
from scenes import small_scene

import granpack as gp
from granpack.analysis import MicrostructureWarning
from granpack.contacts import LID_ID
from granpack.history import StageRecord
from granpack.io import export
from granpack.io.lammps import read_lammps_data
from granpack.io.lammps_input import lid_force

COUNTS = {2: (3,), 3: (2, 2)}


@pytest.fixture(scope="module", params=[3, 2], ids=["3d", "2d"])
def consolidated(request) -> gp.Pack:
    """A small periodic deposit, brought to rest (the rest record), consolidated to
    10 kPa (oedometric, the periodic cell's mode), with a density record beside."""
    dim = request.param
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", gp.UnsettledPackWarning)
        deposit = gp.generate(small_scene(dim, container="periodic"))
    pack = gp.consolidate(gp.settle(deposit, 1e-3), 1e4)
    assert pack.record("rest") is not None and np.count_nonzero(pack.contacts.j == LID_ID) > 0
    # a density record as a density target leaves it (granpack.density): carried as it is
    phi = pack.record("consolidate").report["phi"]
    density = {"target": {"target_phi": 0.5}, "phi": phi, "history": [1], "seconds": 0.0}
    return pack.with_record(StageRecord.from_table("density", density))


def _analysis(subject) -> gp.Microstructure:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MicrostructureWarning)
        return gp.microstructure(subject)


def test_a_tiled_consolidated_sample_keeps_its_lid_and_records(consolidated, tmp_path):
    pack = consolidated
    counts = COUNTS[pack.dim]
    copies = math.prod(counts)
    tiled = gp.tile(pack, counts)
    rec, rec0 = tiled.record("consolidate").table(), pack.record("consolidate").table()
    assert rec is not None
    # the lid stands where it stood, over the whole tiled base
    assert tiled.height == pack.height == rec["height"] == rec0["height"]
    assert rec["walls"] == rec0["walls"]
    assert rec["wall_stress"] == rec0["wall_stress"]
    assert rec["phi"] == rec0["phi"] and rec["k0"] == rec0["k0"]
    assert rec["wall_contacts"] == {n: v * copies for n, v in rec0["wall_contacts"].items()}
    assert rec["deposit_base"] == [b * c for b, c in zip(rec0["deposit_base"], counts, strict=True)]
    assert (
        tiled.record("rest").table() == pack.record("rest").table()
        and tiled.record("density").table() == pack.record("density").table()
    )
    # the lid's contacts are copied with their particles
    assert np.count_nonzero(tiled.contacts.j == LID_ID) == copies * np.count_nonzero(
        pack.contacts.j == LID_ID
    )
    # analysed up to the lid, as the original: phi (the record's), Z, the stress
    m0, m = _analysis(pack), _analysis(tiled)
    assert m.phi == pytest.approx(m0.phi, rel=1e-12) and m.phi == pytest.approx(rec["phi"])
    assert m.z == pytest.approx(m0.z, rel=1e-12)
    assert m.n_wall_contacts == copies * m0.n_wall_contacts
    np.testing.assert_allclose(m.stress, m0.stress, rtol=1e-9, atol=0)
    assert m.unbalanced == pytest.approx(rec0["unbalanced"], rel=1e-9)
    # the lid force is the copies' sum: the same stress over the tiled lid
    assert lid_force(tiled) == pytest.approx(copies * lid_force(pack), rel=1e-12)
    # the records survive the pack file
    back = gp.load_pack(tiled.save(tmp_path / "tiled.npz"))
    # (json's text compares the NaN entries that a periodic sample's boundary_stress holds)
    assert json.dumps(back.record("consolidate").table(), sort_keys=True) == json.dumps(
        rec, sort_keys=True
    )
    assert back.record("rest").table() == tiled.record("rest").table()
    assert back.record("density").table() == tiled.record("density").table()


def test_a_tiled_consolidated_sample_is_exported_with_its_lid(consolidated, tmp_path):
    tiled = gp.tile(consolidated, COUNTS[consolidated.dim])
    lid = tiled.record("consolidate").table()["walls"]["lid"]
    written = export(tiled, tmp_path / "pack.data", "lammps-data")
    data = read_lammps_data(written[0])
    assert data["box"][1][tiled.dim - 1] == lid
    text = written[1].read_text()
    plane = "zplane" if tiled.dim == 3 else "yplane"
    assert f"{plane} NULL {lid!r} contacts" in text and "v_lid_force" in text
    # and the export read back is the tiled sample up to its lid
    p = gp.read_particles(written[0])
    assert p.lid == tiled.record("consolidate").table()["height"]
    m0, m = _analysis(tiled), _analysis(p)
    assert m.phi == pytest.approx(m0.phi, rel=1e-12)
    assert (m.z, m.n_wall_contacts) == (m0.z, m0.n_wall_contacts)


def test_lammps_continues_a_tiled_sample_as_its_original(consolidated, lmp, tmp_path):
    # 1 000 steps in LAMMPS of the original and of its copies side by side: the lid
    # force at the export is granpack's, and the copies' kinetic energy and lid force
    # stay the original's times the copies (without the lid the compressed sample
    # bursts: its kinetic energy grows by five orders of magnitude)
    pack = consolidated
    counts = COUNTS[pack.dim]
    copies = math.prod(counts)
    tiled = gp.tile(pack, counts)
    found = {}
    for name, p in (("original", pack), ("tiled", tiled)):
        where = tmp_path / name
        where.mkdir()
        export(p, where / "pack.data", "lammps-data")
        assert lid_force_in(lmp, where, 0) == pytest.approx(lid_force(p), rel=1e-5)
        log = run(
            lmp,
            where,
            "variable steps index 1000\ninclude in.granpack\n"
            'print "LID ${lid_force}"\nprint "KE $(ke:%.17g)"\n',
        )
        found[name] = [
            float(re.findall(rf"^{k} (\S+)", log, re.MULTILINE)[-1]) for k in ("LID", "KE")
        ]
    (lid0, ke0), (lid, ke) = found["original"], found["tiled"]
    assert lid == pytest.approx(copies * lid0, rel=1e-3)
    assert ke == pytest.approx(copies * ke0, rel=1e-3)
    assert ke < 1e-3  # J: at rest under its lid
