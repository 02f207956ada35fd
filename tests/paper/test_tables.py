"""granpack.tables: the paper's transcribed numbers, ensemble statistics, table layouts, files."""

from __future__ import annotations

import math

import numpy as np
import polars as pl
import pytest

import granpack as gp
from granpack.analysis import empirical_z, phi_from_void_ratio
from granpack.tables import (
    PRESET_TABLES,
    STAT_LABELS,
    Z_COLUMNS,
    ensemble_table,
    paper_tables,
    paper_values,
    summary,
    to_markdown,
    write_tables,
)

DENSITY_TABLES = [2, 5, 8, 11]
Z_TABLES = [3, 4, 6, 7, 9, 10, 12, 13]


# --------------------------------------------------------------------------------------
# the transcription
# --------------------------------------------------------------------------------------
def test_paper_values_layouts():
    t2 = paper_values("table2")
    assert t2.columns == ["pack", "rotations ON", "rotations OFF"]
    assert t2["pack"].to_list() == [str(k) for k in range(1, 11)] + list(STAT_LABELS)
    assert t2.row(0) == ("1", 0.854, 0.813)
    assert t2.row(12) == ("coef. variation", 0.014, 0.012)
    t9 = paper_values(9)
    assert t9.columns == ["pack", *Z_COLUMNS]
    assert t9.height == 10
    assert t9.filter(pl.col("pack") == "8")["z_yanagisawa"].item() == 7.0109  # printed so
    with pytest.raises(gp.GranpackError, match="table14"):
        paper_values("table14")


@pytest.mark.parametrize("number", Z_TABLES)
def test_empirical_formulas_reproduce_the_papers_rows_from_its_e(number):
    t = paper_values(number)
    notes = paper_values(number, notes=True).filter(pl.col("note").is_not_null())
    noted = {(r, c) for r, c in notes.select("row", "column").iter_rows()}
    for row in t.iter_rows(named=True):
        z = empirical_z(row["e"])
        for col in Z_COLUMNS[1:]:
            ours = z[col.removeprefix("z_")]
            # every printed value is within one unit of its last decimal of the formula on
            # the printed e; those that do not round to it carry a note in the data file
            assert abs(ours - row[col]) <= 1e-3 + 1e-9, (number, row["pack"], col)
            if round(ours, 3) != row[col]:
                assert (row["pack"], col) in noted, (number, row["pack"], col, ours)


@pytest.mark.parametrize("number", DENSITY_TABLES)
def test_papers_e_follows_from_its_phi(number):
    # the printed e lies within the rounding of (1 - phi)/phi of the printed phi
    t = paper_values(number)
    for rot, z_number in zip(
        ("rotations ON", "rotations OFF"), PRESET_TABLES[_preset(number)][1:], strict=True
    ):
        phi = np.array(t[rot][:10].to_list())
        e = np.array(paper_values(z_number)["e"].to_list())
        lo, hi = phi_from_void_ratio(e + 5e-4), phi_from_void_ratio(e - 5e-4)
        assert np.all((phi + 5e-4 >= lo) & (phi - 5e-4 <= hi))


def _preset(number):
    return next(p for p, t in PRESET_TABLES.items() if t[0] == number)


@pytest.mark.parametrize("number", DENSITY_TABLES)
def test_summary_reproduces_the_papers_statistics_rows(number):
    # The pack values are printed to 3 decimals: each is off by <= 5e-4, which moves the mean
    # by <= 5e-4 and the ddof = 1 standard deviation by <= 5e-4 sqrt(n/(n-1)); the printed
    # statistic adds its own 5e-4 of rounding.
    t = paper_values(number)
    packs = t.filter(~pl.col("pack").is_in(list(STAT_LABELS)))
    s = summary(packs, ["rotations ON", "rotations OFF"])
    assert s["statistic"].to_list() == ["mean", "std", "cv"]
    printed = t.filter(pl.col("pack").is_in(list(STAT_LABELS)))
    n = packs.height
    for col in ("rotations ON", "rotations OFF"):
        mean, std, cv = s[col].to_list()
        p_mean, p_std, p_cv = printed[col].to_list()
        assert abs(mean - p_mean) <= 1e-3 + 1e-12
        assert abs(std - p_std) <= 5e-4 * math.sqrt(n / (n - 1)) + 5e-4 + 1e-12
        # cv from the bounds on mean and std
        assert abs(cv - p_cv) <= (std + 1.1e-3) / (mean - 1e-3) - std / mean + 5e-4 + 1e-12


