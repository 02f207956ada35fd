"""What the readers and writers of every format share: reading text, checking values,
choosing the dimension, ids, and the container tag."""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .._numbers import _loadtxt
from .._validate import (
    FileFormatError,
    InvalidParameterError,
    is_number,
    short_repr,
)
from ..analysis.container import Container, ContainerTag

if TYPE_CHECKING:
    from ..pack import Pack

_RADIUS_NAMES = ("radius", "r")


_DIAMETER_NAMES = ("diameter", "d")


_ID_NAMES = ("id",)


# How many leading lines the content sniffing looks at for a data file's "N atoms".
_SNIFF_LINES = 40


#: Magic bytes of the compressions a file may come in: gzip is read (LAMMPS writes
#: ``dump ... file.gz`` through gzip), the others are refused by name.
_GZIP_MAGIC = b"\x1f\x8b"
_OTHER_COMPRESSIONS = (
    (b"\x28\xb5\x2f\xfd", "zstd"),
    (b"BZh", "bzip2"),
    (b"\xfd7zXZ\x00", "xz"),
)


def compression(head: bytes) -> str | None:
    """The compression the first bytes of a file show ("gzip", "zstd", "bzip2", "xz"),
    or None."""
    if head.startswith(_GZIP_MAGIC):
        return "gzip"
    return next((name for magic, name in _OTHER_COMPRESSIONS if head.startswith(magic)), None)


def _gunzip(path: Path, raw: bytes, limit: int | None = None) -> tuple[bytes, bool]:
    """The bytes a gzip file holds (every member, as ``cat a.gz b.gz`` joins them), and
    whether the stream stops before its end (a file still being written): the bytes up
    to there are kept. `limit` stops after that many bytes (to sniff a head)."""
    import zlib

    out: list[bytes] = []
    size = 0
    rest = raw
    while rest:
        d = zlib.decompressobj(16 + zlib.MAX_WBITS)
        try:
            chunk = d.decompress(rest, limit - size if limit is not None else 0)
        except zlib.error as exc:
            raise FileFormatError(
                f"cannot read {path}: a damaged gzip stream ({exc})", path=path
            ) from None
        out.append(chunk)
        size += len(chunk)
        if limit is not None and size >= limit:
            return b"".join(out), False
        if not d.eof:
            return b"".join(out), True
        rest = d.unused_data
        if not rest.strip(b"\0"):  # NUL padding after the last member, as gzip allows
            break
    return b"".join(out), False


def _head(path: Path, n: int = 65536) -> bytes:
    """The first `n` bytes of the file; of what it holds where it is gzip-compressed."""
    try:
        with open(path, "rb") as f:
            head = f.read(n)
            if head.startswith(_GZIP_MAGIC):
                # a compressed head can hold far more than n bytes of text
                head = _gunzip(path, head + f.read(), limit=n)[0]
            return head
    except FileNotFoundError:
        raise FileFormatError(
            f"cannot read {path}: no such file", path=path, reason="no such file"
        ) from None
    except OSError as exc:
        raise FileFormatError(f"cannot read {path}: {exc.strerror or exc}", path=path) from None


def as_path(path, parameter: str = "path") -> Path:
    """`path` (str or os.PathLike) as a Path; anything else (None, a number, an open file)
    refused by name."""
    import os

    if isinstance(path, str | os.PathLike) and not isinstance(path, bytes):
        p = Path(path)
        if str(p) not in ("", "."):
            return p
    raise InvalidParameterError(
        f"invalid {parameter} = {short_repr(path)}: must be the path of a file (str or "
        "pathlib.Path)",
        parameter=parameter,
        value=path,
    )


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


def _read_text_cut(path: Path) -> tuple[str, bool]:
    """The text of a file (gzip-compressed or not), and whether a gzip stream stops
    before its end (a file still being written; the text up to there is returned)."""
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise FileFormatError(f"cannot read {path}: no such file", path=path) from None
    except OSError as exc:
        raise FileFormatError(f"cannot read {path}: {exc.strerror or exc}", path=path) from None
    cut = False
    kind = compression(raw[:8])
    if kind == "gzip":
        raw, cut = _gunzip(path, raw)
    elif kind is not None:
        raise FileFormatError(
            f"cannot read {path}: a {kind}-compressed file; granpack reads plain text and "
            f"gzip (decompress it first)",
            path=path,
            reason="compressed",
        )
    try:
        # utf-8-sig: a byte-order mark (Excel and Windows editors write one) is not text
        return raw.decode("utf-8-sig"), cut
    except UnicodeDecodeError as exc:
        raise FileFormatError(
            f"cannot read {path}: not a text file (byte {exc.start} is not UTF-8)", path=path
        ) from None


