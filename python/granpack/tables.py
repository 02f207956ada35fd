"""Ensemble tables in the layout of the paper's section 4 (tables 2-13), with polars.

An ensemble is the paper's n_p packs of one example (preset "4.1" ... "4.4"), generated
with rotations ON and OFF. :func:`paper_tables` lays their microstructures out as the paper
does, with the paper's own numbers (``granpack/data/paper_tables.csv``, transcribed as
printed) beside ours, and adds an ``extra_<preset>`` table of what the paper did not print.

Tables (polars DataFrames; every table has a string column ``pack`` holding "1", "2", ...
and then "mean", "st. deviation", "coef. variation"):

- ``table2``, ``table5``, ``table8``, ``table11`` (packing fraction, one per preset): columns
  ``rotations ON``, ``rotations OFF`` (our bulk phi), ``paper rotations ON``,
  ``paper rotations OFF`` (the paper's, statistics rows included as printed).
- ``table3``/``table4``, ``table6``/``table7``, ``table9``/``table10``, ``table12``/
  ``table13`` (rotations ON/OFF): ``e``, ``z_field``, ``z_athanasiou``, ``z_yanagisawa``,
  ``z_chang`` (ours: the empirical Z of eqs. 16-19 from the void ratio) and the same names
  prefixed ``paper_``. The paper printed no statistics rows for these; ours are given and
  the paper's are null.
- ``extra_<preset>``: column ``rotations`` ("ON"/"OFF") and, per pack and then the three
  statistics, measured Z, Z with walls, Z_m, rattlers, phi_core (exact and the peers'
  centres recipe), fabric eigenvalues, Phi_d, the Table 1 measures, |a^r|, f0, |a^n|, |a^t|
  (amplitudes as in :func:`granpack.analysis.anisotropy_magnitude`) and the binned
  ones when present; then beyond the paper: the width of P(Z) and P(3..6), the rattlers
  removed iteratively and Z_m without them (D + 1 and D contacts needed), the Love-Weber
  stress's normal components and K0, the mean normal force, the strong fraction and the
  strong and weak fabric anisotropies, the bond order q6 and the crystallised fraction.

Statistics: mean, sample standard deviation (ddof = 1, as the paper: its table 2 prints
0.012 for rotations ON, 0.011 would be ddof = 0) and coefficient of variation std/mean.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping, Sequence
from importlib import resources
from pathlib import Path
from typing import cast

import polars as pl

from ._files import atomic_write
from ._validate import InvalidParameterError
from .analysis import Microstructure

__all__ = [
    "ensemble_table",
    "summary",
    "paper_tables",
    "paper_values",
    "write_tables",
    "to_markdown",
    "PRESET_TABLES",
    "STAT_LABELS",
    "Z_COLUMNS",
    "EXTRA_COLUMNS",
]

#: Paper tables of each example: (packing fractions, Z rotations ON, Z rotations OFF).
PRESET_TABLES = {"4.1": (2, 3, 4), "4.2": (5, 6, 7), "4.3": (8, 9, 10), "4.4": (11, 12, 13)}
#: Labels of the statistics rows, as the paper prints them.
STAT_LABELS = ("mean", "st. deviation", "coef. variation")
#: Columns of the coordination tables (3-4, 6-7, 9-10, 12-13).
Z_COLUMNS = ("e", "z_field", "z_athanasiou", "z_yanagisawa", "z_chang")
#: Columns of the ``extra_<preset>`` tables, in order; those absent from every row are left out.
EXTRA_COLUMNS = (
    "n_particles",
    "z",
    "z_walls",
    "z_mech",
    "n_rattlers",
    "phi_core",
    "phi_core_centres",
    "fabric_eig1",
    "fabric_eig2",
    "fabric_eig3",
    "phi_d",
    "anisotropy_curry",
    "anisotropy_thornton",
    "anisotropy_ibraim",
    "anisotropy_maeda",
    "a_r_mag",
    "f0",
    "a_n_mag",
    "a_t_mag",
    "f0_binned",
    "a_n_binned_mag",
    "a_t_binned_mag",
    "z_std",
    "coordination_p3",
    "coordination_p4",
    "coordination_p5",
    "coordination_p6",
    "n_rattlers_iterative",
    "z_mech_iterative",
    "n_rattlers_frictional",
    "z_mech_frictional",
    "stress_xx",
    "stress_yy",
    "stress_zz",
    "k0",
    "unbalanced",
    "force_normal_mean",
    "strong_fraction",
    "a_r_strong_mag",
    "a_r_weak_mag",
    "q6_mean",
    "q6_global",
    "crystal_fraction",
    "d10_mass",
    "d50_mass",
    "d90_mass",
    "cu_mass",
    "cc_mass",
    "d50_number",
    "cu_number",
)
_PAPER_DATA = "paper_tables.csv"


def _row(result) -> dict:
    if isinstance(result, Microstructure):
        return result.to_dict()
    if isinstance(result, Mapping):
        return dict(result)
    raise InvalidParameterError(
        f"invalid result = {type(result).__name__}: expected a Microstructure or a dict "
        "from Microstructure.to_dict()",
        parameter="result",
    )


def ensemble_table(results: Sequence[Microstructure | Mapping]) -> pl.DataFrame:
    """One row per pack: the flat ``to_dict()`` of each result.

    Parameters
    ----------
    results : sequence of Microstructure or dict
        Dicts are taken as they are (e.g. rows read back from a file).

    Returns
    -------
    pl.DataFrame
        Column ``pack`` (int, 1-based, unless the rows carry their own) first, then every key
        of the rows (a key missing from some rows is null there). No summary rows.
    """
    if isinstance(results, Mapping | str) or not isinstance(results, Sequence):
        raise InvalidParameterError(
            f"invalid results = {type(results).__name__}: expected a sequence of "
            "Microstructure or dicts",
            parameter="results",
        )
    rows = [_row(r) for r in results]
    if not rows:
        return pl.DataFrame({"pack": pl.Series([], dtype=pl.Int64)})
    if not all("pack" in r for r in rows):
        rows = [
            {"pack": k + 1, **{a: b for a, b in r.items() if a != "pack"}}
            for k, r in enumerate(rows)
        ]
    try:
        return pl.from_dicts(rows, infer_schema_length=None)
    except (TypeError, ValueError, pl.exceptions.PolarsError) as exc:
        raise InvalidParameterError(
            f"invalid results: rows are not flat dicts of scalars ({exc})", parameter="results"
        ) from None


def summary(
    df: pl.DataFrame,
    columns: Sequence[str],
    labels: Sequence[str] = ("mean", "std", "cv"),
) -> pl.DataFrame:
    """Mean, sample standard deviation (ddof = 1) and coefficient of variation of columns.

    Parameters
    ----------
    df : pl.DataFrame
        One row per pack (e.g. from :func:`ensemble_table`).
    columns : sequence of str
        Numeric columns to summarise. Nulls are skipped; a NaN makes its column's
        statistics NaN.
    labels : three str
        Names of the statistics rows; default ("mean", "std", "cv"); :func:`paper_tables`
        uses the paper's ("mean", "st. deviation", "coef. variation").

    Returns
    -------
    pl.DataFrame
        Three rows; column ``statistic`` (the labels) then one Float64 column per requested
        column: mean; std with ddof = 1 (null with fewer than two values); cv = std/mean
        (null when std is null or mean is 0).
    """
    labels = tuple(labels)
    if len(labels) != 3 or not all(isinstance(s, str) for s in labels):
        raise InvalidParameterError(
            f"invalid labels = {labels!r}: expected three strings", parameter="labels"
        )
    out: dict[str, list] = {"statistic": list(labels)}
    for col in columns:
        if col not in df.columns:
            raise InvalidParameterError(
                f"invalid column {col!r}: not in the table (columns: {', '.join(df.columns)})",
                parameter="column",
            )
        s = df[col]
        if not (s.dtype.is_numeric() or s.dtype == pl.Null):
            raise InvalidParameterError(
                f"invalid column {col!r}: dtype {s.dtype}, expected numbers", parameter="column"
            )
        s = s.cast(pl.Float64).drop_nulls()
        # a Float64 column's mean and std are floats (or None when empty)
        mean = cast("float | None", s.mean()) if len(s) else None
        std = cast("float | None", s.std(ddof=1)) if len(s) >= 2 else None
        cv = None if std is None or not mean else std / mean
        out[col] = [mean, std, cv]
    return pl.DataFrame(out, schema={"statistic": pl.Utf8, **{c: pl.Float64 for c in columns}})


@functools.lru_cache(maxsize=1)
def _paper_long() -> pl.DataFrame:
    text = resources.files("granpack").joinpath("data", _PAPER_DATA).read_bytes()
    return pl.read_csv(
        text,
        comment_prefix="#",
        schema_overrides={
            "table": pl.Utf8,
            "example": pl.Utf8,
            "row": pl.Utf8,
            "column": pl.Utf8,
            "value": pl.Float64,
            "note": pl.Utf8,
        },
    )


def paper_values(table: str | int, notes: bool = False) -> pl.DataFrame:
    """The paper's printed numbers for one of its tables 2-13.

    Parameters
    ----------
    table : str
        "table2" ... "table13" (an int or "2" is accepted too).
    notes : bool
        If True, return the long form with the transcription notes instead: columns
        table, example, row, column, value, note (note non-null where a printed value is a
        typo or does not follow from the printed e, e.g. table 9's "7.0109").

    Returns
    -------
    pl.DataFrame
        Wide form: column ``pack`` ("1"..."10", and for the density tables "mean",
        "st. deviation", "coef. variation"), then ``rotations ON``, ``rotations OFF``
        (tables 2, 5, 8, 11) or ``e``, ``z_field``, ``z_athanasiou``, ``z_yanagisawa``,
        ``z_chang`` (the others), Float64, as printed.
    """
    name = f"table{table}" if isinstance(table, int) or str(table).isdigit() else str(table)
    long = _paper_long().filter(pl.col("table") == name)
    if long.height == 0:
        known = ", ".join(f"table{k}" for k in range(2, 14))
        raise InvalidParameterError(
            f"invalid table = {table!r}: the paper's tables are {known}", parameter="table"
        )
    if notes:
        return long
    rows = list(dict.fromkeys(long["row"].to_list()))
    cols = list(dict.fromkeys(long["column"].to_list()))
    lookup = {(r, c): v for r, c, v in long.select("row", "column", "value").iter_rows()}
    data = {"pack": rows}
    for c in cols:
        data[c] = [lookup.get((r, c)) for r in rows]
    return pl.DataFrame(data, schema={"pack": pl.Utf8, **{c: pl.Float64 for c in cols}})


def _check_results(results) -> dict[tuple[str, bool], list[dict]]:
    if not isinstance(results, Mapping):
        raise InvalidParameterError(
            f"invalid results = {type(results).__name__}: expected a dict mapping "
            "(preset, rotations) to a sequence of results",
            parameter="results",
        )
    out = {}
    for key, seq in results.items():
        if not (isinstance(key, tuple) and len(key) == 2):
            raise InvalidParameterError(
                f"invalid results key {key!r}: expected (preset, rotations)", parameter="results"
            )
        preset, rot = key
        if preset not in PRESET_TABLES:
            raise InvalidParameterError(
                f"invalid preset {preset!r}: expected one of {', '.join(PRESET_TABLES)}",
                parameter="preset",
            )
        if not isinstance(rot, bool):
            raise InvalidParameterError(
                f"invalid rotations {rot!r} for preset {preset}: expected bool",
                parameter="rotations",
            )
        rows = ensemble_table(seq).to_dicts()
        if rows:  # an empty ensemble is the same as a missing one
            out[(preset, rot)] = rows
    return out


def _pack_rows(n: int) -> list[str]:
    return [str(k + 1) for k in range(n)]


def _column(rows: list[dict], key: str, n: int) -> list:
    vals = [r.get(key) for r in rows]
    return vals + [None] * (n - len(vals))


def _stats(values: list, name: str) -> list:
    df = pl.DataFrame({name: values}, schema={name: pl.Float64})
    return summary(df, [name])[name].to_list()


def _phi_table(preset: str, got: dict) -> pl.DataFrame:
    paper = paper_values(PRESET_TABLES[preset][0])
    paper_packs = paper.filter(~pl.col("pack").is_in(list(STAT_LABELS)))
    on, off = got.get((preset, True), []), got.get((preset, False), [])
    n = max(len(on), len(off), paper_packs.height)
    data: dict[str, list] = {"pack": _pack_rows(n) + list(STAT_LABELS)}
    for label, rows in (("rotations ON", on), ("rotations OFF", off)):
        vals = _column(rows, "phi", n)
        data[label] = vals + _stats(vals, label)
    for label in ("rotations ON", "rotations OFF"):
        by_row = dict(zip(paper["pack"].to_list(), paper[label].to_list(), strict=True))
        data[f"paper {label}"] = [by_row.get(p) for p in data["pack"]]
    return pl.DataFrame(
        data, schema={"pack": pl.Utf8, **{k: pl.Float64 for k in data if k != "pack"}}
    )


def _z_table(number: int, rows: list[dict]) -> pl.DataFrame:
    paper = paper_values(number)
    n = max(len(rows), paper.height)
    data: dict[str, list] = {"pack": _pack_rows(n) + list(STAT_LABELS)}
    for col in Z_COLUMNS:
        key = "void_ratio" if col == "e" else col
        vals = _column(rows, key, n)
        data[col] = vals + _stats(vals, col)
    for col in Z_COLUMNS:
        by_row = dict(zip(paper["pack"].to_list(), paper[col].to_list(), strict=True))
        data[f"paper_{col}"] = [by_row.get(p) for p in data["pack"]]
    return pl.DataFrame(
        data, schema={"pack": pl.Utf8, **{k: pl.Float64 for k in data if k != "pack"}}
    )


def _extra_table(preset: str, got: dict) -> pl.DataFrame:
    groups = [
        (lab, got[(preset, rot)])
        for lab, rot in (("ON", True), ("OFF", False))
        if (preset, rot) in got
    ]
    present = [c for c in EXTRA_COLUMNS if any(c in r for _, rows in groups for r in rows)]
    parts = []
    for lab, rows in groups:
        n = len(rows)
        data: dict[str, list] = {
            "rotations": [lab] * (n + 3),
            "pack": _pack_rows(n) + list(STAT_LABELS),
        }
        for col in present:
            vals = [None if r.get(col) is None else float(r[col]) for r in rows]
            data[col] = vals + _stats(vals, col)
        schema = {"rotations": pl.Utf8, "pack": pl.Utf8, **{c: pl.Float64 for c in present}}
        parts.append(pl.DataFrame(data, schema=schema))
    return pl.concat(parts, how="vertical")


def paper_tables(
    results: Mapping[tuple[str, bool], Sequence[Microstructure | Mapping]],
) -> dict[str, pl.DataFrame]:
    """The paper's tables 2-13 for our ensembles, the paper's values beside ours.

    Parameters
    ----------
    results : mapping
        (preset, rotations) -> the microstructures (or their ``to_dict()`` rows) of that
        ensemble's packs, preset one of "4.1" ... "4.4", rotations a bool. Presets not
        given (or given no packs) are skipped; for a preset given with one rotation setting
        only, the density table's other column is null and the other coordination table is
        left out.

    Returns
    -------
    dict of str to pl.DataFrame
        "table2" ... "table13" and "extra_4.1" ... in the layouts of the module doc: pack
        rows (as many as the larger of our ensemble and the paper's ten; missing values
        null), then "mean", "st. deviation" (ddof = 1) and "coef. variation".
    """
    got = _check_results(results)
    out: dict[str, pl.DataFrame] = {}
    for preset, (t_phi, t_on, t_off) in PRESET_TABLES.items():
        if not any((preset, rot) in got for rot in (True, False)):
            continue
        out[f"table{t_phi}"] = _phi_table(preset, got)
        for number, rot in ((t_on, True), (t_off, False)):
            if (preset, rot) in got:
                out[f"table{number}"] = _z_table(number, got[(preset, rot)])
        out[f"extra_{preset}"] = _extra_table(preset, got)
    return out


# --------------------------------------------------------------------------------------
# files
# --------------------------------------------------------------------------------------
def _fmt(v) -> str:
    if v is None:
        return ""
    if isinstance(v, bool):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v) or math.isinf(v):
            return str(v)
        # Three decimals as the paper prints, four significant digits for small values.
        return f"{v:.3f}" if v == 0.0 or abs(v) >= 1.0 else f"{v:.4g}"
    return str(v)


def to_markdown(df: pl.DataFrame) -> str:
    """A GitHub-flavoured Markdown table of `df` (numbers right-aligned, nulls empty;
    floats to three decimals, or four significant digits below 1)."""
    head = "| " + " | ".join(df.columns) + " |"
    align = "|" + "|".join("---:" if dt.is_numeric() else "---" for dt in df.dtypes) + "|"
    body = ["| " + " | ".join(_fmt(v) for v in row) + " |" for row in df.iter_rows()]
    return "\n".join([head, align, *body]) + "\n"


def write_tables(tables: Mapping[str, pl.DataFrame], out_dir) -> list[Path]:
    """Writes each table as ``<name>.csv`` and ``<name>.md`` in `out_dir` (created if
    needed), each atomically (a temporary file in the same folder, then a rename).

    Parameters
    ----------
    tables : mapping of str to pl.DataFrame
        Names must be plain file names (no path separators, not starting with a dot).
    out_dir : str or Path

    Returns
    -------
    list of Path
        The files written, csv then md for each table, in the mapping's order.
    """
    if not isinstance(tables, Mapping):
        raise InvalidParameterError(
            f"invalid tables = {type(tables).__name__}: expected a dict", parameter="tables"
        )
    out = Path(out_dir)
    for name, df in tables.items():
        if (
            not isinstance(name, str)
            or not name
            or name.startswith(".")
            or any(s in name for s in ("/", "\\", "\0"))
        ):
            raise InvalidParameterError(
                f"invalid table name {name!r}: must be a plain file name", parameter="table"
            )
        if not isinstance(df, pl.DataFrame):
            raise InvalidParameterError(
                f"invalid table {name!r}: {type(df).__name__}, expected polars", parameter="table"
            )
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for name, df in tables.items():
        csv = out / f"{name}.csv"
        md = out / f"{name}.md"
        atomic_write(csv, df.write_csv().encode())
        atomic_write(md, to_markdown(df).encode())
        written += [csv, md]
    return written
