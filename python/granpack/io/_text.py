"""What the readers and writers of every format share: reading text, checking values,
choosing the dimension, ids, and the container tag."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .._numbers import _loadtxt
from .._validate import (
    FileFormatError,
    InvalidParameterError,
    short_repr,
)
from ..container_tag import ContainerTag, container_tag, parse_container_tag
from ..dem_input import container_of

if TYPE_CHECKING:
    from ..pack import Pack

_RADIUS_NAMES = ("radius", "r")


_DIAMETER_NAMES = ("diameter", "d")


_ID_NAMES = ("id",)


# How many leading lines the content sniffing looks at for a data file's "N atoms".
_SNIFF_LINES = 40


def _head(path: Path, n: int = 65536) -> bytes:
    try:
        with open(path, "rb") as f:
            return f.read(n)
    except FileNotFoundError:
        raise FileFormatError(
            f"cannot read {path}: no such file", path=path, reason="no such file"
        ) from None
    except OSError as exc:
        raise FileFormatError(f"cannot read {path}: {exc.strerror or exc}", path=path) from None


def _frame_index(path: Path, snapshot: int, n: int, holder: str, unit: str) -> int:
    """The 0-based index of `snapshot` (Python's: -1 the last) among the `n` snapshots or
    frames (`unit`) that the file (`holder`: "dump", "file") holds; out of range, a
    FileFormatError that gives the range."""
    if not -n <= snapshot < n:
        raise FileFormatError(
            f"{path}: snapshot = {snapshot} is out of range: the {holder} holds {n} "
            f"{unit}{'s' if n > 1 else ''} (0 to {n - 1}, or -{n} to -1)",
            path=path,
            reason="snapshot out of range",
        )
    return int(snapshot) % n


def _single_snapshot(path: Path, snapshot: int) -> None:
    if snapshot not in (0, -1):
        raise FileFormatError(
            f"{path}: snapshot = {snapshot} is out of range: the file holds one snapshot (0 or -1)",
            path=path,
            reason="snapshot out of range",
        )


def _read_text(path: Path) -> str:
    try:
        # utf-8-sig: a byte-order mark (Excel and Windows editors write one) is not text
        return path.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise FileFormatError(f"cannot read {path}: no such file", path=path) from None
    except UnicodeDecodeError as exc:
        raise FileFormatError(
            f"cannot read {path}: not a text file (byte {exc.start} is not UTF-8)", path=path
        ) from None
    except OSError as exc:
        raise FileFormatError(f"cannot read {path}: {exc.strerror or exc}", path=path) from None


def _check_values(path: Path, x: np.ndarray, r: np.ndarray, where) -> None:
    """Refuses non-finite coordinates and radii <= 0; `where(k)` names row k's line."""
    bad = ~np.all(np.isfinite(x), axis=1)
    if np.any(bad):
        k = int(np.argmax(bad))
        raise FileFormatError(f"{path}:{where(k)}: non-finite coordinate", path=path)
    bad = ~(np.isfinite(r) & (r > 0.0))
    if np.any(bad):
        k = int(np.argmax(bad))
        raise FileFormatError(
            f"{path}:{where(k)}: radius {r[k]} must be finite and > 0 (m)", path=path
        )


def _choose_dim(
    path: Path, x3: np.ndarray, has_z: bool, dim: int | None, z_periodic: bool = False
) -> int:
    """2 or 3 for coordinates x3 (N, 3; z column meaningful only if has_z)."""
    if not has_z:
        if dim == 3:
            raise FileFormatError(f"{path}: dim = 3 needs a z column; the file has none", path=path)
        return 2
    z_const = bool(np.all(x3[:, 2] == x3[0, 2]))
    if dim is None:
        # LAMMPS' 2D has z = 0 and a periodic z. A constant z alone is not enough: one
        # layer of equal spheres resting on a floor is 3D with the same z for all
        return 2 if z_const and (x3[0, 2] == 0.0 or z_periodic) else 3
    if dim == 2 and not z_const:
        raise FileFormatError(
            f"{path}: dim = 2 needs the same z for every particle; z runs from "
            f"{float(np.min(x3[:, 2]))} to {float(np.max(x3[:, 2]))}",
            path=path,
        )
    return dim


def _integer_ids(path: Path, raw: np.ndarray, where) -> np.ndarray:
    """An id column read as numbers, as int64; refuses a value that is not a finite
    integer, or one too large for a float to hold exactly, naming its line `where(k)`."""
    finite = np.isfinite(raw)
    whole = finite & (raw == np.round(np.where(finite, raw, 0.0)))
    if not np.all(whole):
        k = int(np.argmax(~whole))
        raise FileFormatError(f"{path}:{where(k)}: id {raw[k]} is not an integer", path=path)
    big = np.abs(raw) >= 2.0**53
    if np.any(big):
        k = int(np.argmax(big))
        raise FileFormatError(
            f"{path}:{where(k)}: id {raw[k]:.17g} is too large to read exactly (ids must lie "
            "below 2**53)",
            path=path,
        )
    return raw.astype(np.int64)


def _sorted_by_id(path: Path, ids: np.ndarray, where) -> np.ndarray:
    """The order that sorts by id; refuses a repeated id, naming both lines."""
    order = np.argsort(ids, kind="stable")
    s = ids[order]
    dup = np.flatnonzero(s[1:] == s[:-1])
    if dup.size:
        a, b = sorted((int(order[dup[0]]), int(order[dup[0] + 1])))
        raise FileFormatError(
            f"{path}:{where(b)}: id {int(ids[b])} repeats the id of line {where(a)}; ids "
            "must be unique",
            path=path,
        )
    return order


def _pick(names: list[str], wanted: tuple[str, ...]) -> int | None:
    low = [n.strip().lower() for n in names]
    for w in wanted:
        if w in low:
            return low.index(w)
    return None


def _tag_fields(tag: ContainerTag | None, d: int) -> dict:
    """ParticleFile keywords for a container tag (nothing for None)."""
    if tag is None:
        return {}
    out: dict = {
        "container": tag.kind,
        "cylinder_radius": tag.cylinder_radius,
        "periodic": (tag.kind == "periodic",) * (d - 1),
    }
    if tag.lo is not None and tag.hi is not None:
        out["box"] = (tag.lo, tag.hi)
    return out


def _comment_tag(path: Path, lines: list[str], d: int) -> ContainerTag | None:
    """The container tag of a ``# granpack: ...`` comment line among the leading lines."""
    for k, ln in enumerate(lines[:_SNIFF_LINES]):
        body = ln.lstrip("\ufeff").strip()
        if body.startswith("#") and "granpack" in body:
            tag = parse_container_tag(body, path, k + 1, d)
            if tag is not None:
                return tag
    return None


def contact_counts(pack: Pack) -> np.ndarray:
    """(N,) int64: contacts each particle takes part in (particle-particle and wall)."""
    c = pack.contacts
    n = len(pack)
    counts = np.bincount(np.asarray(c.i, dtype=np.int64), minlength=n)
    pp = np.asarray(c.j) >= 0
    counts += np.bincount(np.asarray(c.j, dtype=np.int64)[pp], minlength=n)
    return counts.astype(np.int64)


def _pad3(a: np.ndarray) -> np.ndarray:
    """(N, D) -> (N, 3) with zeros in the missing components (2D lies at z = 0)."""
    a = np.asarray(a, dtype=np.float64)
    if a.ndim == 1:  # 2D spin: rotation about z
        out = np.zeros((a.shape[0], 3))
        out[:, 2] = a
        return out
    out = np.zeros((a.shape[0], 3))
    out[:, : a.shape[1]] = a
    return out


def _axes(dim: int) -> list[str]:
    return ["x", "y", "z"][:dim]


def _tag(pack: Pack) -> str:
    """The container tag of `pack`, with its box corners (lo = 0, hi = (base, H_top))."""
    lo, hi = pack.box
    return container_tag(*container_of(pack), lo, hi)


def _read_args(snapshot, dim) -> int:
    """Checks a reader's `snapshot` (an integer) and `dim` (None, 2 or 3); returns the
    snapshot as an int."""
    if isinstance(snapshot, bool) or not isinstance(snapshot, int | np.integer):
        raise InvalidParameterError(
            f"invalid snapshot = {short_repr(snapshot)}: must be an integer (0 the first, "
            "-1 the last)",
            parameter="snapshot",
            value=snapshot,
        )
    if dim is not None and (isinstance(dim, bool) or dim not in (2, 3)):
        raise InvalidParameterError(
            f"invalid dim = {short_repr(dim)}: must be None, 2 or 3", parameter="dim", value=dim
        )
    return int(snapshot)


def _rows_text(*columns, prefix: str = "") -> str:
    """Lines of space-separated columns (each (N,) of ints or float64), floats at full
    precision as `_format_lines` writes them; `prefix` starts every line. Plain columns go
    through polars' CSV writer, twice as fast as a template (the same text: checked on
    1e6 rows)."""
    import polars as pl

    cols: dict[str, object] = {}
    if prefix:
        n = len(columns[0]) if columns else 0
        cols["_p"] = pl.repeat(prefix, n, eager=True, dtype=pl.String)
    for k, c in enumerate(columns):
        a = np.asarray(c)
        cols[f"c{k}"] = a if a.dtype.kind in "iu" else a.astype(np.float64, copy=False)
    return pl.DataFrame(cols).write_csv(
        separator=" ", include_header=False, quote_style="never", line_terminator="\n"
    )


def _column_table(block: list[str], ncol: int, usecols: list[int]) -> np.ndarray | None:
    """The columns `usecols` of the rows `block` (each `ncol` fields, no comments or blank
    lines) as float64, parsed by numpy's C reader in one pass; None where any row does
    not hold `ncol` fields or a used field is not a number, so that the caller's
    row-by-row reading names the row at fault."""
    if not block or len(block[0].split()) != ncol:
        return None
    text = "\n".join(block)
    # every column a number (a dump's, say): numpy's reader itself refuses a row whose
    # field count differs from the first's
    a = _loadtxt(text, comments=None)
    if a is not None and a.shape == (len(block), ncol):
        return a[:, usecols]
    # a column of text (an XYZ species): the field count checked on the whole block
    if len(text.split()) != len(block) * ncol:
        return None
    a = _loadtxt(text, comments=None, usecols=usecols)
    return a if a is not None and a.shape == (len(block), len(usecols)) else None


def lammps_positions(pack: Pack) -> np.ndarray:
    """(N, 3) centres as the data file writes them: 2D at z = 0, and a periodic pack's
    wrapped into [0, L) along each periodic axis."""
    x = _pad3(pack.positions)
    kind, _ = container_of(pack)
    if kind == "periodic":
        for ax, length in enumerate(pack.scene.base):
            x[:, ax] = np.mod(x[:, ax], length)
            # mod can round a tiny negative up to L itself
            x[x[:, ax] >= length, ax] = 0.0
    return x


def _state3(pack: Pack) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(positions, radii, velocities, spins) as the DEM codes' files write them: (N, 3)
    each (2D at z = 0, the spin about z), a periodic pack's centres wrapped into its cell
    (`lammps_positions`)."""
    r = np.asarray(pack.radii, dtype=np.float64)
    return lammps_positions(pack), r, _pad3(pack.velocities), _pad3(pack.spins)


def _format_lines(template: str, *columns) -> str:
    """One line per row: `template` with its ``{}`` filled by the columns (each (N,) of
    ints, float64 or text), floats at full precision as ``repr`` writes them (the shortest
    decimal that reads back to the same bits), formatted by polars."""
    import polars as pl

    if not columns or len(columns[0]) == 0:
        return ""
    df = pl.DataFrame({f"c{k}": np.asarray(c) for k, c in enumerate(columns)})
    lines = df.select(pl.format(template, *(pl.col(f"c{k}") for k in range(len(columns)))))
    return lines.write_csv(include_header=False, quote_style="never", line_terminator="\n")
