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
- ``"npz"``: a granpack pack file (``Pack.save``), contacts and forces included.
"""

from __future__ import annotations

import math
import re
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
from .contacts import Contacts
from .container_tag import ContainerTag, parse_container_tag

if TYPE_CHECKING:
    from .pack import Pack

__all__ = ["FORMATS", "ParticleFile", "detect_format", "read_particles"]

#: The format names `read_particles` takes and reports.
FORMATS = ("lammps-dump", "lammps-data", "yade", "xyz", "xyzr", "csv", "parquet", "npz")

# Coordinate columns of a dump, in order of preference: plain, unwrapped, scaled,
# scaled unwrapped (LAMMPS' names). Scaled ones are fractions of the box.
_DUMP_COORDS = (("x", "y", "z", False), ("xu", "yu", "zu", False))
_DUMP_SCALED = (("xs", "ys", "zs", True), ("xsu", "ysu", "zsu", True))
_RADIUS_NAMES = ("radius", "r")
_DIAMETER_NAMES = ("diameter", "d")
_ID_NAMES = ("id",)
# How many leading lines the content sniffing looks at for a data file's "N atoms".
_SNIFF_LINES = 40
_DATA_HEADER = re.compile(r"^\s*\d+\s+atoms\s*(#.*)?$", re.MULTILINE)
# YADE's text export: "#format x_y_z_r" (export.text), or another textExt layout
_YADE_HEADER = re.compile(r"^#\s*format\s+(\S+)\s*$")
#: The YADE layouts read, as their header names them; columns other than x y z r id are
#: skipped (matId, the material).
YADE_LAYOUTS = ("x_y_z_r", "x_y_z_r_matId", "id_x_y_z_r_matId")


class ParticleFile:
    """The particles of one file (one snapshot of a dump), as :func:`read_particles`
    returns them. ``gp.microstructure(p)`` analyses it as it does a pack.

    Attributes
    ----------
    path : Path
        The file read.
    format : str
        The format found (or given), one of `FORMATS`.
    dim : int
        2 or 3.
    positions : (N, D) float64, read-only
        Centres (m), sorted by id where the file has ids; vertical axis last (y in 2D).
    radii : (N,) float64, read-only
        Radii (m).
    ids : (N,) int64 or None
        The file's particle ids, in the order of `positions` (None: the file has none).
    box : (lo, hi) or None
        The box corners (D each, m) where the file gives one (a dump's ``BOX BOUNDS``, a
        data file's header, a pack's scene); the analysis puts its walls there. None: the
        analysis uses the particles' bounding box, with no walls.
    periodic : tuple of D bool, or None
        Periodic axes from a dump's ``BOX BOUNDS`` flags (``pp``) or an XYZ file's pbc.
        The analysis takes periodic horizontal axes as a periodic cell (no walls there,
        contacts across the seam by minimum image); the vertical axis is always bounded
        by the floor and the open top.
    container : {"box", "periodic", "cylinder"} or None
        The container the file says the pack lies in: a granpack pack's scene, the
        container tag of granpack's text exports (`granpack.container_tag`), or periodic
        horizontal axes in `periodic`. None: the file does not say; the analysis then
        assumes a box (walls at `box`, or none without one) and says so
        (``Microstructure.container_source``).
    cylinder_radius : float or None
        R (m) of a cylinder container.
    timestep : int or None
        A dump snapshot's ``TIMESTEP``.
    snapshot : int
        Which snapshot (a dump's snapshot, an XYZ file's frame) was read (0-based,
        counted from the start).
    n_snapshots : int
        How many the file holds (1 for every format but a dump and extended XYZ).
    contacts : granpack.Contacts or None
        The contacts with forces of a granpack pack (npz); None otherwise (the analysis
        then finds the contacts from the geometry and has no forces).
    pack : granpack.Pack or None
        The pack itself for a ``.npz`` file.
    notes : tuple of str
        What the reader left out or assumed (periodic flags, a dimension it inferred).
    """

    def __init__(
        self,
        *,
        path: Path,
        format: str,
        positions: np.ndarray,
        radii: np.ndarray,
        ids: np.ndarray | None = None,
        box: tuple[np.ndarray, np.ndarray] | None = None,
        periodic: tuple[bool, ...] | None = None,
        container: str | None = None,
        cylinder_radius: float | None = None,
        timestep: int | None = None,
        snapshot: int = 0,
        n_snapshots: int = 1,
        contacts: Contacts | None = None,
        pack: Pack | None = None,
        notes: tuple[str, ...] = (),
    ) -> None:
        self.path = path
        self.format = format
        self.positions = _frozen(np.asarray(positions, dtype=np.float64))
        self.radii = _frozen(np.asarray(radii, dtype=np.float64))
        self.dim = int(self.positions.shape[1])
        self.ids = None if ids is None else _frozen(np.asarray(ids, dtype=np.int64))
        self.box = None if box is None else (_frozen(box[0]), _frozen(box[1]))
        self.periodic = periodic
        if container is None and periodic is not None and any(periodic[: self.dim - 1]):
            container = "periodic"
        self.container = container
        self.cylinder_radius = cylinder_radius
        self.timestep = timestep
        self.snapshot = snapshot
        self.n_snapshots = n_snapshots
        self.contacts = contacts
        self.pack = pack
        self.notes = notes

    def __len__(self) -> int:
        return int(self.radii.shape[0])

    def with_contacts(self, contacts) -> ParticleFile:
        """The same particles with `contacts` (a granpack.Contacts, or what
        :func:`granpack.read_contacts` returns), so that ``gp.microstructure`` takes its
        forces: ``gp.microstructure(p.with_contacts(gp.read_contacts(f, p)))``."""
        c = getattr(contacts, "contacts", contacts)
        if not isinstance(c, Contacts):
            raise InvalidParameterError(
                f"invalid contacts = {type(contacts).__name__}: expected granpack.Contacts or "
                "the result of granpack.read_contacts",
                parameter="contacts",
            )
        from .analysis.inputs import _as_contacts, check_contacts_touch
        from .analysis.prepare import analysis_container

        # the contacts must touch in the container the analysis will see
        _as_contacts(c, len(self), self.dim)
        container, walls = analysis_container(self)
        source = getattr(contacts, "path", None)
        ids = self.ids if self.ids is not None else np.arange(1, len(self) + 1)
        check_contacts_touch(
            c.i,
            c.j,
            self.positions,
            self.radii,
            container=container,
            walls=walls,
            box=self.box,
            path=source,
            ids=ids if source is not None else None,
        )
        notes = self.notes + tuple(getattr(contacts, "notes", ()))
        return ParticleFile(
            path=self.path,
            format=self.format,
            positions=self.positions,
            radii=self.radii,
            ids=self.ids,
            box=self.box,
            periodic=self.periodic,
            container=self.container,
            cylinder_radius=self.cylinder_radius,
            timestep=self.timestep,
            snapshot=self.snapshot,
            n_snapshots=self.n_snapshots,
            contacts=c,
            pack=self.pack,
            notes=notes,
        )

    def __repr__(self) -> str:
        where = f", snapshot {self.snapshot} of {self.n_snapshots}" if self.n_snapshots > 1 else ""
        return (
            f"ParticleFile({str(self.path)!r}, format={self.format!r}, dim={self.dim}, "
            f"n={len(self)}{where})"
        )


def _frozen(a) -> np.ndarray:
    # a copy, so that freezing it never freezes the caller's array (a pack's own)
    a = np.array(a, copy=True, order="C")
    a.setflags(write=False)
    return a


# --------------------------------------------------------------------------------------
# format detection
# --------------------------------------------------------------------------------------
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


def detect_format(path) -> str:
    """The format `read_particles` would read `path` as, one of `FORMATS`.

    A ``.npz`` or ``.parquet`` suffix, or the file's magic bytes (zip, ``PAR1``), decide
    for the binary formats. Text is told by its content, whatever the suffix: a first
    line ``ITEM: ...`` is a dump, an ``N atoms`` header line a data file, a first
    (non-comment) line with a word that is not a number and a comma a CSV header, a
    first line ``#format x_y_z_r`` (YADE's header) YADE text; anything else is
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
    text = head.decode("utf-8-sig", errors="replace")
    lines = text.splitlines()
    first = next((ln.strip() for ln in lines if ln.strip()), "")
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
        ``"parquet"``, ``"npz"``). Default None: found by :func:`detect_format`.
    snapshot : int
        Which snapshot of a dump, or frame of an extended XYZ file: 0 the first, -1
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
    _single_snapshot(path, snapshot)
    if fmt == "npz":
        return _read_npz(path, dim)
    if fmt == "lammps-data":
        return _read_data(path, dim)
    if fmt == "xyzr":
        return _read_xyzr(path, dim)
    if fmt == "yade":
        return _read_yade(path, dim)
    return _read_table(path, fmt, dim)


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