def test_paper_standard_deviations_are_ddof_1():
    t = paper_values(2).filter(~pl.col("pack").is_in(list(STAT_LABELS)))
    on = np.array(t["rotations ON"].to_list())
    assert round(on.std(ddof=1), 3) == 0.012  # as printed
    assert round(on.std(ddof=0), 3) == 0.011


# --------------------------------------------------------------------------------------
# ensembles
# --------------------------------------------------------------------------------------
def lattice_result(n: int) -> gp.analysis.Microstructure:
    """An n x n square lattice of touching discs: Z = 4 (n - 1)/n."""
    r = 0.01
    s = 2 * r * (1 - 1e-9)
    g = np.meshgrid(*[r + np.arange(n) * s] * 2, indexing="ij")
    x = np.column_stack([a.ravel() for a in g])
    return gp.microstructure(positions=x, radii=np.full(len(x), r), core_margin=2 * r)


def fake_row(phi: float, **extra) -> dict:
    e = (1 - phi) / phi
    z = empirical_z(e)
    return {
        "phi": phi,
        "void_ratio": e,
        **{f"z_{k}": v for k, v in z.items()},
        "z": 4.0 + phi,
        "z_mech": 4.2,
        "fabric_eig1": 0.52,
        "fabric_eig2": 0.48,
        "a_r_mag": 0.08,
        **extra,
    }


def test_ensemble_table_one_row_per_pack():
    results = [lattice_result(5), lattice_result(6).to_dict(), lattice_result(7)]
    df = ensemble_table(results)
    assert df.height == 3
    assert df["pack"].to_list() == [1, 2, 3]
    assert df.columns[0] == "pack"
    assert df["z"].to_list() == pytest.approx([4 * 4 / 5, 4 * 5 / 6, 4 * 6 / 7])
    assert df["n_particles"].to_list() == [25, 36, 49]
    assert set(results[1]) <= set(df.columns)
    assert ensemble_table([]).height == 0
    with pytest.raises(gp.GranpackError, match="result"):
        ensemble_table([1.0])
    with pytest.raises(gp.GranpackError, match="sequence"):
        ensemble_table({"a": 1})


def test_summary_statistics_and_degenerate_cases():
    df = pl.DataFrame({"a": [1.0, 2.0, 4.0], "b": [0.0, 0.0, 0.0], "c": [5, None, 7]})
    s = summary(df, ["a", "b", "c"], labels=STAT_LABELS)
    a = np.array([1.0, 2.0, 4.0])
    assert s["statistic"].to_list() == list(STAT_LABELS)
    assert s["a"].to_list() == pytest.approx([a.mean(), a.std(ddof=1), a.std(ddof=1) / a.mean()])
    assert s["b"].to_list() == [0.0, 0.0, None]  # cv of a zero mean is undefined
    assert s["c"].to_list() == pytest.approx([6.0, math.sqrt(2), math.sqrt(2) / 6])
    one = summary(df.head(1), ["a"])
    assert one["a"].to_list() == [1.0, None, None]
    with pytest.raises(gp.GranpackError, match="'zz'"):
        summary(df, ["zz"])
    with pytest.raises(gp.GranpackError, match="dtype"):
        summary(pl.DataFrame({"s": ["x"]}), ["s"])


