"""The one registry behind :func:`read_particles` and :func:`export`: every format, by name,
by suffix and by content.

A format is a row of `READERS` or `WRITERS`, naming the module of ``granpack.io`` that
holds its reader or writer (imported when first used, so that ``import granpack`` loads
neither polars nor gsd). Adding a format is one module and one row here. A format both
read and written has one name in both tables: the name `write` takes is the one
`read_particles` reports of the file written (``ParticleFile.format``).

Detection reads the content first. Where the suffix names another format than the content
shows (a dump saved as ``.data``), the content wins and the ParticleFile's notes say so;
a format forced with ``format=`` that the content contradicts is read as asked, and its
reader refuses what it cannot read ("no Atoms section").
"""

from __future__ import annotations

import re
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from importlib import import_module
from pathlib import Path
from typing import TYPE_CHECKING

from .._validate import (
    FileFormatError,
    GranpackError,
    InvalidParameterError,
    check_outputs,
    is_number,
    short_repr,
)
from ._text import _SNIFF_LINES, _head, _read_args, _single_snapshot, as_path, compression
from .particle_file import ParticleFile

if TYPE_CHECKING:
    from ..pack import Pack

__all__ = [
    "READERS",
    "WRITERS",
    "FORMATS",
    "EXPORT_FORMATS",
    "detect_format",
    "read_particles",
    "export",
    "write",
    "output_paths",
    "FORMER_FORMAT_NAMES",
]


@dataclass(frozen=True)
class Reader:
    """A format `read_particles` reads.

    Attributes
    ----------
    name : str
        The name ``format=`` takes and ``ParticleFile.format`` gives.
    module, function : str
        ``granpack.io.<module>.<function>(path, dim=...)`` (and ``snapshot=`` where
        `frames`) returns a ParticleFile.
    suffixes : tuple of str
        Lower-case suffixes that suggest it (content decides for text).
    frames : bool
        The file may hold several snapshots (``snapshot=`` picks one).
    """

    name: str
    module: str
    function: str
    suffixes: tuple[str, ...] = ()
    frames: bool = False

    def load(self) -> Callable[..., ParticleFile]:
        return getattr(import_module(f"granpack.io.{self.module}"), self.function)


@dataclass(frozen=True)
class Writer:
    """A format `export` writes.

    Attributes
    ----------
    name : str
        The name ``format=`` takes (``granpack export --format``).
    module, function : str
        ``granpack.io.<module>.<function>(pack, path)`` writes every file of the format
        and returns their paths (a path or a list).
    suffix : str
        The suffix of the file it writes by default.
    guessed_from : tuple of str
        Suffixes that choose this format when ``format`` is not given (a suffix two
        formats share chooses neither: name the format).
    extra : callable or None
        ``extra(path) -> list[Path]``: the other files it writes beside `path`.
    """

    name: str
    module: str
    function: str
    suffix: str
    guessed_from: tuple[str, ...] = ()
    extra: Callable[[Path], list[Path]] | None = field(default=None, compare=False)

    def load(self) -> Callable[..., Path | list[Path]]:
        return getattr(import_module(f"granpack.io.{self.module}"), self.function)


#: The formats `read_particles` reads, by name.
READERS: dict[str, Reader] = {
    r.name: r
    for r in (
        Reader("lammps-dump", "lammps", "read_dump", (".dump", ".lammpstrj"), frames=True),
        Reader("lammps-data", "lammps", "read_data", (".data", ".lmp")),
        Reader("yade", "yade", "read_yade"),
        Reader("xyz", "xyz", "read_xyz", (".xyz", ".extxyz"), frames=True),
        Reader("xyzr", "xyzr", "read_xyzr_file", (".txt", ".xyzr")),
        Reader("csv", "tables", "read_csv", (".csv",)),
        Reader("parquet", "tables", "read_parquet", (".parquet", ".pq")),
        Reader("npz", "npz", "read_npz", (".npz",)),
        Reader("gsd", "gsd", "read_gsd", (".gsd",), frames=True),
        Reader("kratos", "kratos", "read_kratos", (".mdpa",)),
    )
}
#: The format names `read_particles` takes and reports.
FORMATS = tuple(READERS)