def _read_text(path: Path) -> str:
    """The text of a file, gzip-compressed or not; a gzip stream that stops before its
    end is refused (see `_read_text_cut` for the readers that take what is there)."""
    text, cut = _read_text_cut(path)
    if cut:
        raise FileFormatError(
            f"cannot read {path}: the gzip stream stops before its end-of-stream marker (a "
            "truncated file, or one still being written)",
            path=path,
            reason="truncated",
        )
    return text


def _text_digits(rows: list[str], cols: list[int], comment: str | None = None) -> int:
    """The most significant digits the fields `cols` of the lines `rows` are written
    with (`granpack.analysis.inputs.written_digits`), from an even stride of at most
    50 000 lines: the precision of the file's format, for the contact check."""
    from ..analysis.inputs import written_digits

    if len(rows) > 50_000:
        rows = rows[:: len(rows) // 50_000 + 1]
    words: list[str] = []
    for ln in rows:
        t = (ln.split(comment, 1)[0] if comment else ln).replace(",", " ").split()
        words.extend(t[c] for c in cols if c < len(t))
    return written_digits(words)


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


def _integer_ids(path: Path, raw: np.ndarray, where, tokens=None) -> np.ndarray:
    """An id column read as numbers, as int64; refuses a value that is not a finite
    integer, naming its line `where(k)`. Ids of 2**53 and above (LAMMPS' 64-bit tags),
    which a float cannot hold exactly, are read again from their text, `tokens()` (the
    column's fields as written, row by row), so that no two merge; without the text, or
    beyond int64, they are refused."""
    finite = np.isfinite(raw)
    whole = finite & (raw == np.round(np.where(finite, raw, 0.0)))
    if not np.all(whole):
        k = int(np.argmax(~whole))
        raise FileFormatError(f"{path}:{where(k)}: id {raw[k]} is not an integer", path=path)
    big = np.abs(raw) >= 2.0**53
    if not np.any(big):
        return raw.astype(np.int64)
    if tokens is not None:
        exact = _exact_integers(tokens())
        if exact is not None:
            return exact
    k = int(np.argmax(big))
    raise FileFormatError(
        f"{path}:{where(k)}: id {raw[k]:.17g} is too large to read exactly (ids of 2**53 "
        "and above must be written as integers, and lie within a 64-bit integer)",
        path=path,
    )


def _exact_integers(words) -> np.ndarray | None:
    """Integers written as text (``123``, ``-4``) as int64, exactly; None where one is
    written otherwise (``1e20``, ``3.0``) or lies beyond int64."""
    out = np.empty(len(words), dtype=np.int64)
    lo, hi = np.iinfo(np.int64).min, np.iinfo(np.int64).max
    for k, w in enumerate(words):
        w = w.strip()
        if not w.lstrip("+-").isdigit():
            return None
        v = int(w)
        if not lo <= v <= hi:
            return None
        out[k] = v
    return out


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
        "lid": tag.lid,
    }
    if tag.lo is not None and tag.hi is not None:
        out["box"] = (tag.lo, tag.hi)
    return out


def _comment_tag(path: Path, lines: list[str], d: int) -> ContainerTag | None:
    """The container tag of a ``# granpack: ...`` comment line among the leading lines."""
    for k, ln in enumerate(lines[:_SNIFF_LINES]):
        body = ln.lstrip("\ufeff").strip()
        if body.startswith("#") and "granpack" in body:
            tag = Container.read_tag(body, path, k + 1, d)
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
    """The container tag of `pack`, with its box corners (lo = 0, hi = (base, H_top)) and
    the lid of a consolidated pack."""
    lo, hi = pack.box
    return Container.of_pack(pack).tag_words()


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
    kind = Container.of_pack(pack).kind
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


class DumpBlock:
    """One snapshot of a LAMMPS or LIGGGHTS dump (of atoms, or ``dump local`` entries):
    where its items stand (0-based lines) and what its header says."""

    __slots__ = (
        "start",
        "timestep",
        "n",
        "n_line",
        "bounds",
        "flags",
        "box_line",
        "names",
        "first",
    )

    def __init__(self, start: int) -> None:
        self.start = start
        self.timestep: int | None = None
        self.n: int | None = None
        self.n_line = 0  # 0-based line after the count's value
        self.bounds: list[tuple[float, float]] | None = None
        self.flags: list[str] | None = None
        self.box_line = 0
        self.names: list[str] | None = None  # the columns of ITEM: ATOMS or ITEM: ENTRIES
        self.first = 0  # 0-based line of the first row


