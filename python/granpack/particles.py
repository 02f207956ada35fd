"""Particles from files written by granpack or by other codes: :func:`read_particles`.

One entry point reads every supported format and says which one it found; the result,
a :class:`ParticleFile`, goes straight into ``gp.microstructure`` and ``granpack analyze``.

Formats (the names `format=` takes and ``ParticleFile.format`` gives):

- ``"lammps-dump"``: a LAMMPS or LIGGGHTS ``dump custom`` (or ``write_dump ... custom``)
  text file, one or more snapshots; columns found by name;
- ``"lammps-data"``: a LAMMPS data file for ``atom_style sphere`` (as granpack's export
  and LAMMPS' ``write_data`` write it; a file for another atom style is refused);
- ``"yade"``: YADE's text export (``yade.export.text``/``textExt``, the file
  ``yade.ymport.text`` reads): a header comment ``#format x_y_z_r`` (or
  ``x_y_z_r_matId``, ``id_x_y_z_r_matId``), then one sphere a line;
- ``"xyz"``: extended XYZ (OVITO, ASE) with ``pos`` and ``radius`` properties, as
  granpack's export writes it, one or more frames;
- ``"xyzr"``: plain text, ``x y z r`` or ``x y r`` a line;
- ``"csv"``: comma-separated text with a header row naming the columns;
- ``"parquet"``: a Parquet table with named columns;
- ``"npz"``: a granpack pack file (``Pack.save``), contacts and forces included;
- ``"gsd"``: a gsd file in HOOMD-blue's schema (granpack's export, HOOMD-blue), one or
  more frames (`granpack.io.gsd`; needs the ``gsd`` package);
- ``"kratos"``: a Kratos DEM model part (``.mdpa``: ``Begin Nodes``, sphere elements,
  ``NodalData RADIUS``), as granpack's export and DEMGen write it (`granpack.io.kratos`).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ._validate import (
    FileFormatError,
    GranpackError,
    InvalidParameterError,
    is_number,
    short_repr,
)
from .io._text import (
    _SNIFF_LINES,
    _head,
    _single_snapshot,
)
from .io.lammps import _DATA_HEADER, _read_data, _read_dump
from .io.npz import _read_npz
from .io.particle_file import ParticleFile
from .io.tables import _read_table
from .io.xyz import _read_extxyz
from .io.xyzr import _read_xyzr
from .io.yade import _YADE_HEADER, _read_yade

if TYPE_CHECKING:
    pass

__all__ = ["FORMATS", "ParticleFile", "detect_format", "read_particles"]

#: The format names `read_particles` takes and reports.
FORMATS = (
    "lammps-dump",
    "lammps-data",
    "yade",
    "xyz",
    "xyzr",
    "csv",
    "parquet",
    "npz",
    "gsd",
    "kratos",
)

# gsd's magic number, 0x65DF65DF65DF65DF little-endian (granpack.io.gsd.GSD_MAGIC)
_GSD_MAGIC = bytes.fromhex("df65df65df65df65")






# --------------------------------------------------------------------------------------
# format detection
# --------------------------------------------------------------------------------------


def detect_format(path) -> str:
    """The format `read_particles` would read `path` as, one of `FORMATS`.

    A ``.npz``, ``.parquet`` or ``.gsd`` suffix, or the file's magic bytes (zip, ``PAR1``,
    gsd's), decide for the binary formats. Text is told by its content, whatever the
    suffix: a first line ``ITEM: ...`` is a dump, an ``N atoms`` header line a data
    file, a first (non-comment) line with a word that is not a number and a comma a CSV
    header, a first line ``#format x_y_z_r`` (YADE's header) YADE text; anything else is
    ``x y (z) r`` text.

    Raises
    ------
    FileFormatError
        The file cannot be opened.
    """
    path = Path(path)
    head = _head(path)
    suffix = path.suffix.lower()
    if suffix == ".npz" or head.startswith(b"PK\x03\x04"):
        return "npz"
    if suffix in (".parquet", ".pq") or head.startswith(b"PAR1"):
        return "parquet"
    if suffix == ".gsd" or head.startswith(_GSD_MAGIC):
        return "gsd"
    text = head.decode("utf-8-sig", errors="replace")
    lines = text.splitlines()
    first = next((ln.strip() for ln in lines if ln.strip()), "")
    # a Kratos model part (granpack.io.kratos): blocks "Begin Nodes" ... "End Nodes"
    if suffix == ".mdpa" or any(ln.split()[:2] == ["Begin", "Nodes"] for ln in lines):
        return "kratos"
    if first.startswith("ITEM:"):
        return "lammps-dump"
    if _YADE_HEADER.match(first):
        return "yade"
    if first.isdigit() and len(lines) > 1 and "properties=" in lines[1].lower():
        return "xyz"
    # a data file: a title line, then header lines such as "12 atoms" before "Atoms"
    if _DATA_HEADER.search("\n".join(lines[1:_SNIFF_LINES])):
        return "lammps-data"
    body = next((b for ln in lines if (b := ln.split("#", 1)[0].strip())), "")
    words = body.replace(",", " ").split()
    if "," in body and any(not is_number(w) for w in words):
        return "csv"
    return "xyzr"


# --------------------------------------------------------------------------------------
# the entry point
# --------------------------------------------------------------------------------------
def read_particles(
    path, format: str | None = None, snapshot: int = -1, *, dim: int | None = None
) -> ParticleFile:
    """Reads the particles of a file from granpack or another code.

    Parameters
    ----------
    path : str or Path
    format : str, optional
        One of `FORMATS` (``"lammps-dump"``, ``"lammps-data"``, ``"xyzr"``, ``"csv"``,
        ``"parquet"``, ``"npz"``, ``"gsd"``). Default None: found by :func:`detect_format`.
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
        format found, and for a dump the snapshot and timestep.

    Notes
    -----
    A dump's columns are found by name: ``x y z`` (else ``xu yu zu``, else the scaled
    ``xs ys zs`` or ``xsu ysu zsu``, which are fractions of the box), ``radius`` (else
    ``diameter``) and ``id`` (to sort by; optional). Other columns are ignored. Its box
    is the snapshot's ``BOX BOUNDS`` (orthogonal boxes only), and its flags give
    `periodic`, which the analysis follows on the horizontal axes (a periodic cell).
    Snapshots may hold different
    numbers of particles (a dump written while particles are inserted); each is read
    with its own header.

    CSV and Parquet tables need columns ``x``, ``y`` (, ``z``) and one of ``r``,
    ``radius``, ``diameter`` (names in any case; ``id`` optional), as granpack's own
    CSV and Parquet export writes them.

    Raises
    ------
    FileFormatError
        The file cannot be read as the format: the message names the file, the line (or
        row) and what was expected there (a truncated dump, a missing column, a row with
        too few numbers, a radius <= 0, a snapshot that the file does not hold).
    InvalidParameterError
        An unknown `format`, a `snapshot` that is not an integer, or `dim` not None, 2, 3.
    """
    path = Path(path)
    if format is not None and format not in FORMATS:
        raise InvalidParameterError(
            f"invalid format = {short_repr(format)}: must be one of {', '.join(FORMATS)} "
            "(or None to detect it)",
            parameter="format",
            value=format,
            expected=", ".join(FORMATS),
        )
    if isinstance(snapshot, bool) or not isinstance(snapshot, int | np.integer):
        raise InvalidParameterError(
            f"invalid snapshot = {short_repr(snapshot)}: must be an integer (0 the first, "
            "-1 the last)",
            parameter="snapshot",
            value=snapshot,
        )
    snapshot = int(snapshot)
    if dim is not None and (isinstance(dim, bool) or dim not in (2, 3)):
        raise InvalidParameterError(
            f"invalid dim = {short_repr(dim)}: must be None, 2 or 3", parameter="dim", value=dim
        )
    fmt = format if format is not None else detect_format(path)
    try:
        p = _read(path, fmt, snapshot, dim)
    except FileFormatError:
        raise
    except InvalidParameterError:
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
    return p


def _read(path: Path, fmt: str, snapshot: int, dim: int | None) -> ParticleFile:
    """The reader of `fmt`; the formats with frames (dumps, extended XYZ) take `snapshot`."""
    if fmt == "lammps-dump":
        return _read_dump(path, snapshot, dim)
    if fmt == "xyz":
        return _read_extxyz(path, snapshot, dim)
    if fmt == "gsd":
        from .io.gsd import read_gsd

        return read_gsd(path, dim=dim, snapshot=snapshot)
    _single_snapshot(path, snapshot)
    if fmt == "kratos":
        from .io.kratos import read_kratos

        return read_kratos(path, dim=dim)
    if fmt == "npz":
        return _read_npz(path, dim)
    if fmt == "lammps-data":
        return _read_data(path, dim)
    if fmt == "xyzr":
        return _read_xyzr(path, dim)
    if fmt == "yade":
        return _read_yade(path, dim)
    return _read_table(path, fmt, dim)