def _snippet(path: Path) -> list[Path]:
    from .lammps_input import SNIPPET_NAME

    return [path.with_name(SNIPPET_NAME)]


def _container_file(path: Path) -> list[Path]:
    from .vtk import container_path

    return [container_path(path)]


def _templates(path: Path) -> list[Path]:
    from .demengine import templates_path

    return [templates_path(path)]


#: The formats `export` writes, by name.
WRITERS: dict[str, Writer] = {
    w.name: w
    for w in (
        Writer("vtk", "vtk", "write_vtk_files", ".vtu", (".vtu", ".vtk"), _container_file),
        Writer("lammps-data", "lammps", "write_lammps_files", ".data", (".data", ".lmp"), _snippet),
        Writer("liggghts", "lammps", "write_liggghts_files", ".data", (), _snippet),
        Writer("yade", "yade", "write_yade", ".txt"),
        Writer("xyz", "xyz", "write_xyz", ".xyz", (".xyz",)),
        Writer("csv", "tables", "write_csv", ".csv", (".csv",)),
        Writer("parquet", "tables", "write_parquet", ".parquet", (".parquet",)),
        Writer("gsd", "gsd", "write_gsd", ".gsd", (".gsd",)),
        Writer("kratos", "kratos", "write_kratos", ".mdpa", (".mdpa",)),
        Writer("mercurydpm", "mercurydpm", "write_mercurydpm", ".data"),
        Writer("pfc", "pfc", "write_pfc", ".dat", (".p3dat", ".p2dat")),
        Writer("demengine", "demengine", "write_demengine", ".csv", (), _templates),
        Writer("npz", "npz", "write_npz", ".npz", (".npz",)),
    )
}
#: Former names of export formats, still taken (with a DeprecationWarning) until the next
#: release: the name of each is now the one `read_particles` reports of its file.
FORMER_FORMAT_NAMES = {"lammps": "lammps-data"}
#: Export formats and the suffix of the file each writes.
EXPORT_FORMATS = {name: w.suffix for name, w in WRITERS.items()}

# content signatures
_GSD_MAGIC = bytes.fromhex("df65df65df65df65")  # 0x65DF65DF65DF65DF, little-endian
_DATA_HEADER = re.compile(r"^\s*\d+\s+atoms\s*(#.*)?$", re.MULTILINE)
_YADE_HEADER = re.compile(r"^#\s*format\s+(\S+)\s*$")


def _is_text(head: bytes) -> bool:
    """Whether the first bytes read as UTF-8 text (a character cut at the end of the head
    aside) without NUL bytes: what every text format granpack reads is."""
    if b"\x00" in head:
        return False
    try:
        head.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        return exc.start >= len(head) - 3 and exc.reason == "unexpected end of data"
    return True


#: The formats read through the text reader that takes gzip (LAMMPS writes compressed
#: dumps; the other codes' text is read the same way).
_GZIP_FORMATS = ("lammps-dump", "yade", "xyz", "kratos")
#: The formats that are no text.
_BINARY_FORMATS = ("npz", "parquet", "gsd")


