"""granpack/data/lammps_2d.csv, the LAMMPS figures behind the choice of the 2D mass
convention (docs/physics.md): the file ships, reads, and its 4.1 ON row is the LAMMPS
pack that the peers' folder holds, measured again by granpack."""

from __future__ import annotations

import math
from importlib import resources
from pathlib import Path

import polars as pl
import pytest

import granpack as gp
from granpack.analysis import read_xyzr

PEERS = Path(__file__).resolve().parents[2].parent / "shared" / "peers"


def table() -> pl.DataFrame:
    text = resources.files("granpack").joinpath("data/lammps_2d.csv").read_text()
    return pl.read_csv(text.encode(), comment_prefix="#", schema_overrides={"example": pl.String})


def test_the_lammps_2d_figures_ship_with_their_provenance():
    df = table()
    assert df["case"].to_list() == ["4.1 ON", "4.1 OFF", "4.2 ON", "4.2 OFF"]
    assert df["rotations"].to_list() == [True, False, True, False]
    # rotations off packs looser in LAMMPS too, and the polydisperse 4.2 looser than 4.1
    phi = dict(zip(df["case"], df["phi_bulk"], strict=True))
    assert phi["4.1 OFF"] < phi["4.1 ON"] and phi["4.2 OFF"] < phi["4.2 ON"] < phi["4.1 ON"]
    assert all(0.79 < p < 0.85 for p in phi.values())
    head = resources.files("granpack").joinpath("data/lammps_2d.csv").read_text()
    for word in ("LAMMPS 29Sep2021", "density/disc", "in.pack2d_off", "analyze_dump.py"):
        assert word in head, word


def test_the_4_1_on_row_is_the_lammps_pack_measured_again():
    f = PEERS / "lammps" / "pack2d_final_xyr.txt"
    if not f.is_file():
        pytest.skip(f"LAMMPS pack {f} not present")
    x, r, _ = read_xyzr(f)
    m = gp.microstructure(positions=x, radii=r, box=([0.0, 0.0], [1.0, math.inf]))
    row = table().filter(pl.col("case") == "4.1 ON").row(0, named=True)
    assert len(r) == row["particles"]
    assert m.phi == pytest.approx(row["phi_bulk"], abs=5e-5)
    assert m.z == pytest.approx(row["z_pp"], abs=5e-4)
    assert m.phi_core_centres == pytest.approx(row["phi_core"], abs=5e-5)
