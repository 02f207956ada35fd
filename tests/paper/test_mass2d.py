"""`granpack paper` runs the 2D cases under both mass conventions and reports them beside
the paper's phi and LAMMPS' (granpack.paper.mass2d)."""

from __future__ import annotations

import json
import math

import polars as pl
import pytest

import granpack as gp
from granpack.cli import main
from granpack.paper import mass2d


def test_convention_table_puts_each_phi_in_its_column():
    scenes = {
        ("4.1", True): gp.PackScene.preset("4.1").replace(inertia_2d="sphere"),
        ("4.3", True): gp.PackScene.preset("4.3"),  # 3D: no row
    }
    table = mass2d.convention_table(
        scenes,
        phi={("4.1", True): [0.80, 0.82], ("4.3", True): [0.55]},
        other_phi={("4.1", True): [0.84, 0.85]},
        paper_phi={("4.1", True): [0.86, 0.87, 0.85]},
    )
    assert table.height == 1
    row = table.row(0, named=True)
    assert (row["example"], row["rotations"], row["packs"]) == ("4.1", "ON", 2)
    # the scene has sphere mass, so `phi` is the sphere column
    assert row["phi_sphere_mass"] == pytest.approx(0.81)
    assert row["sd_sphere_mass"] == pytest.approx(math.sqrt(2) * 0.01)
    assert row["phi_disc_mass"] == pytest.approx(0.845)
    assert row["phi_paper"] == pytest.approx(0.86) and row["sd_paper"] == pytest.approx(0.01)
    assert row["phi_lammps"] == 0.8413  # data/lammps_2d.csv, 4.1 ON
    # the presets' default is disc mass: then `phi` is the disc column
    scenes["4.1", True] = gp.PackScene.preset("4.1")
    table = mass2d.convention_table(
        scenes,
        phi={("4.1", True): [0.80, 0.82]},
        other_phi={("4.1", True): [0.84, 0.85]},
        paper_phi={},
    )
    row = table.row(0, named=True)
    assert row["phi_disc_mass"] == pytest.approx(0.81)
    assert row["phi_sphere_mass"] == pytest.approx(0.845)


def test_the_other_convention_runs_the_same_seeds_and_streams(tmp_path):
    scenes = {
        ("4.2", False): gp.PackScene.preset("4.2").replace(
            rotations=False, seed=5, inertia_2d="sphere"
        )
    }
    tasks = mass2d.other_convention_tasks(scenes, 3, tmp_path, seed=5)
    assert list(tasks) == [("4.2", False)]
    got = [(t.scene.inertia_2d, t.scene.seed, t.scene.stream) for t in tasks["4.2", False]]
    assert got == [("disc", 5, 0), ("disc", 5, 1), ("disc", 5, 2)]
    assert tasks["4.2", False][0].path.parent.name == "4.2-off-disc-mass"
    assert mass2d.OTHER == {"sphere": "disc", "disc": "sphere"}


def test_paper_reports_both_conventions_beside_lammps_and_the_paper(tmp_path, capsys):
    out = tmp_path / "paper"
    argv = ["paper", "--quick", "--examples", "4.1", "--out", str(out)]
    # Tiny scenes (hidden development options) so that the test runs in seconds.
    assert main([*argv, "--scale", "0.2", "--settle-time", "0.3", "--workers", "1"]) == 0
    assert "and 4 under the other 2D mass convention" in capsys.readouterr().out
    t = pl.read_csv(out / "tables" / "mass_2d.csv")
    assert t["rotations"].to_list() == ["ON", "OFF"]
    for rot, row in zip((True, False), t.iter_rows(named=True), strict=True):
        onoff = "on" if rot else "off"
        # the presets' default is disc mass; the sphere twins are the other convention
        for conv, folder in (("disc", f"4.1-{onoff}"), ("sphere", f"4.1-{onoff}-sphere-mass")):
            micro = out / "micro" / folder
            phis = [json.loads((micro / f"pack_00{k}.json").read_text())["phi"] for k in range(2)]
            assert row[f"phi_{conv}_mass"] == pytest.approx(sum(phis) / 2, rel=1e-12)
            pack = gp.load_pack(out / "packs" / folder / "pack_001.npz")
            assert (pack.scene.inertia_2d, pack.scene.stream) == (conv, 1)
        assert row["phi_lammps"] == (0.8413 if rot else 0.8184)
        assert row["phi_paper"] == pytest.approx(0.861 if rot else 0.837, abs=5e-4)
    # the twins differ only by the mass: the sphere packs are other packs
    a = gp.load_pack(out / "packs" / "4.1-on" / "pack_000.npz")
    b = gp.load_pack(out / "packs" / "4.1-on-sphere-mass" / "pack_000.npz")
    assert a.scene.replace(inertia_2d="sphere") == b.scene
    assert not (len(a) == len(b) and (a.positions == b.positions).all())
    report = (out / "report.md").read_text()
    assert "## The 2D mass convention" in report and "tables/mass_2d.csv" in report
    assert "The presets' default is disc mass" in report
    assert "packs/<case>-sphere-mass/" in report
