"""CSV and Parquet tables (polars): particles and contacts, with the container tag."""

from __future__ import annotations

import io
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .._files import atomic_write
from .._validate import (
    FileFormatError,
)
from ..analysis.container import Container, ContainerTag
from ..analysis.inputs import written_digits

if TYPE_CHECKING:
    import polars as pl

    from ..pack import Pack

from ._text import (
    _DIAMETER_NAMES,
    _ID_NAMES,
    _RADIUS_NAMES,
    _axes,
    _check_values,
    _choose_dim,
    _comment_tag,
    _integer_ids,
    _pick,
    _read_text,
    _sorted_by_id,
    _tag,
    _tag_fields,
    contact_counts,
)
from .particle_file import ParticleFile


def _read_table(path: Path, fmt: str, dim: int | None) -> ParticleFile:
    import polars as pl

    try:
        if fmt == "csv":
            # every column as text first: a bad value is then found and named by its line
            df = pl.read_csv(path, infer_schema_length=0, comment_prefix="#")
        else:
            df = pl.read_parquet(path)
    except FileNotFoundError:
        raise FileFormatError(f"cannot read {path}: no such file", path=path) from None
    except (OSError, pl.exceptions.PolarsError, ValueError) as exc:
        if fmt == "csv":
            _refuse_ragged_csv(path)
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise FileFormatError(f"cannot read {path} as {fmt}: {first[:200]}", path=path) from None

    names = list(df.columns)
    if fmt == "csv":
        # the file line of each row: the header is the first line that is neither blank
        # nor a comment; polars makes a row (all null) of each later blank line too, so
        # those rows are dropped along with their lines
        all_lines = _read_text(path).splitlines()
        data_lines = [
            k + 1 for k, ln in enumerate(all_lines) if ln.strip() and not ln.startswith("#")
        ]
        head_line = data_lines[0] if data_lines else 1
        row_line = [
            k + 1 for k in range(head_line, len(all_lines)) if not all_lines[k].startswith("#")
        ]
        blank = df.select(pl.all_horizontal(pl.all().is_null())).to_series().to_numpy()
        if blank.any():
            df = df.filter(pl.Series(~blank))
        if len(row_line) == len(blank):
            row_line = [line for line, b in zip(row_line, blank, strict=True) if not b]
        else:  # a layout this mapping does not follow: name rows by number instead
            row_line = []

        def where(k: int) -> str:
            return str(row_line[k]) if k < len(row_line) else f"row {k + 1}"

        label = f"{path}:{head_line}"
    else:

        def where(k: int) -> str:
            return f"row {k}"

        label = str(path)

    ix, iy, iz = _pick(names, ("x",)), _pick(names, ("y",)), _pick(names, ("z",))
    i_r = _pick(names, _RADIUS_NAMES)
    i_d = _pick(names, _DIAMETER_NAMES) if i_r is None else None
    missing = [w for w, c in (("x", ix), ("y", iy)) if c is None]
    if i_r is None and i_d is None:
        missing.append("r (or radius, diameter)")
    if missing:
        raise FileFormatError(
            f"{label}: missing column{'s' if len(missing) > 1 else ''} {', '.join(missing)}; "
            f"found {', '.join(names) or 'none'} (expected x, y, z (3D), r or radius or "
            "diameter, optional id)",
            path=path,
            reason="missing columns",
        )
    if len(df) == 0:
        raise FileFormatError(f"{label}: no rows", path=path)
    i_id = _pick(names, _ID_NAMES)

    def column(c: int) -> np.ndarray:
        name = names[c]
        s = df.get_column(name)
        if fmt == "csv" and s.dtype == pl.String:  # CSV: every column is read as text
            s = s.str.strip_chars()
        elif not s.dtype.is_numeric():
            # a Boolean, date or nested column would cast to numbers that mean nothing
            # (True as a radius of 1.0)
            raise FileFormatError(
                f"{label}: column {name!r} holds {s.dtype} values; x, y, z, the radius and "
                "the id must be numeric columns (integers or floats)",
                path=path,
                reason="non-numeric column",
            )
        try:
            f = s.cast(pl.Float64, strict=False)
        except pl.exceptions.PolarsError:
            raise FileFormatError(
                f"{label}: column {name!r} ({s.dtype}) is not numeric", path=path
            ) from None
        bad = f.is_null().to_numpy()
        if bad.any():
            k = int(np.argmax(bad))
            value = s[k]
            what = "a missing value" if value is None else f"{str(value)!r} is not a number"
            raise FileFormatError(f"{path}:{where(k)}: column {name!r}: {what}", path=path)
        return f.to_numpy().astype(np.float64)

    assert ix is not None and iy is not None  # else refused above as missing
    has_z = iz is not None
    x3 = np.zeros((len(df), 3))
    x3[:, 0], x3[:, 1] = column(ix), column(iy)
    if iz is not None:
        x3[:, 2] = column(iz)
    if i_r is not None:
        r = column(i_r)
    else:
        assert i_d is not None
        r = column(i_d) / 2.0
    ids = None
    if i_id is not None:
        ids = _table_ids(path, df.get_column(names[i_id]), column(i_id), where)
        order = _sorted_by_id(path, ids, where)
        ids, x3, r = ids[order], x3[order], r[order]
        _check_values(path, x3, r, lambda k: where(int(order[k])))
    else:
        _check_values(path, x3, r, where)
    d = _choose_dim(path, x3, has_z, dim)
    digits = None
    if fmt == "csv":
        tag = _comment_tag(path, _read_text(path).splitlines(), d)
        # the precision of the text as written, for the contact check
        step = len(df) // 50_000 + 1
        words: list[str] = []
        for c in (ix, iy, iz, i_r if i_r is not None else i_d):
            if c is not None:
                words += [w for w in df.get_column(names[c]).gather_every(step).to_list() if w]
        digits = written_digits(words)
    else:
        tag = _parquet_tag(path, d)
    return ParticleFile(
        path=path,
        format=fmt,
        positions=x3[:, :d],
        radii=r,
        ids=ids,
        digits=digits,
        **_tag_fields(tag, d),
    )