# --------------------------------------------------------------------------------------
# LAMMPS / LIGGGHTS dump custom
# --------------------------------------------------------------------------------------
class _Snapshot:
    __slots__ = ("start", "timestep", "n", "n_line", "bounds", "flags", "box_line", "cols")

    def __init__(self, start: int) -> None:
        self.start = start  # 0-based index of its first line
        self.timestep: int | None = None
        self.n: int | None = None
        self.n_line = 0
        self.bounds: list[tuple[float, float]] | None = None
        self.flags: list[str] | None = None
        self.box_line = 0
        self.cols: tuple[int, list[str]] | None = None  # (0-based line of ITEM: ATOMS, names)


def _scan_dump(path: Path, lines: list[str]) -> list[_Snapshot]:
    """Walks the ITEM blocks of every snapshot, checking their structure (and skipping
    the atom rows), so that a truncated or inconsistent file is refused whichever
    snapshot is asked for."""
    snaps: list[_Snapshot] = []
    cur: _Snapshot | None = None
    i = 0
    n_lines = len(lines)

    def fail(k: int, what: str) -> FileFormatError:
        found = repr(lines[k].strip()[:60]) if k < n_lines else "the end of the file"
        return FileFormatError(f"{path}:{k + 1}: expected {what}, found {found}", path=path)

    def value_line(k: int, what: str, kind=int) -> float | int:
        if k >= n_lines:
            raise fail(k, what)
        words = lines[k].split()
        try:
            if len(words) != 1:
                raise ValueError
            return kind(words[0])
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
        if cur is None or cur.cols is not None:
            if item not in ("TIMESTEP", "UNITS", "TIME"):
                raise fail(i, "'ITEM: TIMESTEP' (the start of a snapshot)")
            cur = _Snapshot(i)
            snaps.append(cur)
        if item == "TIMESTEP":
            if cur.timestep is not None:
                raise fail(i, f"'ITEM: ATOMS' of the snapshot that starts at line {cur.start + 1}")
            cur.timestep = int(value_line(i + 1, "the timestep (an integer)"))
            i += 2
        elif item in ("UNITS", "TIME"):  # dump_modify units/time yes
            if i + 1 >= n_lines:
                raise fail(i + 1, f"the {item.lower()} value")
            i += 2
        elif item in ("NUMBER OF ATOMS",):
            n = int(value_line(i + 1, "the number of atoms (an integer >= 0)"))
            if n < 0:
                raise fail(i + 1, "the number of atoms (an integer >= 0)")
            cur.n, cur.n_line = n, i + 2
            i += 2
        elif item.startswith("BOX BOUNDS"):
            words = item.split()[2:]
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
                if j >= n_lines:
                    raise fail(j, what)
                w = lines[j].split()
                if len(w) != 2 or not all(is_number(v) for v in w):
                    raise fail(j, what)
                lo, hi = float(w[0]), float(w[1])
                if not (math.isfinite(lo) and math.isfinite(hi) and hi >= lo):
                    raise fail(j, what + " (finite, lo <= hi)")
                bounds.append((lo, hi))
            cur.bounds = bounds
            i += 4
        elif item.startswith("ATOMS"):
            names = item.split()[1:]
            if cur.n is None:
                raise FileFormatError(
                    f"{path}:{i + 1}: 'ITEM: ATOMS' before 'ITEM: NUMBER OF ATOMS' in the "
                    f"snapshot that starts at line {cur.start + 1}",
                    path=path,
                )
            if not names:
                raise fail(i, "'ITEM: ATOMS' followed by the column names (dump custom)")
            cur.cols = (i, names)
            first, end = i + 1, i + 1 + cur.n
            # a snapshot shorter than its header: the next ITEM line falls inside
            if end > n_lines or any(ln.startswith("ITEM:") for ln in lines[first:end]):
                k = next(
                    (j for j in range(first, min(end, n_lines)) if lines[j].startswith("ITEM:")),
                    n_lines,
                )
                got = k - first
                raise FileFormatError(
                    f"{path}:{k + 1}: expected {cur.n} atom rows after line {i + 1} (ITEM: "
                    f"NUMBER OF ATOMS at line {cur.n_line - 1} says {cur.n}), found {got} "
                    f"before {'the end of the file' if k >= n_lines else 'the next ITEM'}: "
                    "a truncated or inconsistent snapshot",
                    path=path,
                )
            if end < n_lines and lines[end].strip() and not lines[end].startswith("ITEM:"):
                raise FileFormatError(
                    f"{path}:{end + 1}: expected 'ITEM: TIMESTEP' after the {cur.n} atom rows "
                    f"that ITEM: NUMBER OF ATOMS (line {cur.n_line - 1}) announces, found a "
                    "further row: the snapshot holds more atoms than its header says",
                    path=path,
                )
            i = end
        elif item.startswith("NUMBER OF ENTRIES") or item.startswith("ENTRIES"):
            raise FileFormatError(
                f"{path}:{i + 1}: a 'dump local' file ({line}): pair or bond entries, not "
                "particles",
                path=path,
            )
        else:
            raise fail(i, "ITEM: TIMESTEP, NUMBER OF ATOMS, BOX BOUNDS or ATOMS")
    if not snaps:
        raise FileFormatError(f"{path}: an empty dump (no snapshot)", path=path)
    last = snaps[-1]
    if last.cols is None:
        raise fail(
            n_lines,
            "the rest of the snapshot that starts at line "
            f"{last.start + 1} (up to its ITEM: ATOMS rows): a truncated dump",
        )
    for s in snaps:
        if s.bounds is None or s.timestep is None:
            raise FileFormatError(
                f"{path}:{s.start + 1}: the snapshot that starts here has no "
                f"{'ITEM: BOX BOUNDS' if s.bounds is None else 'ITEM: TIMESTEP'}",
                path=path,
            )
    return snaps