def _by_content(head: bytes) -> str | None:
    """The format the first bytes show, or None for text that could be any table (and
    for bytes that are no text: the suffix then decides, and the reader refuses them)."""
    if head.startswith(b"PK\x03\x04"):
        return "npz"
    if head.startswith(b"PAR1"):
        return "parquet"
    if head.startswith(_GSD_MAGIC):
        return "gsd"
    if not _is_text(head):
        return None
    text = head.decode("utf-8-sig", errors="replace")
    lines = text.splitlines()
    first = next((ln.strip() for ln in lines if ln.strip()), "")
    if first.startswith("ITEM:"):
        return "lammps-dump"
    if _YADE_HEADER.match(first):
        return "yade"
    # a Kratos model part (granpack.io.kratos): blocks "Begin Nodes" ... "End Nodes"
    if any(ln.split()[:2] == ["Begin", "Nodes"] for ln in lines):
        return "kratos"
    if first.isdigit() and len(lines) > 1 and "properties=" in lines[1].lower():
        return "xyz"
    # a data file: a title line, then header lines such as "12 atoms" before "Atoms"
    if _DATA_HEADER.search("\n".join(lines[1:_SNIFF_LINES])):
        return "lammps-data"
    body = next((b for ln in lines if (b := ln.split("#", 1)[0].strip())), "")
    words = body.replace(",", " ").split()
    if "," in body and any(not is_number(w) for w in words):
        return "csv"
    return None


def detect_format(path) -> str:
    """The format `read_particles` would read `path` as, one of `FORMATS`.

    The content decides: magic bytes for the binary formats (zip for a pack file,
    ``PAR1`` for Parquet, gsd's), and for text a first line ``ITEM: ...`` (a dump), an
    ``N atoms`` header line (a data file), ``#format x_y_z_r`` (YADE), a count then a
    ``Properties=`` line (extended XYZ), ``Begin Nodes`` (Kratos), a header row of names
    with commas (CSV). Text that shows none of these is read by its suffix where that
    names a format (``.npz``, ``.parquet``, ``.gsd``: an unreadable file of that kind is
    then refused by its reader), else as ``x y (z) r`` text.

    Raises
    ------
    FileFormatError
        The file cannot be opened.
    """
    path = as_path(path)
    head = _head(path)
    found = _by_content(head)
    if found is not None:
        return found
    suffix = path.suffix.lower()
    for name in ("npz", "parquet", "gsd", "kratos"):
        if suffix in READERS[name].suffixes:
            return name
    return "xyzr"


def _raw_head(path: Path) -> bytes:
    """The first bytes of the file as stored (compressed or not)."""
    try:
        with open(path, "rb") as f:
            return f.read(8)
    except OSError:
        return b""  # the reader names the failure to open it


def _suffix_disagrees(path: Path, fmt: str) -> str | None:
    """A note where the suffix names another format than the content showed."""
    suffix = path.suffix.lower()
    named = [r.name for r in READERS.values() if suffix in r.suffixes]
    if not named or fmt in named or (fmt in ("xyzr", "yade") and suffix == ".txt"):
        return None
    return (
        f"the content of {path.name} is {fmt}, its suffix {suffix} suggests "
        f"{' or '.join(named)}: read as {fmt}, as the content says"
    )


