"""Packs written as text by other DEM codes (``x y z r``)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .._numbers import _number_table
from .._validate import FileFormatError, GranpackError, InvalidParameterError, is_number

__all__ = ["read_xyzr"]


def read_xyzr(path, dim: int | None = None) -> tuple[np.ndarray, np.ndarray, int]:
    """Reads a pack written as text, one particle a line: ``x y z r`` (or ``x y r`` in 2D).

    Blank lines and everything after ``#`` are ignored; commas count as spaces. A 2D pack
    in four columns has one all-zero coordinate column: z (then y is vertical, as LAMMPS
    writes 2D) or y (then z is vertical); that column is dropped.

    Parameters
    ----------
    path : str or Path
    dim : {None, 2, 3}
        None (default): 2 if a three-column file or the z (else y) column is all zero,
        otherwise 3.

    Returns
    -------
    positions : (N, D) float64, vertical axis last (m)
    radii : (N,) float64 (m)
    dim : int

    Raises
    ------
    GranpackError
        Unreadable file, a line that is not 3 or 4 numbers (named by its line number),
        non-finite values, radii <= 0, or a 2D request with no all-zero column.
    """
    path = Path(path)
    if dim is not None and dim not in (2, 3):
        raise InvalidParameterError(f"invalid dim = {dim!r}: must be None, 2 or 3", parameter="dim")
    try:
        text = path.read_text(encoding="utf-8-sig")  # Excel writes a byte-order mark
    except FileNotFoundError:
        raise GranpackError(f"cannot read {path}: no such file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise GranpackError(f"cannot read {path}: {exc}") from None
    all_lines = text.splitlines()
    a = _number_table(all_lines, 0, (3, 4))
    if a is not None and np.all(np.isfinite(a)) and np.all(a[:, -1] > 0.0):
        return _columns(path, a, dim)
    # the line-by-line reading, which names the line at fault
    rows: list[list[float]] = []
    lines: list[int] = []
    ncol = None
    for lineno, line in enumerate(all_lines, 1):
        body = line.split("#", 1)[0].replace(",", " ").split()
        if not body:
            continue
        if len(body) not in (3, 4) or (ncol is not None and len(body) != ncol):
            want = "4 numbers (x y z r) or 3 (x y r)" if ncol is None else f"{ncol} numbers"
            raise FileFormatError(
                f"{path}:{lineno}: expected {want}, found {len(body)} fields", path=path
            )
        ncol = len(body)
        try:
            vals = [float(v) for v in body]
        except ValueError:
            bad = next(v for v in body if not is_number(v))
            raise FileFormatError(f"{path}:{lineno}: {bad!r} is not a number", path=path) from None
        if not all(math.isfinite(v) for v in vals):
            raise FileFormatError(f"{path}:{lineno}: non-finite value", path=path)
        if vals[-1] <= 0.0:
            raise FileFormatError(f"{path}:{lineno}: radius {vals[-1]} must be > 0 (m)", path=path)
        rows.append(vals)
        lines.append(lineno)
    if not rows:
        raise FileFormatError(f"{path}: no particles (every line is blank or a comment)", path=path)
    return _columns(path, np.array(rows), dim)


def _columns(path: Path, a: np.ndarray, dim: int | None):
    """(positions, radii, dim) of the rows `a` (x y r or x y z r)."""
    ncol = a.shape[1]
    radii = np.ascontiguousarray(a[:, -1])
    if ncol == 3:
        if dim == 3:
            raise FileFormatError(
                f"{path}: dim = 3 needs four columns x y z r, found three", path=path
            )
        return np.ascontiguousarray(a[:, :2]), radii, 2
    z_zero = bool(np.all(a[:, 2] == 0.0))
    y_zero = bool(np.all(a[:, 1] == 0.0))
    if dim is None:
        dim = 2 if (z_zero or y_zero) else 3
    if dim == 3:
        return np.ascontiguousarray(a[:, :3]), radii, 3
    if z_zero:
        return np.ascontiguousarray(a[:, :2]), radii, 2
    if y_zero:
        return np.ascontiguousarray(a[:, [0, 2]]), radii, 2
    raise FileFormatError(f"{path}: dim = 2 needs an all-zero y or z column; neither is", path=path)