def _pick(names: list[str], wanted: tuple[str, ...]) -> int | None:
    low = [n.strip().lower() for n in names]
    for w in wanted:
        if w in low:
            return low.index(w)
    return None


def _read_dump(path: Path, snapshot: int, dim: int | None) -> ParticleFile:
    lines = _read_text(path).splitlines()
    snaps = _scan_dump(path, lines)
    n_snap = len(snaps)
    if not -n_snap <= snapshot < n_snap:
        raise FileFormatError(
            f"{path}: snapshot = {snapshot} is out of range: the dump holds {n_snap} "
            f"snapshot{'s' if n_snap > 1 else ''} (0 to {n_snap - 1}, or -{n_snap} to -1)",
            path=path,
            reason="snapshot out of range",
        )
    k_snap = snapshot % n_snap
    s = snaps[k_snap]
    assert s.cols is not None and s.n is not None and s.bounds is not None
    atoms_line, names = s.cols
    header = f"{path}:{atoms_line + 1}"

    coord: tuple[int | None, int | None, int | None] | None = None
    scaled = False
    for cx, cy, cz, sc in (*_DUMP_COORDS, *_DUMP_SCALED):
        ix, iy = _pick(names, (cx,)), _pick(names, (cy,))
        if ix is not None and iy is not None:
            coord, scaled = (ix, iy, _pick(names, (cz,))), sc
            break
    if coord is None:
        raise FileFormatError(
            f"{header}: missing columns: expected x y (z), xu yu (zu) or scaled xs ys (zs) "
            f"in 'ITEM: ATOMS', found {' '.join(names)}",
            path=path,
            reason="missing coordinate columns",
        )
    i_rad = _pick(names, ("radius",))
    i_dia = _pick(names, ("diameter",))
    if i_rad is None and i_dia is None:
        raise FileFormatError(
            f"{header}: missing column: expected radius or diameter in 'ITEM: ATOMS', found "
            f"{' '.join(names)} (add radius to the dump custom command)",
            path=path,
            reason="missing radius column",
        )
    i_id = _pick(names, _ID_NAMES)

    if s.n == 0:
        raise FileFormatError(
            f"{path}:{s.n_line}: snapshot {k_snap} holds no atoms (NUMBER OF ATOMS 0)",
            path=path,
        )
    first = atoms_line + 1
    ncol = len(names)
    table = [row.split() for row in lines[first : first + s.n]]
    for j, t in enumerate(table):
        if len(t) != ncol:
            raise FileFormatError(
                f"{path}:{first + j + 1}: expected {ncol} values ({' '.join(names)}), found "
                f"{len(t)}",
                path=path,
            )
    want = [c for c in (*coord, i_rad if i_rad is not None else i_dia) if c is not None]
    if i_id is not None:
        want.append(i_id)
    try:
        a = np.array([[t[c] for c in want] for t in table], dtype=np.float64).reshape(
            s.n, len(want)
        )
    except ValueError:
        for j, t in enumerate(table):
            bad = next((t[c] for c in want if not is_number(t[c])), None)
            if bad is not None:
                raise FileFormatError(
                    f"{path}:{first + j + 1}: {bad!r} is not a number", path=path
                ) from None
        raise
    has_z = coord[2] is not None
    nc = 3 if has_z else 2
    x3 = np.zeros((s.n, 3))
    x3[:, :nc] = a[:, :nc]
    lo = np.array([b[0] for b in s.bounds])
    hi = np.array([b[1] for b in s.bounds])
    if scaled:  # fractions of the box
        x3[:, :nc] = lo[:nc] + x3[:, :nc] * (hi[:nc] - lo[:nc])
    r = a[:, nc] if i_rad is not None else a[:, nc] / 2.0
    ids = None
    order = np.arange(s.n)

    def where(k: int) -> int:
        return first + int(order[k]) + 1

    if i_id is not None:
        ids = _integer_ids(path, a[:, -1], lambda k: first + k + 1)
        order = _sorted_by_id(path, ids, lambda k: first + k + 1)
        ids = ids[order]
        x3, r = x3[order], r[order]
    _check_values(path, x3, r, where)

    notes: list[str] = []
    flags = s.flags
    z_periodic = flags is not None and len(flags) == 3 and flags[2] == "pp"
    d = _choose_dim(path, x3, has_z, dim, z_periodic)
    periodic = None
    if flags is not None:
        if len(flags) != 3:
            raise FileFormatError(
                f"{path}:{s.box_line}: expected three boundary flags after BOX BOUNDS (such as "
                f"'pp pp ff'), found {' '.join(flags)}",
                path=path,
            )
        periodic = tuple(f == "pp" for f in flags[:d])
        axes = [ax for ax, p in zip("xyz", periodic, strict=False) if p]
        if axes:
            notes.append(
                f"periodic in {' and '.join(axes)} (BOX BOUNDS {' '.join(flags)}): the "
                "analysis takes the periodic horizontal axes as a periodic cell"
            )
    return ParticleFile(
        path=path,
        format="lammps-dump",
        positions=x3[:, :d],
        radii=r,
        ids=ids,
        box=(lo[:d], hi[:d]),
        periodic=periodic,
        timestep=s.timestep,
        snapshot=k_snap,
        n_snapshots=n_snap,
        notes=tuple(notes),
    )


