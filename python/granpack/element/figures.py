"""The figures of an element test's lab report (matplotlib, PNG).

Built on `matplotlib.figure.Figure` with the Agg canvas, never through pyplot (as
`granpack.plot`): nothing opens a window or touches global state. The ``*_plot``
functions return the figure; the ``*_figure`` functions write it as a PNG, atomically
(`granpack.plot.save`), and return the path.

* `triaxial_plot` / `triaxial_figure`: q, eps_v and the fabric's deviator against the
  axial strain, one line per table (label), the peak of each marked.
* `compression_plot` / `compression_figure`: the void ratio against log10 of the
  stress (sigma_v for an oedometer table, p for an isotropic one), loading and
  unloading marked apart.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np
import polars as pl
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from .._validate import as_int
from ..errors import InvalidParameterError
from ..plot import save
from .lab import _columns, _sin_mobilised, compression_report

__all__ = ["triaxial_plot", "triaxial_figure", "compression_plot", "compression_figure"]

#: The columns `triaxial_plot` reads from each table.
_TRIAXIAL = ("eps_a", "eps_v", "sigma_1", "sigma_3", "fabric_dev")


def _figure(width: float, height: float) -> Figure:
    fig = Figure(figsize=(width, height), layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _unit(dim: int) -> str:
    """The stress unit of the axes: kPa in 3D, kN/m in 2D (a 2D stress is a force per
    length)."""
    return "kN/m" if as_int("dim", dim, 2, 3) == 2 else "kPa"


def _tables(tables: object) -> Mapping[str, pl.DataFrame]:
    if not isinstance(tables, Mapping) or not tables:
        raise InvalidParameterError(
            "invalid tables: a non-empty mapping of label -> element table expected "
            '(e.g. {"Dr 0.2": loose, "Dr 0.8": dense})',
            parameter="tables",
        )
    return tables


def triaxial_plot(tables: Mapping[str, pl.DataFrame], *, dim: int = 3) -> Figure:
    """Three panels against the axial strain eps_a (%): the deviator q = sigma_1 -
    sigma_3 (kPa; kN/m in 2D), the volumetric strain eps_v (%, compression-positive)
    and the fabric's deviator fabric_dev (-). One line per label of `tables` (e.g.
    ``{"Dr 0.2": loose, "Dr 0.8": dense}`` or ``{"granpack": a, "YADE": b}``); each
    line's peak (its row of the largest (s1 - s3)/(s1 + s3)) marked with a circle.
    `dim` (2 or 3, default 3) names the stress unit.

    Raises
    ------
    InvalidParameterError
        ``tables`` empty or not a mapping; a table lacking a column or with fewer
        than 2 rows (``table``); ``dim`` not 2 or 3.
    """
    unit = _unit(dim)
    tables = _tables(tables)
    fig = _figure(13.0, 4.0)
    ax_q, ax_v, ax_f = fig.subplots(1, 3)
    for n, (label, table) in enumerate(tables.items()):
        c = _columns(table, _TRIAXIAL, what="a triaxial figure")
        color = f"C{n % 10}"
        ea = 100.0 * c["eps_a"]
        q = (c["sigma_1"] - c["sigma_3"]) / 1e3
        k = int(np.argmax(_sin_mobilised(c["sigma_1"], c["sigma_3"])))
        ax_q.plot(ea, q, color=color, label=str(label))
        ax_q.plot(ea[k], q[k], "o", color=color, markerfacecolor="none")
        ax_v.plot(ea, 100.0 * c["eps_v"], color=color, label=str(label))
        ax_f.plot(ea, c["fabric_dev"], color=color, label=str(label))
    ax_q.set_ylabel(f"q = sigma_1 - sigma_3 ({unit})")
    ax_v.set_ylabel("eps_v (%, compression +)")
    ax_f.set_ylabel("fabric_dev (-)")
    for ax in (ax_q, ax_v, ax_f):
        ax.set_xlabel("eps_a (%)")
        ax.grid(alpha=0.3)
    ax_v.axhline(0.0, color="0.5", lw=0.8)
    ax_q.legend(title="o: peak", fontsize="small")
    return fig


def triaxial_figure(tables: Mapping[str, pl.DataFrame], path: str | Path, *, dim: int = 3) -> Path:
    """Writes `triaxial_plot(tables, dim=dim)` as a PNG at `path` (atomically) and
    returns the path."""
    return save(triaxial_plot(tables, dim=dim), path)


def compression_plot(tables: Mapping[str, pl.DataFrame], *, dim: int = 3) -> Figure:
    """The void ratio e against the stress on a log axis (kPa; kN/m in 2D): sigma_v
    (sigma_1) for an oedometer table (one with a ``k0`` column), p for an isotropic one
    (the branches as `granpack.element.lab.compression_report` splits them). Loading:
    filled circles and a solid line; unloading: open squares and a dashed line. One
    colour per label of `tables`.

    Raises
    ------
    InvalidParameterError
        ``tables`` empty or not a mapping; a table as `compression_report` refuses;
        ``dim`` not 2 or 3.
    """
    unit = _unit(dim)
    tables = _tables(tables)
    fig = _figure(6.5, 4.5)
    ax = fig.subplots()
    names = set()
    for n, (label, table) in enumerate(tables.items()):
        rep = compression_report(table)
        names.add("sigma_v" if rep["stress"] == "sigma_1" else "p")
        s = table[rep["stress"]].cast(pl.Float64).to_numpy() / 1e3
        e = table["e"].cast(pl.Float64).to_numpy()
        color = f"C{n % 10}"
        load, unload = rep["loading_rows"], rep["unloading_rows"]
        ax.plot(s[load], e[load], "o-", color=color, label=f"{label}, loading")
        if unload:
            ax.plot(
                s[unload],
                e[unload],
                "s--",
                color=color,
                markerfacecolor="none",
                label=f"{label}, unloading",
            )
    ax.set_xscale("log")
    ax.set_xlabel(f"{' / '.join(sorted(names))} ({unit}, log scale)")
    ax.set_ylabel("void ratio e (-)")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize="small")
    return fig


def compression_figure(
    tables: Mapping[str, pl.DataFrame], path: str | Path, *, dim: int = 3
) -> Path:
    """Writes `compression_plot(tables, dim=dim)` as a PNG at `path` (atomically) and
    returns the path."""
    return save(compression_plot(tables, dim=dim), path)