def read_particles(
    path, format: str | None = None, snapshot: int = -1, *, dim: int | None = None
) -> ParticleFile:
    """Reads the particles of a file from granpack or another code.

    Parameters
    ----------
    path : str or Path
    format : str, optional
        One of `FORMATS` (``"lammps-dump"``, ``"lammps-data"``, ``"yade"``, ``"xyz"``,
        ``"xyzr"``, ``"csv"``, ``"parquet"``, ``"npz"``, ``"gsd"``, ``"kratos"``).
        Default None: found by :func:`detect_format`, content first.
    snapshot : int
        Which snapshot of a dump, or frame of an extended XYZ or gsd file: 0 the first, -1
        (default) the last, as Python indexes. Files with one snapshot take 0 or -1.
    dim : {None, 2, 3}
        None (default): as the file says. A dump, data file or table is 2D when it has
        no z column, or when every z is 0 (or, in a dump, the same for every particle
        with a periodic z, as LAMMPS' 2D is); text follows ``read_xyzr``'s rule. 2 drops
        a constant z; 3 keeps it.

    Returns
    -------
    ParticleFile
        Positions (sorted by id where the file has ids), radii, box, periodic flags, the
        container where the file says it, the format found, and for a file of frames the
        snapshot and timestep.

    Notes
    -----
    A dump's columns are found by name: ``x y z`` (else ``xu yu zu``, else the scaled
    ``xs ys zs`` or ``xsu ysu zsu``, which are fractions of the box), ``radius`` (else
    ``diameter``) and ``id`` (to sort by; optional). Other columns are ignored. Its box
    is the snapshot's ``BOX BOUNDS`` (orthogonal boxes only), and its flags give
    `periodic`, which the analysis follows on the horizontal axes (a periodic cell).
    Snapshots may hold different numbers of particles (a dump written while particles
    are inserted); each is read with its own header.

    Each axis of a dump is read from its own column, so scaled and unscaled ones may mix
    (``x y zs``; a note says so). A dump whose last snapshot stops short (LAMMPS still
    writing it, or a cut copy) is read up to its last complete snapshot, with a note.
    gzip-compressed dumps (``dump ... file.gz``), YADE, extended XYZ and Kratos text are
    read; other compressed files are refused by name. Ids are read exactly up to 64 bits.

    CSV and Parquet tables need columns ``x``, ``y`` (, ``z``) and one of ``r``,
    ``radius``, ``diameter`` (names in any case; ``id`` optional), as granpack's own
    CSV and Parquet export writes them; Parquet columns must be numeric (a Boolean or
    text column is refused).

    Raises
    ------
    FileFormatError
        The file cannot be read as the format: the message names the file, the line (or
        row, chunk) and what was expected there (a truncated dump, a missing column, a
        row with too few numbers, a radius <= 0, a snapshot that the file does not hold,
        no particles).
    InvalidParameterError
        A `path` that is no path (None, a number), an unknown `format`, a `snapshot` that
        is not an integer, or `dim` not None, 2, 3.
    """
    path = as_path(path)
    if format is not None and format not in READERS:
        raise InvalidParameterError(
            f"invalid format = {short_repr(format)}: must be one of {', '.join(FORMATS)} "
            "(or None to detect it)",
            parameter="format",
            value=format,
            expected=", ".join(FORMATS),
        )
    snapshot = _read_args(snapshot, dim)
    fmt = format if format is not None else detect_format(path)
    packed = compression(_raw_head(path))
    if packed is not None and (packed != "gzip" or fmt not in _GZIP_FORMATS):
        raise FileFormatError(
            f"cannot read {path}: a {packed}-compressed file read as {fmt}; granpack reads "
            f"gzip-compressed {', '.join(_GZIP_FORMATS)} text (such as LAMMPS' dump ... "
            "file.gz) and the other formats uncompressed: decompress it first",
            path=path,
            reason="compressed",
        )
    if fmt not in _BINARY_FORMATS and not _is_text(_head(path)):
        raise FileFormatError(
            f"cannot read {path} as {fmt}: not a text file (NUL bytes, or bytes that are "
            "not UTF-8)",
            path=path,
            reason="not text",
        )
    reader = READERS[fmt]
    try:
        if reader.frames:
            p = reader.load()(path, snapshot=snapshot, dim=dim)
        else:
            _single_snapshot(path, snapshot)
            p = reader.load()(path, dim=dim)
    except (FileFormatError, InvalidParameterError):
        raise
    except UnicodeDecodeError as exc:
        raise FileFormatError(
            f"cannot read {path} as {fmt}: not a text file (byte {exc.start} is not UTF-8)",
            path=path,
        ) from None
    except GranpackError as exc:
        # the older readers raise the base class for an unreadable file
        raise FileFormatError(str(exc), path=path) from None
    if len(p) == 0:  # every reader refuses an empty body; this holds for any new one too
        raise FileFormatError(f"{path}: no particles", path=path)
    if format is None:
        note = _suffix_disagrees(path, fmt)
        if note is not None:
            p.notes = (*p.notes, note)
    return p


def _format_from_suffix(path: Path) -> str:
    suffix = path.suffix.lower()
    for w in WRITERS.values():
        if suffix in w.guessed_from:
            return w.name
    raise InvalidParameterError(
        f"cannot tell the export format from {path.name!r}: give format= ({', '.join(WRITERS)})",
        parameter="format",
    )