def scan_dump(path: Path, lines: list[str], local: bool = False) -> list[DumpBlock]:
    """Walks the ITEM blocks of every snapshot of a dump, checking their structure (and
    skipping the rows), so that a truncated or inconsistent file is refused whichever
    snapshot is asked for: a dump of atoms (``dump custom``: their ITEM: ATOMS rows and
    box), or with `local` a ``dump local`` file (its ITEM: ENTRIES rows: pairs)."""
    rows_item = "ENTRIES" if local else "ATOMS"
    count_item = f"NUMBER OF {rows_item}"
    things = "entries" if local else "atoms"
    rows_word = "entries" if local else "atom rows"
    n_lines = len(lines)
    blocks: list[DumpBlock] = []
    cur: DumpBlock | None = None
    i = 0

    def fail(k: int, what: str) -> FileFormatError:
        found = repr(lines[k].strip()[:60]) if k < n_lines else "the end of the file"
        return FileFormatError(f"{path}:{k + 1}: expected {what}, found {found}", path=path)

    def integer(k: int, what: str) -> int:
        words = lines[k].split() if k < n_lines else []
        try:
            if len(words) != 1:
                raise ValueError
            return int(words[0])
        except ValueError:
            raise fail(k, what) from None

    while i < n_lines:
        line = lines[i].strip()
        if not line:
            # LAMMPS writes no blank lines; tolerate them between snapshots only
            i += 1
            continue
        if not line.startswith("ITEM:"):
            raise fail(i, "an 'ITEM:' line")
        item = line[5:].strip()
        if cur is None or cur.names is not None:
            if item not in ("TIMESTEP", "UNITS", "TIME"):
                raise fail(i, "'ITEM: TIMESTEP' (the start of a snapshot)")
            cur = DumpBlock(i)
            blocks.append(cur)
        if item == "TIMESTEP":
            if cur.timestep is not None:
                raise fail(
                    i, f"'ITEM: {rows_item}' of the snapshot that starts at line {cur.start + 1}"
                )
            cur.timestep = integer(i + 1, "the timestep (an integer)")
            i += 2
        elif item in ("UNITS", "TIME"):  # dump_modify units/time yes
            if i + 1 >= n_lines:
                raise fail(i + 1, f"the {item.lower()} value")
            i += 2
        elif item == count_item:
            what = f"the number of {things} (an integer >= 0)"
            n = integer(i + 1, what)
            if n < 0:
                raise fail(i + 1, what)
            cur.n, cur.n_line = n, i + 2
            i += 2
        elif item.startswith("BOX BOUNDS"):
            if not local:  # the contacts need no box
                _box_bounds(path, lines, i, cur, fail)
            i += 4
        elif item.startswith(rows_item) and item.split()[0] == rows_item:
            names = item.split()[1:]
            if cur.n is None:
                raise FileFormatError(
                    f"{path}:{i + 1}: 'ITEM: {rows_item}' before 'ITEM: {count_item}' in the "
                    f"snapshot that starts at line {cur.start + 1}",
                    path=path,
                )
            if not names and not local:
                raise fail(i, "'ITEM: ATOMS' followed by the column names (dump custom)")
            cur.names, cur.first = names, i + 1
            first, end = i + 1, i + 1 + cur.n
            # a snapshot shorter than its header: the next ITEM line falls inside
            if end > n_lines or any(ln.startswith("ITEM:") for ln in lines[first:end]):
                k = next(
                    (j for j in range(first, min(end, n_lines)) if lines[j].startswith("ITEM:")),
                    n_lines,
                )
                raise FileFormatError(
                    f"{path}:{k + 1}: expected {cur.n} {rows_word} after line {i + 1} (ITEM: "
                    f"{count_item} at line {cur.n_line - 1} says {cur.n}), found {k - first} "
                    f"before {'the end of the file' if k >= n_lines else 'the next ITEM'}: "
                    "a truncated or inconsistent snapshot",
                    path=path,
                )
            if end < n_lines and lines[end].strip() and not lines[end].startswith("ITEM:"):
                raise FileFormatError(
                    f"{path}:{end + 1}: expected 'ITEM: TIMESTEP' after the {cur.n} {rows_word} "
                    f"that ITEM: {count_item} (line {cur.n_line - 1}) announces, found a "
                    f"further row: the snapshot holds more {things} than its header says",
                    path=path,
                )
            i = end
        elif not local and (item.startswith("NUMBER OF ENTRIES") or item.startswith("ENTRIES")):
            raise FileFormatError(
                f"{path}:{i + 1}: a 'dump local' file ({line}): pair or bond entries, not "
                "particles",
                path=path,
            )
        elif local and item == "NUMBER OF ATOMS":
            raise FileFormatError(
                f"{path}:{i + 1}: a dump of atoms ({line}), not of contacts: give the dump "
                "local file of compute pair/gran/local or pair/local",
                path=path,
            )
        else:
            raise fail(i, f"ITEM: TIMESTEP, {count_item}, BOX BOUNDS or {rows_item}")
    if not blocks:
        raise FileFormatError(f"{path}: an empty dump (no snapshot)", path=path)
    last = blocks[-1]
    if last.names is None:
        raise fail(
            n_lines,
            "the rest of the snapshot that starts at line "
            f"{last.start + 1} (up to its ITEM: {rows_item} rows): a truncated dump",
        )
    for s in blocks:
        if (s.bounds is None and not local) or s.timestep is None:
            raise FileFormatError(
                f"{path}:{s.start + 1}: the snapshot that starts here has no "
                f"{'ITEM: TIMESTEP' if s.timestep is None else 'ITEM: BOX BOUNDS'}",
                path=path,
            )
    return blocks