# --------------------------------------------------------------------------------------
# the other formats
# --------------------------------------------------------------------------------------
def _read_npz(path: Path, dim: int | None) -> ParticleFile:
    from .dem_input import container_of
    from .pack import load_pack

    pack = load_pack(path)
    if dim is not None and dim != pack.dim:
        raise FileFormatError(f"{path}: dim = {dim} asked for a {pack.dim}D pack", path=path)
    kind, radius = container_of(pack)
    return ParticleFile(
        path=path,
        format="npz",
        positions=np.asarray(pack.positions),
        radii=np.asarray(pack.radii),
        box=pack.box,
        periodic=(kind == "periodic",) * (pack.dim - 1),
        container=kind,
        cylinder_radius=radius,
        contacts=pack.contacts,
        pack=pack,
    )


def _read_data(path: Path, dim: int | None) -> ParticleFile:
    from .export import read_lammps_data

    data = read_lammps_data(path)
    x3 = data["positions"]
    ids = data["id"]
    if len(ids) == 0:
        raise FileFormatError(f"{path}: no atoms (the header says 0 atoms)", path=path)
    r = data["diameter"] / 2.0
    _check_values(path, x3, r, lambda k: int(data["line"][k]))
    notes = _data_notes(data)
    # granpack's 2D data files have z = 0; any constant z is 2D, as in a dump
    d = _choose_dim(path, x3, True, dim)
    lo, hi = data["box"]
    # LAMMPS keeps the boundary flags in the input script, not the data file: the
    # container is known only from granpack's tag on the title line
    title = _head(path, 4096).decode("utf-8-sig", errors="replace").partition("\n")[0]
    tag = parse_container_tag(title, path, 1, d)
    return ParticleFile(
        path=path,
        format="lammps-data",
        positions=x3[:, :d],
        radii=r,
        ids=ids,
        box=(lo[:d], hi[:d]),
        notes=notes,
        **_tag_fields(tag, d),
    )