def _table_ids(path: Path, s, raw: np.ndarray, where) -> np.ndarray:
    """The id column `s` as int64, exactly: an integer column as it is, a CSV column of
    text from its digits (ids of 2**53 and above, which `raw`, its float64 reading,
    cannot hold), a float column through `_integer_ids`."""
    import polars as pl

    if s.dtype.is_integer():
        if s.dtype == pl.UInt64 and s.max() is not None and s.max() > np.iinfo(np.int64).max:
            k = int(np.argmax(s.to_numpy() > np.iinfo(np.int64).max))
            raise FileFormatError(
                f"{path}:{where(k)}: id {s[k]} lies beyond a 64-bit signed integer", path=path
            )
        return s.cast(pl.Int64).to_numpy().astype(np.int64)
    text = s.str.strip_chars() if s.dtype == pl.String else None  # CSV
    return _integer_ids(path, raw, where, None if text is None else (lambda: text.to_list()))


def _refuse_ragged_csv(path: Path) -> None:
    """Names the first row of a CSV file whose field count differs from its header's
    (polars' own message names no line)."""
    import csv

    try:
        lines = _read_text(path).splitlines()
    except FileFormatError:
        return
    header: int | None = None
    for k, row in enumerate(csv.reader(lines)):
        line = lines[k] if k < len(lines) else ""
        if not line.strip() or line.startswith("#"):
            continue
        if header is None:
            header = len(row)
            head_line = k + 1
            continue
        if len(row) != header:
            raise FileFormatError(
                f"{path}:{k + 1}: expected {header} fields (as the header at line {head_line}"
                f" names), found {len(row)}",
                path=path,
                reason="wrong field count",
            )


def _parquet_tag(path: Path, d: int) -> ContainerTag | None:
    """The container tag in a Parquet file's key-value metadata (key ``granpack``)."""
    import polars as pl

    try:
        meta = pl.read_parquet_metadata(path)
    except (OSError, pl.exceptions.PolarsError, ValueError):
        return None
    text = meta.get("granpack")
    return None if text is None else Container.read_tag(text, path, 0, d)