def scan_complete_dump(
    path: Path, lines: list[str], local: bool = False, cut: bool = False
) -> tuple[list[DumpBlock], str | None]:
    """`scan_dump`, less a last snapshot that stops short: the state of a dump that
    LAMMPS is still writing (or that was cut off). Returns the complete snapshots and a
    note where one was left out; a file whose only snapshot stops short is refused.

    A snapshot stops short where the file ends inside it (its header, or fewer rows than
    its count), where its last row holds fewer fields than its columns (a line cut in
    two), or where a gzip stream stops before its end (`cut`). A number cut after a
    digit, at the end of an uncompressed file, cannot be told from a whole one."""
    starts = [k for k, ln in enumerate(lines) if ln.strip() == "ITEM: TIMESTEP"]
    for q, k in enumerate(starts):  # dump_modify units/time yes: items before TIMESTEP
        while k >= 2 and lines[k - 2].strip() in ("ITEM: UNITS", "ITEM: TIME"):
            k -= 2
        starts[q] = k
    why = None
    err: FileFormatError | None = None
    try:
        blocks = scan_dump(path, lines, local)
    except FileFormatError as exc:
        if "the end of the file" not in str(exc):
            raise
        err = exc
        why = "the gzip stream stops before its end" if cut else "the file ends inside it"
    else:
        last = blocks[-1]
        assert last.names is not None and last.n is not None
        end_row = lines[last.first + last.n - 1].split() if last.n else []
        if cut:
            why = "the gzip stream stops before its end"
        elif last.names and last.n and len(end_row) < len(last.names):
            why = (
                f"its last row, line {last.first + last.n}, holds {len(end_row)} of its "
                f"{len(last.names)} fields"
            )
        else:
            return blocks, None
    if len(starts) < 2:
        if err is not None:
            raise err
        if not cut:  # a short last row: the row reader names its line
            return blocks, None
        raise FileFormatError(
            f"{path}:{starts[0] + 1 if starts else 1}: the only snapshot is incomplete ({why}): "
            "a dump still being written or cut off",
            path=path,
            reason="truncated",
        )
    try:
        blocks = scan_dump(path, lines[: starts[-1]], local)
    except FileFormatError:
        if err is not None:
            raise err from None
        raise
    note = (
        f"the last snapshot (from line {starts[-1] + 1}) is incomplete ({why}): a dump "
        f"still being written or cut off; the {len(blocks)} complete snapshot"
        f"{'s' if len(blocks) > 1 else ''} before it {'are' if len(blocks) > 1 else 'is'} read"
    )
    return blocks, note


def _box_bounds(path: Path, lines: list[str], i: int, cur: DumpBlock, fail) -> None:
    """Reads the ITEM: BOX BOUNDS at line `i` into `cur` (an orthogonal box only)."""
    line = lines[i].strip()
    words = line[5:].strip().split()[2:]
    if words[:3] == ["xy", "xz", "yz"]:
        raise FileFormatError(
            f"{path}:{i + 1}: a triclinic box ({line}); only orthogonal boxes are read",
            path=path,
        )
    cur.flags = words or None
    cur.box_line = i + 1
    bounds = []
    for k, ax in enumerate("xyz"):
        j = i + 1 + k
        what = f"the {ax} bounds: two numbers '{ax}lo {ax}hi'"
        if j >= len(lines):
            raise fail(j, what)
        w = lines[j].split()
        if len(w) != 2 or not all(is_number(v) for v in w):
            raise fail(j, what)
        lo, hi = float(w[0]), float(w[1])
        if not (math.isfinite(lo) and math.isfinite(hi) and hi >= lo):
            raise fail(j, what + " (finite, lo <= hi)")
        bounds.append((lo, hi))
    cur.bounds = bounds