def _data_notes(data: dict) -> tuple[str, ...]:
    """What the data reader assumed: the atom style where the file names none, and
    positions kept as written where the rows carry image flags."""
    notes = []
    if data["style"] is None:
        notes.append(
            "the Atoms section names no atom style: read as atom_style sphere (id type "
            "diameter density x y z)"
        )
    moved = int(np.count_nonzero(np.any(data["image"] != 0, axis=1)))
    if moved:
        notes.append(
            f"{moved} atom{'s' if moved > 1 else ''} with non-zero image flags: positions "
            "read as written (inside the box), not unwrapped"
        )
    return tuple(notes)


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


def _read_xyzr(path: Path, dim: int | None) -> ParticleFile:
    from .analysis import read_xyzr

    x, r, d = read_xyzr(path, dim=dim)
    return ParticleFile(path=path, format="xyzr", positions=x, radii=r)


def _read_yade(path: Path, dim: int | None) -> ParticleFile:
    """YADE's text export: the ``#format`` header names the columns."""
    lines = _read_text(path).splitlines()
    k0 = next((k for k, ln in enumerate(lines) if ln.strip()), None)
    head = _YADE_HEADER.match(lines[k0].strip()) if k0 is not None else None
    if head is None or head.group(1) not in YADE_LAYOUTS:
        found = repr(lines[k0].strip()[:60]) if k0 is not None else "an empty file"
        raise FileFormatError(
            f"{path}:{(k0 or 0) + 1}: expected a YADE header '#format <layout>' with a layout "
            f"of {', '.join(YADE_LAYOUTS)}, found {found}",
            path=path,
        )
    assert k0 is not None  # a header was matched
    layout = head.group(1)
    names = layout.split("_")
    ncol = len(names)
    rows: list[list[float]] = []
    row_line: list[int] = []
    for k in range(k0 + 1, len(lines)):
        body = lines[k].split("#", 1)[0].split()
        if not body:
            continue
        if len(body) != ncol:
            raise FileFormatError(
                f"{path}:{k + 1}: expected {ncol} numbers ({' '.join(names)}, as the header "
                f"'#format {layout}' says), found {len(body)} fields",
                path=path,
            )
        bad = next((v for v in body if not is_number(v)), None)
        if bad is not None:
            raise FileFormatError(f"{path}:{k + 1}: {bad!r} is not a number", path=path)
        rows.append([float(v) for v in body])
        row_line.append(k + 1)
    if not rows:
        raise FileFormatError(f"{path}: no spheres after the header '#format {layout}'", path=path)
    a = np.array(rows, dtype=np.float64)
    x3 = a[:, [names.index(c) for c in ("x", "y", "z")]]
    r = a[:, names.index("r")]
    ids = None
    order = np.arange(len(rows))
    if "id" in names:
        ids = _integer_ids(path, a[:, names.index("id")], lambda k: row_line[k])
        order = _sorted_by_id(path, ids, lambda k: row_line[k])
        ids, x3, r = ids[order], x3[order], r[order]
    _check_values(path, x3, r, lambda k: row_line[int(order[k])])
    d = _choose_dim(path, x3, True, dim)
    tag = _comment_tag(path, lines, d)
    return ParticleFile(
        path=path, format="yade", positions=x3[:, :d], radii=r, ids=ids, **_tag_fields(tag, d)
    )