def test_paper_tables_layout_and_values():
    on = [fake_row(0.86 + 0.001 * k) for k in range(10)]
    off = [fake_row(0.83 + 0.002 * k, f0=1.5) for k in range(12)]
    only_on_3d = [fake_row(0.57, fabric_eig3=0.3, phi_d=0.02) for _ in range(3)]
    tables = paper_tables(
        {("4.1", True): on, ("4.1", False): off, ("4.3", True): only_on_3d, ("4.4", False): []}
    )
    assert set(tables) == {
        "table2",
        "table3",
        "table4",
        "extra_4.1",
        "table8",
        "table9",
        "extra_4.3",
    }
    t2 = tables["table2"]
    assert t2.columns == [
        "pack",
        "rotations ON",
        "rotations OFF",
        "paper rotations ON",
        "paper rotations OFF",
    ]
    # 12 packs OFF: rows 1..12, the paper's 11 and 12 are null, ours ON null there
    assert t2["pack"].to_list() == [str(k) for k in range(1, 13)] + list(STAT_LABELS)
    assert t2["rotations ON"][10] is None and t2["paper rotations ON"][11] is None
    assert t2["paper rotations ON"][0] == 0.854
    assert t2["paper rotations OFF"].to_list()[-3:] == [0.837, 0.010, 0.012]
    phis = np.array([r["phi"] for r in off])
    assert t2["rotations OFF"].to_list()[-3:] == pytest.approx(
        [phis.mean(), phis.std(ddof=1), phis.std(ddof=1) / phis.mean()]
    )
    t3 = tables["table3"]
    assert t3.columns == ["pack", *Z_COLUMNS, *[f"paper_{c}" for c in Z_COLUMNS]]
    assert t3["e"][0] == pytest.approx((1 - 0.86) / 0.86)
    assert t3["z_athanasiou"][0] == pytest.approx(3 * (1 + t3["e"][0]) / t3["e"][0])
    assert t3["paper_z_athanasiou"][0] == 20.544
    assert t3["paper_e"].to_list()[-3:] == [None, None, None]
    t8 = tables["table8"]
    assert t8["rotations OFF"].null_count() == t8.height  # not given
    assert t8["paper rotations OFF"][0] == 0.540
    extra = tables["extra_4.1"]
    assert extra["rotations"].to_list() == ["ON"] * 13 + ["OFF"] * 15
    assert {"z", "z_mech", "fabric_eig1", "a_r_mag", "f0"} <= set(extra.columns)
    assert "fabric_eig3" not in extra.columns
    assert extra.filter((pl.col("rotations") == "OFF") & (pl.col("pack") == "mean"))[
        "f0"
    ].item() == pytest.approx(1.5)
    assert {"fabric_eig3", "phi_d"} <= set(tables["extra_4.3"].columns)


def test_paper_tables_reject_bad_keys():
    with pytest.raises(gp.GranpackError, match="preset"):
        paper_tables({("4.9", True): [fake_row(0.8)]})
    with pytest.raises(gp.GranpackError, match="rotations"):
        paper_tables({("4.1", "yes"): [fake_row(0.8)]})
    with pytest.raises(gp.GranpackError, match="key"):
        paper_tables({"4.1": [fake_row(0.8)]})


def test_write_tables_csv_and_markdown(tmp_path):
    tables = paper_tables({("4.2", True): [fake_row(0.825), fake_row(0.83)]})
    paths = write_tables(tables, tmp_path / "out")
    assert [p.name for p in paths] == [f"{n}.{ext}" for n in tables for ext in ("csv", "md")]
    back = pl.read_csv(tmp_path / "out" / "table5.csv", schema=tables["table5"].schema)
    assert back.equals(tables["table5"])
    md = (tmp_path / "out" / "table6.md").read_text().splitlines()
    assert md[0].startswith("| pack | e | z_field |")
    assert md[1].startswith("|---|---:|")
    assert md[2].split(" | ")[7] == "9.909"  # paper_z_field of pack 1, three decimals
    assert len(md) == 2 + 13
    assert not [p for p in (tmp_path / "out").iterdir() if p.name.startswith(".")]
    # rewriting replaces in place
    write_tables({"table5": tables["table5"].head(2)}, tmp_path / "out")
    assert pl.read_csv(tmp_path / "out" / "table5.csv").height == 2
    with pytest.raises(gp.GranpackError, match="file name"):
        write_tables({"../x": tables["table5"]}, tmp_path)


def test_markdown_formats_numbers_like_the_paper():
    df = pl.DataFrame({"pack": ["1", "mean"], "v": [0.8537, None], "w": [10.2481, math.inf]})
    lines = to_markdown(df).splitlines()
    assert lines[2] == "| 1 | 0.8537 | 10.248 |"
    assert lines[3] == "| mean |  | inf |"


def test_the_analysis_beyond_the_paper_has_columns_in_the_extra_tables():
    from granpack.tables import EXTRA_COLUMNS

    row = lattice_result(4).to_dict()
    beyond = {"z_std", "z_mech_iterative", "k0", "strong_fraction", "a_r_strong_mag", "q6_mean"}
    assert beyond <= set(EXTRA_COLUMNS) and beyond | {"crystal_fraction"} <= set(row)
    # every column the extra tables name is a key of to_dict() (in 2D or 3D, binned or not)
    optional = {"fabric_eig3", "stress_zz", "f0_binned", "a_n_binned_mag", "a_t_binned_mag"}
    assert set(EXTRA_COLUMNS) - optional <= set(row)