def particle_table(pack: Pack) -> pl.DataFrame:
    """One row per particle: ``id``, ``x``, ``y`` (, ``z``) (m), ``radius`` (m),
    ``layer``, ``vx``, ``vy`` (, ``vz``) (m/s), spin ``w`` (2D, rad/s) or ``wx``,
    ``wy``, ``wz`` (3D), ``n_contacts`` (particle-particle plus wall)."""
    import polars as pl

    dim = pack.dim
    ax = _axes(dim)
    cols: dict[str, np.ndarray] = {"id": np.arange(len(pack), dtype=np.int64)}
    pos = np.asarray(pack.positions)
    vel = np.asarray(pack.velocities)
    for k, a in enumerate(ax):
        cols[a] = pos[:, k]
    cols["radius"] = np.asarray(pack.radii)
    cols["layer"] = np.asarray(pack.layer, dtype=np.int64)
    for k, a in enumerate(ax):
        cols[f"v{a}"] = vel[:, k]
    spins = np.asarray(pack.spins)
    if dim == 2:
        cols["w"] = spins
    else:
        for k, a in enumerate("xyz"):
            cols[f"w{a}"] = spins[:, k]
    cols["n_contacts"] = contact_counts(pack)
    return pl.DataFrame(cols)


def contact_table(pack: Pack) -> pl.DataFrame:
    """One row per contact: ``i``, ``j`` (j < 0 a wall: -1 floor, -2/-3 x walls, -4/-5 y
    walls), ``nx``.. (unit normal i -> j), ``overlap`` (m), ``fn`` (N), ``ftx``..
    (tangential force on j, N), ``bx``.. (branch vector, m)."""
    import polars as pl

    c = pack.contacts
    ax = _axes(pack.dim)
    cols: dict[str, np.ndarray] = {
        "i": np.asarray(c.i, dtype=np.int64),
        "j": np.asarray(c.j, dtype=np.int64),
    }
    normal = np.asarray(c.normal).reshape(len(c), pack.dim)
    ft = np.asarray(c.force_tangential).reshape(len(c), pack.dim)
    br = np.asarray(c.branch).reshape(len(c), pack.dim)
    for k, a in enumerate(ax):
        cols[f"n{a}"] = normal[:, k]
    cols["overlap"] = np.asarray(c.overlap, dtype=np.float64)
    cols["fn"] = np.asarray(c.force_normal, dtype=np.float64)
    for k, a in enumerate(ax):
        cols[f"ft{a}"] = ft[:, k]
    for k, a in enumerate(ax):
        cols[f"b{a}"] = br[:, k]
    return pl.DataFrame(cols)


def _table_paths(path: Path, ext: str) -> tuple[Path, Path]:
    stem = path.name
    for suffix in (ext, ".vtu", ".vtk", ".data", ".npz"):
        if stem.endswith(suffix):
            stem = stem[: -len(suffix)]
            break
    return path.with_name(f"{stem}.particles{ext}"), path.with_name(f"{stem}.contacts{ext}")


def write_csv(pack: Pack, path: str | Path) -> list[Path]:
    """Writes ``<stem>.particles.csv`` and ``<stem>.contacts.csv`` (full float64
    precision). Returns both paths."""
    p_path, c_path = _table_paths(Path(path), ".csv")
    # a comment line first: read_particles takes the container from it
    head = f"# granpack: dim={pack.dim} {_tag(pack)}\n"
    return [
        atomic_write(p_path, (head + particle_table(pack).write_csv()).encode()),
        atomic_write(c_path, contact_table(pack).write_csv().encode()),
    ]


def write_parquet(pack: Pack, path: str | Path) -> list[Path]:
    """Writes ``<stem>.particles.parquet`` and ``<stem>.contacts.parquet``. Returns
    both paths."""
    p_path, c_path = _table_paths(Path(path), ".parquet")
    out = []
    for target, df in ((p_path, particle_table(pack)), (c_path, contact_table(pack))):
        buf = io.BytesIO()
        # the container tag as key-value metadata: read_particles analyses the table in it
        df.write_parquet(buf, metadata={"granpack": f"dim={pack.dim} {_tag(pack)}"})
        out.append(atomic_write(target, buf.getvalue()))
    return out


def read_csv(path: Path, dim: int | None = None) -> ParticleFile:
    """A CSV table of particles (columns in `read_particles`' notes), with the container
    tag of granpack's export where the file has it."""
    return _read_table(Path(path), "csv", dim)


def read_parquet(path: Path, dim: int | None = None) -> ParticleFile:
    """A Parquet table of particles, with the container tag in its metadata where
    granpack's export wrote one."""
    return _read_table(Path(path), "parquet", dim)