def _xyz_frames(path: Path, lines: list[str]) -> list[int]:
    """The count line (0-based) of every frame of an extended XYZ file: a count, a comment
    line, then that many rows, repeated. Every frame's structure is checked, so that a
    truncated file is refused whichever frame is asked for."""
    starts: list[int] = []
    i = 0
    while i < len(lines):
        count = lines[i].strip()
        if not count:  # blank lines between frames and at the end
            i += 1
            continue
        if not (count.isascii() and count.isdigit()):
            what = (
                "the particle count (an integer)"
                if not starts
                else f"the particle count of frame {len(starts)} (an integer) or the end of "
                f"the file after the {int(lines[starts[-1]])} rows of the frame at line "
                f"{starts[-1] + 1}"
            )
            raise FileFormatError(
                f"{path}:{i + 1}: expected {what}, found {count[:60]!r}", path=path
            )
        n = int(count)
        if i + 1 >= len(lines):
            raise FileFormatError(
                f"{path}:{i + 2}: expected the comment line with Properties=, found the end of "
                "the file",
                path=path,
            )
        if i + 2 + n > len(lines):
            raise FileFormatError(
                f"{path}:{len(lines) + 1}: expected {n} particle rows after line {i + 2} (line "
                f"{i + 1} says {n}), found {len(lines) - i - 2}: a truncated file",
                path=path,
            )
        starts.append(i)
        i += 2 + n
    if not starts:
        raise FileFormatError(
            f"{path}:1: expected the particle count (an integer), found an empty file", path=path
        )
    return starts