def _current_name(format):
    """`format`, or the name that replaced it (`FORMER_FORMAT_NAMES`), with a
    DeprecationWarning."""
    new = FORMER_FORMAT_NAMES.get(format) if isinstance(format, str) else None
    if new is None:
        return format
    warnings.warn(
        f"format {format!r} is now {new!r}, the name read_particles reports of the file; "
        f"{format!r} will be removed in the next release",
        DeprecationWarning,
        stacklevel=3,
    )
    return new


def output_paths(path: str | Path, format: str) -> list[Path]:
    """Every file `export` writes for `path` in `format`, in the order it writes them."""
    path = Path(path)
    format = _current_name(format)
    if format in ("csv", "parquet"):
        from .tables import _table_paths

        return list(_table_paths(path, WRITERS[format].suffix))
    w = WRITERS[format]
    return [path, *(w.extra(path) if w.extra is not None else [])]


def export(
    pack: Pack,
    path: str | Path,
    format: str | None = None,
    *,
    refuse: Sequence = (),
    parameter: str = "path",
) -> list[Path]:
    """Writes `pack` in one of `EXPORT_FORMATS` and returns the files written.

    Parameters
    ----------
    pack : Pack
    path : path
        Output file. For csv/parquet its stem names the two tables
        (``<stem>.particles.csv``, ``<stem>.contacts.csv``).
    format : {"vtk", "lammps-data", "liggghts", "yade", "xyz", "csv", "parquet", "gsd", \
"kratos", "mercurydpm", "pfc", "demengine", "npz"}, optional
        Default: from the suffix of `path` (.vtu/.vtk, .data/.lmp (lammps-data), .xyz,
        .csv, .parquet, .gsd, .mdpa (kratos), .p3dat/.p2dat (pfc), .npz (the pack file,
        `Pack.save`); yade, liggghts, mercurydpm and demengine are named, not guessed).
        ``"lammps"``, the former name of ``"lammps-data"``, is still taken, with a
        DeprecationWarning, until the next release. demengine also writes
        ``<stem>.templates.csv``; lammps and liggghts also write ``in.granpack`` beside
        the data file; vtk also writes ``<stem>.container.vtu``.
    refuse : sequence of paths
        Files that must not be overwritten (the pack file read, say).
    parameter : str
        The name errors give `path` (the command line passes ``"--out"``).

    Raises
    ------
    InvalidParameterError
        Before anything is written, naming `parameter`: an unknown format; two of the
        files the format writes would be one file (``--out DIR/in.granpack`` for lammps,
        whose input script is ``in.granpack``); or one would be a file of `refuse`.
    """
    path = Path(path)
    if format is None:
        format = _format_from_suffix(path)
    format = _current_name(format)
    if format not in WRITERS:
        raise InvalidParameterError(
            f"invalid format = {format!r}: choose one of {', '.join(WRITERS)}",
            parameter="format",
        )
    check_outputs(output_paths(path, format), refuse, parameter)
    written = WRITERS[format].load()(pack, path)
    return list(written) if isinstance(written, list | tuple) else [written]


def write(pack: Pack, path: str | Path, format: str | None = None) -> list[Path]:
    """Writes `pack` to `path` in `format` and returns the files written: the other
    direction of `read_particles`, with the same format names.

    Parameters
    ----------
    pack : Pack
    path : path
        Output file (csv/parquet: its stem names the particle and contact tables).
    format : str, optional
        One of `EXPORT_FORMATS` (see `export`). Default None: from the suffix of `path`,
        as `read_particles` does. The formats read and written carry the same name both
        ways: ``read_particles(write(pack, "p.data")[0]).format == "lammps-data"``.

    Raises
    ------
    InvalidParameterError
        Before anything is written: an unknown format, or a suffix that names none.
    """
    return export(pack, path, format)
