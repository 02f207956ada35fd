"""Paired comparisons of two ensembles made with the same seeds and streams: the rows of
the tables that `compare.md` files give, shared by the studies that pit a variant against
a reference pack by pack."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import polars as pl

HEADER = (
    "| quantity | {ref} mean | {var} mean | mean difference | its standard error "
    "| difference / sd of {ref} |"
)


def table_head(ref: str, var: str) -> list[str]:
    """The header and rule of the paired table, the reference named `ref`, the variant `var`."""
    return [HEADER.format(ref=ref, var=var), "|---|---|---|---|---|---|"]


def paired_row(q: str, a: np.ndarray, b: np.ndarray) -> str | None:
    """Row of quantity `q`: the means of the reference `a` and the variant `b` (pack k of
    each made with the same seed and stream), the mean paired difference, its standard
    error, and the difference in sd of the reference. Pairs with a NaN on either side are
    left out; None with fewer than two pairs."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    ok = ~(np.isnan(a) | np.isnan(b))
    if ok.sum() < 2:
        return None
    d = b[ok] - a[ok]
    sd = a[ok].std(ddof=1)
    se = d.std(ddof=1) / np.sqrt(ok.sum())
    return (
        f"| {q} | {a[ok].mean():.5g} | {b[ok].mean():.5g} | {d.mean():+.4g} "
        f"| {se:.2g} | {d.mean() / sd if sd > 0 else float('nan'):+.2f} |"
    )


def layer_medians(path: Path, label: str) -> str:
    """The median seconds of each layer over the packs of a `*_layers.csv` (columns
    layer, seconds), as one line."""
    lay = pl.read_csv(path)
    med = lay.group_by("layer").agg(pl.col("seconds").median()).sort("layer")
    return f"Median seconds a layer, {label}: " + ", ".join(f"{s:.2f}" for s in med["seconds"])