def _xyz_numbers(path: Path, line: int, key: str, value: str, count: int) -> np.ndarray:
    """The `count` finite numbers of the comment line's ``key="..."``, or a
    FileFormatError naming the key (the comment is line `line`)."""
    words = value.split()
    if len(words) != count or not all(is_number(w) for w in words):
        raise FileFormatError(
            f'{path}:{line}: expected {key}="..." with {count} numbers, found {value!r}',
            path=path,
        )
    a = np.array(words, dtype=np.float64)
    if not np.all(np.isfinite(a)):
        raise FileFormatError(
            f'{path}:{line}: expected {key}="..." with {count} finite numbers, found {value!r}',
            path=path,
        )
    return a


#: The extended XYZ booleans (pbc)
_XYZ_TRUE = ("T", "TRUE")
_XYZ_FALSE = ("F", "FALSE")


def _read_extxyz(path: Path, snapshot: int, dim: int | None) -> ParticleFile:
    """Extended XYZ, one or more frames, each: the count, the comment line with
    ``Properties=`` (and optionally an orthogonal ``Lattice``, ``Origin``, ``pbc``), then
    the rows. Frame `snapshot` is read (-1: the last), as a dump's snapshot."""
    import shlex

    lines = _read_text(path).splitlines()
    starts = _xyz_frames(path, lines)
    n_frames = len(starts)
    if not -n_frames <= snapshot < n_frames:
        raise FileFormatError(
            f"{path}: snapshot = {snapshot} is out of range: the file holds {n_frames} "
            f"frame{'s' if n_frames > 1 else ''} (0 to {n_frames - 1}, or -{n_frames} to -1)",
            path=path,
            reason="snapshot out of range",
        )
    k_frame = snapshot % n_frames
    b = starts[k_frame]  # the frame's count line (0-based); its comment is line b + 2
    n = int(lines[b])
    if n == 0:
        raise FileFormatError(
            f"{path}:{b + 1}: frame {k_frame} holds no particles (count 0)", path=path
        )
    c = b + 2
    try:
        words = shlex.split(lines[b + 1])
    except ValueError as exc:
        raise FileFormatError(
            f"{path}:{c}: cannot read the comment line: {exc}", path=path
        ) from None
    info = {}
    for w in words:
        if "=" in w:
            key, value = w.split("=", 1)
            info[key.lower()] = value
    spec = info.get("properties", "").split(":")
    if len(spec) % 3 or not spec[0]:
        raise FileFormatError(
            f"{path}:{c}: expected Properties=name:type:count:..., found "
            f"{info.get('properties', 'none')!r}",
            path=path,
        )
    cols: dict[str, tuple[int, int]] = {}
    at = 0
    for k in range(0, len(spec), 3):
        name, kind, count = spec[k].lower(), spec[k + 1], spec[k + 2]
        if not (count.isascii() and count.isdigit() and int(count) >= 1):
            raise FileFormatError(
                f"{path}:{c}: property {spec[k]!r} has count {count!r} (expected an integer >= 1)",
                path=path,
            )
        if kind.upper() not in ("S", "R", "I", "L"):
            raise FileFormatError(
                f"{path}:{c}: property {spec[k]!r} has type {kind!r} (expected S, R, I or L)",
                path=path,
            )
        if name in cols:
            raise FileFormatError(
                f"{path}:{c}: property {spec[k]!r} named twice in Properties", path=path
            )
        cols[name] = (at, int(count))
        at += int(count)
    missing = [name for name in ("pos", "radius") if name not in cols]
    if missing or cols["pos"][1] not in (2, 3) or cols["radius"][1] != 1:
        raise FileFormatError(
            f"{path}:{c}: missing propert{'ies' if len(missing) > 1 else 'y'} "
            f"{' and '.join(missing) or 'pos with 2 or 3 components and radius with 1'} in "
            "Properties (expected pos:R:3 and radius:R:1)",
            path=path,
            reason="missing columns",
        )
    rows = [ln.split() for ln in lines[b + 2 : b + 2 + n]]
    for k, t in enumerate(rows):
        if len(t) != at:
            raise FileFormatError(
                f"{path}:{c + k + 1}: expected {at} values (Properties), found {len(t)}",
                path=path,
            )
    p0, pn = cols["pos"]
    r0 = cols["radius"][0]
    num = [[t[j] for j in (*range(p0, p0 + pn), r0)] for t in rows]
    for k, t in enumerate(num):
        bad = next((v for v in t if not is_number(v)), None)
        if bad is not None:
            raise FileFormatError(f"{path}:{c + k + 1}: {bad!r} is not a number", path=path)
    a = np.array(num, dtype=np.float64).reshape(n, pn + 1)
    x3 = np.zeros((n, 3))
    x3[:, :pn] = a[:, :pn]
    r = a[:, pn]
    _check_values(path, x3, r, lambda k: c + k + 1)
    d = _choose_dim(path, x3, pn == 3, dim)
    box = None
    if "origin" in info:
        o = _xyz_numbers(path, c, "Origin", info["origin"], 3)
    else:
        o = np.zeros(3)
    if "lattice" in info:
        m = _xyz_numbers(path, c, "Lattice", info["lattice"], 9).reshape(3, 3)
        if np.any(m != np.diag(np.diag(m))):
            raise FileFormatError(
                f'{path}:{c}: a non-orthogonal cell (Lattice="{info["lattice"]}"); only '
                "orthogonal cells are read",
                path=path,
            )
        if np.any(np.diag(m)[:d] <= 0.0):
            raise FileFormatError(
                f'{path}:{c}: expected Lattice="..." with cell lengths > 0 along the '
                f"{d} axes of the particles, found {info['lattice']!r}",
                path=path,
            )
        box = (o[:d], (o + np.diag(m))[:d])
    periodic = None
    if "pbc" in info:
        pbc = info["pbc"].upper().split()
        if len(pbc) != 3 or not all(v in _XYZ_TRUE + _XYZ_FALSE for v in pbc):
            raise FileFormatError(
                f'{path}:{c}: expected pbc="..." with three of T, F (or True, False), '
                f"found {info['pbc']!r}",
                path=path,
            )
        periodic = tuple(v in _XYZ_TRUE for v in pbc[:d])
    notes: tuple[str, ...] = ()
    if n_frames > 1:
        notes = (f"frame {k_frame} of {n_frames} read (counted from 0)",)
    # the lattice and pbc say the box and the periodic axes; granpack's tag adds a cylinder
    tag = parse_container_tag(info.get("granpack", ""), path, c, d)
    extra: dict = {}
    if tag is not None:
        extra = {"container": tag.kind, "cylinder_radius": tag.cylinder_radius}
        if tag.kind == "periodic" and not (periodic and any(periodic[: d - 1])):
            periodic = (True,) * (d - 1)
    return ParticleFile(
        path=path,
        format="xyz",
        positions=x3[:, :d],
        radii=r,
        box=box,
        periodic=periodic,
        snapshot=k_frame,
        n_snapshots=n_frames,
        notes=notes,
        **extra,
    )


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
        if s.dtype == pl.String:  # CSV: every column is read as text
            s = s.str.strip_chars()
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
        ids = _integer_ids(path, column(i_id), where)
        order = _sorted_by_id(path, ids, where)
        ids, x3, r = ids[order], x3[order], r[order]
        _check_values(path, x3, r, lambda k: where(int(order[k])))
    else:
        _check_values(path, x3, r, where)
    d = _choose_dim(path, x3, has_z, dim)
    if fmt == "csv":
        tag = _comment_tag(path, _read_text(path).splitlines(), d)
    else:
        tag = _parquet_tag(path, d)
    return ParticleFile(
        path=path, format=fmt, positions=x3[:, :d], radii=r, ids=ids, **_tag_fields(tag, d)
    )


def _parquet_tag(path: Path, d: int) -> ContainerTag | None:
    """The container tag in a Parquet file's key-value metadata (key ``granpack``)."""
    import polars as pl

    try:
        meta = pl.read_parquet_metadata(path)
    except (OSError, pl.exceptions.PolarsError, ValueError):
        return None
    text = meta.get("granpack")
    return None if text is None else parse_container_tag(text, path, 0, d)
