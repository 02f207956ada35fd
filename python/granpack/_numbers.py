"""Text tables of numbers read in one pass by numpy's C reader, or None where that fails
(every caller then reads row by row and names the row at fault). Shared by the file
readers (`granpack.io`) and the analysis' ``x y z r`` reader."""

from __future__ import annotations

import numpy as np


def _number_table(
    lines: list[str], start: int, ncol: tuple[int, ...], commas: bool = True
) -> np.ndarray | None:
    """lines[start:] as a table of numbers, parsed in one pass by numpy's C reader: blank
    lines and ``#`` comments skipped, every row `ncol` numbers (one of the counts given,
    the same for all), commas as blanks where `commas`. None where that fails for any reason: the
    caller's line-by-line reader then reads the file again and names the line at fault,
    so that this path changes the speed, never the result or the message."""
    body = "\n".join(lines[start:])
    if commas and "," in body:
        body = body.replace(",", " ")
    # (without `commas`, a comma in a row is not a number to numpy's reader either: the
    # parse fails and the caller's reading names the line; commas in comments are skipped)
    a = _loadtxt(body, comments="#")
    if a is None or a.shape[0] == 0 or a.shape[1] not in ncol:
        return None
    return a


def _loadtxt(text: str, **options) -> np.ndarray | None:
    """numpy's C reader on `text` as an at-least-2D float64 table, or None where it fails
    or finds no data (the callers' row-by-row readings then name the fault)."""
    import io
    import warnings

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # "input contained no data"
            return np.loadtxt(io.StringIO(text), ndmin=2, dtype=np.float64, **options)
    except (ValueError, UserWarning):
        return None
