"""LAMMPS and LIGGGHTS: ``dump custom`` files (read), data files for ``atom_style sphere``
(read and written; `write_data`'s image flags and Velocities read), and the input that
continues a run (`granpack.io.lammps_input`)."""

from __future__ import annotations

import io
import math
import re
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .._files import atomic_write
from .._validate import (
    FileFormatError,
    InvalidParameterError,
    is_number,
)
from ..analysis.container import Container
from ..history import stage_table
from .lammps_input import SNIPPET_NAME, lammps_input, liggghts_input

if TYPE_CHECKING:
    from ..pack import Pack

from ._text import (
    _ID_NAMES,
    _check_values,
    _choose_dim,
    _column_table,
    _frame_index,
    _integer_ids,
    _pad3,
    _pick,
    _read_text_cut,
    _rows_text,
    _sorted_by_id,
    _tag_fields,
    _text_digits,
    lammps_positions,
    scan_complete_dump,
)
from .particle_file import ParticleFile

# The column suffixes of one axis in a dump, in order of preference: plain, unwrapped,
# scaled, scaled unwrapped (LAMMPS' names), and whether each is a fraction of the box.
_DUMP_COORD_KINDS = (("", False), ("u", False), ("s", True), ("su", True))


_DATA_HEADER = re.compile(r"^\s*\d+\s+atoms\s*(#.*)?$", re.MULTILINE)


def read_dump(path: Path, snapshot: int, dim: int | None) -> ParticleFile:
    text, cut = _read_text_cut(path)
    lines = text.splitlines()
    snaps, short = scan_complete_dump(path, lines, cut=cut)
    n_snap = len(snaps)
    k_snap = _frame_index(path, snapshot, n_snap, "dump", "snapshot")
    s = snaps[k_snap]
    assert s.names is not None and s.n is not None and s.bounds is not None
    atoms_line, names = s.first - 1, s.names
    header = f"{path}:{atoms_line + 1}"

    # each axis from its own column: x (else xu, else the scaled xs, xsu); LAMMPS writes
    # whatever columns dump custom names, so x y with a scaled zs is a valid dump
    cols_ax: list[int | None] = []
    scaled_ax: list[bool] = []
    for ax in "xyz":
        found = [
            (c, sc)
            for tail, sc in _DUMP_COORD_KINDS
            if (c := _pick(names, (ax + tail,))) is not None
        ]
        cols_ax.append(found[0][0] if found else None)
        scaled_ax.append(bool(found) and found[0][1])
    if cols_ax[0] is None or cols_ax[1] is None:
        raise FileFormatError(
            f"{header}: missing columns: expected x y (z), xu yu (zu) or scaled xs ys (zs) "
            f"in 'ITEM: ATOMS', found {' '.join(names)}",
            path=path,
            reason="missing coordinate columns",
        )
    coord = (cols_ax[0], cols_ax[1], cols_ax[2])
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
    want = [c for c in (*coord, i_rad if i_rad is not None else i_dia) if c is not None]
    if i_id is not None:
        want.append(i_id)
    fast = _column_table(lines[first : first + s.n], ncol, want)
    table = [] if fast is not None else [row.split() for row in lines[first : first + s.n]]
    for j, t in enumerate(table):
        if len(t) != ncol:
            raise FileFormatError(
                f"{path}:{first + j + 1}: expected {ncol} values ({' '.join(names)}), found "
                f"{len(t)}",
                path=path,
            )
    try:
        a = (
            fast
            if fast is not None
            else np.array([[t[c] for c in want] for t in table], dtype=np.float64).reshape(
                s.n, len(want)
            )
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
    for k_ax in range(nc):
        if scaled_ax[k_ax]:  # fractions of the box
            x3[:, k_ax] = lo[k_ax] + x3[:, k_ax] * (hi[k_ax] - lo[k_ax])
    r = a[:, nc] if i_rad is not None else a[:, nc] / 2.0
    ids = None
    order = np.arange(s.n)

    def where(k: int) -> int:
        return first + int(order[k]) + 1

    if i_id is not None:
        ids = _integer_ids(
            path,
            a[:, -1],
            lambda k: first + k + 1,
            lambda: [ln.split()[i_id] for ln in lines[first : first + s.n]],
        )
        order = _sorted_by_id(path, ids, lambda k: first + k + 1)
        ids = ids[order]
        x3, r = x3[order], r[order]
    _check_values(path, x3, r, where)

    notes: list[str] = [] if short is None else [short]
    if len(set(scaled_ax[:nc])) > 1:
        kinds = ", ".join(
            f"{names[c]} ({'a fraction of the box' if sc else 'm'})"
            for c, sc in zip(coord[:nc], scaled_ax[:nc], strict=False)
            if c is not None
        )
        notes.append(f"coordinates from scaled and unscaled columns: {kinds}")
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
    rad_col = i_rad if i_rad is not None else i_dia
    digits = _text_digits(
        lines[first : first + s.n], [c for c in (*coord, rad_col) if c is not None]
    )
    return ParticleFile(
        path=path,
        format="lammps-dump",
        digits=digits,
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


def read_data(path: Path, dim: int | None) -> ParticleFile:
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
    tag = Container.read_tag(data["title"], path, 1, d)
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


def lammps_density(pack: Pack) -> np.ndarray:
    """(N,) density column (kg/m^3) that makes LAMMPS' mass = density 4/3 pi r^3 equal
    granpack's mass."""
    s = pack.scene
    rho = s.material.density
    r = np.asarray(pack.radii, dtype=np.float64)
    if s.dim == 2 and s.inertia_2d == "disc":
        # unit-thickness disc: m = rho pi r^2
        return rho * (math.pi * r**2) / (4.0 / 3.0 * math.pi * r**3)
    return np.full(r.shape, rho)


def input_text(pack: Pack, data_name: str, code: str) -> str:
    """The text of ``in.granpack`` for `code` ("lammps" or "liggghts") reading the data
    file `data_name` (see `granpack.io.lammps_input`)."""
    if code == "lammps":
        return lammps_input(pack, data_name)
    if code == "liggghts":
        return liggghts_input(pack, data_name)
    raise InvalidParameterError(
        f"invalid code = {code!r}: must be 'lammps' or 'liggghts'", parameter="code", value=code
    )


def write_lammps(pack: Pack, path: str | Path) -> Path:
    """Writes a LAMMPS/LIGGGHTS data file for ``atom_style sphere`` (SI units; read it
    with ``units si``, ``atom_style sphere`` and ``read_data``; 2D needs
    ``dimension 2`` and ``boundary f f p``). The box's vertical bounds are the floor and
    the pack's height, the lid's height for a consolidated pack. Returns the path.
    `export` also writes the input ``in.granpack`` beside it (`input_text`)."""
    path = Path(path)
    s = pack.scene
    n = len(pack)
    x = lammps_positions(pack)
    d = 2.0 * np.asarray(pack.radii, dtype=np.float64)
    rho = lammps_density(pack)
    v = _pad3(pack.velocities)
    w = _pad3(pack.spins)
    container = Container.of_pack(pack)
    top = pack.height
    rec = stage_table(pack, "consolidate")
    if rec is not None:
        # a consolidated pack: the box is the walls' (the sides at 0 and base, where the
        # consolidation left them), closed at the lid
        top = float(rec["walls"]["lid"])
    if s.dim == 3:
        bounds = [(0.0, s.base[0]), (0.0, s.base[1]), (0.0, top)]
    else:
        half = float(np.max(pack.radii)) if n else float(s.r_max or 0.0)
        bounds = [(0.0, s.base[0]), (0.0, top), (-half, half)]
    mass = ""
    if s.dim == 2:
        mass = f", mass convention {s.inertia_2d}" + (
            " (disc of unit thickness: m = pi r^2 rho)"
            if s.inertia_2d == "disc"
            else " (sphere: m = 4/3 pi r^3 rho)"
        )
    # the container tag (`Container.tag_words`): read_particles analyses the file in it
    where = ", " + container.tag_words(corners=False)
    # A particle touching the top sits exactly on H_top; nothing is outside the box.
    out = io.StringIO()
    out.write(
        f"LAMMPS data file from granpack: dim={s.dim} N={n} seed={s.seed} "
        f"stream={s.stream} rotations={'on' if s.rotations else 'off'} (SI units, "
        f"atom_style sphere{', dimension 2, vertical y' if s.dim == 2 else ', vertical z'}"
        f"{mass}{where})\n\n"
    )
    out.write(f"{n} atoms\n1 atom types\n\n")
    for (lo, hi), ax in zip(bounds, "xyz", strict=True):
        out.write(f"{lo!r} {hi!r} {ax}lo {ax}hi\n")
    out.write("\nAtoms # sphere\n\n")
    ids = np.arange(1, n + 1)
    out.write(_rows_text(ids, np.ones(n, dtype=np.int64), d, rho, x[:, 0], x[:, 1], x[:, 2]))
    out.write("\nVelocities\n\n")
    out.write(_rows_text(ids, v[:, 0], v[:, 1], v[:, 2], w[:, 0], w[:, 1], w[:, 2]))
    return atomic_write(path, out.getvalue().encode())


# a row whose integer columns are written as integers (an id "1.0" is not one)
_INT_WORD = r"[-+]?[0-9]+"


def _data_rows(
    lines: list[str], rows: list[int], ncol: int, integers: tuple[int, ...]
) -> np.ndarray | None:
    """The section rows `rows` as an (n, ncol) float64 table in one pass of numpy's
    reader, where every row holds `ncol` finite numbers and the columns `integers` are
    written as integers within 2**53; None otherwise, so that the row-by-row reading runs
    and names the row at fault."""
    block = [lines[k] for k in rows]
    a = _column_table(block, ncol, list(range(ncol)))
    if a is None or not np.all(np.isfinite(a)):
        return None
    ints = a[:, list(integers)]
    if np.any(np.abs(ints) >= 2.0**53):
        return None
    # the integer columns' text: a compiled pattern over each row (the rows were read
    # as numbers already, so only the form of those columns is left to check)
    pattern = re.compile(
        r"^\s*" + r"\s+".join(_INT_WORD if c in integers else r"\S+" for c in range(ncol)) + r"\s*$"
    )
    if not all(pattern.match(row) for row in block):
        return None
    return a


def read_lammps_data(path: str | Path) -> dict:
    """Reads the particles of a LAMMPS data file for ``atom_style sphere``, as granpack's
    export and LAMMPS' ``write_data`` write it.

    The header takes the lines LAMMPS writes (``N atoms``, ``N atom types`` and the other
    counts, ``xlo xhi``, ``ylo yhi``, ``zlo zhi``; ``xy xz yz`` only with zero tilts).
    Atoms rows are ``id type diameter density x y z``, optionally followed by the three
    integer image flags ``ix iy iz``; the positions are kept as written (inside the box,
    the flags are not applied). Velocities rows are ``id vx vy vz wx wy wz``. Other
    sections (Masses, Pair Coeffs, ...) are skipped.

    Returns a dict of arrays sorted by atom id: ``id``, ``type``, ``diameter``,
    ``density``, ``positions`` (N, 3), ``image`` (N, 3; zeros when the rows have no image
    flags), ``velocities`` and ``spins`` (N, 3; zeros when the file has no Velocities
    section), ``line`` (the file line of each atom, 1-based), ``box`` ((lo, hi) corners,
    3 each; LAMMPS' default -0.5 0.5 for an axis the header leaves out), ``style`` (the
    atom style the Atoms line's comment names, None without one) and ``title`` (the first
    line).

    Raises
    ------
    FileFormatError
        The file cannot be read as a data file for ``atom_style sphere``; the message names
        the line and what was expected there: an Atoms section for another atom style
        (``Atoms # hybrid sphere ...``), rows of another length, a value that is not a
        number (or not finite, or not an integer where LAMMPS wants one), a triclinic box,
        a count that the sections do not match, a repeated id.
    """
    from .._validate import is_number

    path = Path(path)
    try:
        # utf-8-sig: a byte-order mark (as Windows editors write one) is not text
        text = path.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise FileFormatError(
            f"cannot read LAMMPS data file {path}: no such file", path=path, reason="no such file"
        ) from None
    except UnicodeDecodeError as exc:
        raise FileFormatError(
            f"cannot read LAMMPS data file {path}: not a text file (byte {exc.start} is not UTF-8)",
            path=path,
        ) from None
    except OSError as exc:
        raise FileFormatError(
            f"cannot read LAMMPS data file {path}: {exc.strerror or exc}", path=path
        ) from None
    lines = text.splitlines()
    sphere = "atom_style sphere (id type diameter density x y z [ix iy iz])"

    def fail(k: int, what: str) -> FileFormatError:
        # k: 0-based line index; what: the expectation, stated for users
        found = repr(lines[k].strip()[:60]) if k < len(lines) else "the end of the file"
        return FileFormatError(f"{path}:{k + 1}: expected {what}, found {found}", path=path)

    def number(k: int, word: str, column: str) -> float:
        try:
            value = float(word)
        except ValueError:
            raise FileFormatError(
                f"{path}:{k + 1}: {column} {word!r} is not a number", path=path
            ) from None
        if not math.isfinite(value):
            raise FileFormatError(
                f"{path}:{k + 1}: {column} {word!r} is not a finite number", path=path
            )
        return value

    def integer(k: int, word: str, column: str) -> int:
        try:
            value = int(word)
        except ValueError:
            raise FileFormatError(
                f"{path}:{k + 1}: {column} {word!r} is not an integer", path=path
            ) from None
        if not -(2**63) <= value < 2**63:
            raise FileFormatError(
                f"{path}:{k + 1}: {column} {word} is out of range (64-bit integers)", path=path
            )
        return value

    if not lines or not text.strip():
        raise FileFormatError(
            f"{path}:1: expected a LAMMPS data file (a title line, then a header such as "
            "'12 atoms'), found an empty file",
            path=path,
        )
    n_atoms: int | None = None
    n_line = 0
    lo = np.full(3, -0.5)  # LAMMPS' default box, for an axis the header leaves out
    hi = np.full(3, 0.5)
    sections: dict[str, list[int]] = {"Atoms": [], "Velocities": []}
    section_line: dict[str, int] = {}
    style: str | None = None
    current: str | None = None  # None: the header
    for k in range(1, len(lines)):  # line 1 is the title
        line = lines[k]
        body = line.split("#", 1)[0].strip()
        if not body:
            continue
        words = body.split()
        # a section name is words, the first capitalised (Atoms, Pair Coeffs, Velocities)
        if words[0][0].isupper() and not is_number(words[0]):
            name = " ".join(words)
            if name in section_line and name in sections:
                raise FileFormatError(
                    f"{path}:{k + 1}: a second {name} section (the first is at line "
                    f"{section_line[name] + 1})",
                    path=path,
                )
            section_line[name] = k
            current = name if name in sections else "other"
            if name == "Atoms":
                comment = line.split("#", 1)[1].strip() if "#" in line else ""
                style = comment or None
                if style is not None and style.split()[0] != "sphere":
                    raise FileFormatError(
                        f"{path}:{k + 1}: the Atoms section is written for atom_style "
                        f"{style!r}; only {sphere} is read",
                        path=path,
                        reason=f"atom_style {style}",
                    )
            continue
        if current is None:  # a header line: a count and a keyword, or box bounds
            if words[-1] in ("avec", "bvec", "cvec") or words[-2:] == ["abc", "origin"]:
                raise FileFormatError(
                    f"{path}:{k + 1}: a general triclinic box ({body}); only orthogonal "
                    "boxes are read",
                    path=path,
                )
            if len(words) == 2 and words[1] == "atoms":
                try:
                    n_atoms = int(words[0])
                except ValueError:
                    n_atoms = -1
                if n_atoms < 0:
                    raise fail(k, "'N atoms' with N an integer >= 0")
                n_line = k
                continue
            axis = next(
                (a for a, ax in enumerate("xyz") if words[-2:] == [f"{ax}lo", f"{ax}hi"]), None
            )
            if axis is not None:
                ax = "xyz"[axis]
                if len(words) != 4:
                    raise fail(k, f"'{ax}lo {ax}hi' after two numbers")
                a = number(k, words[0], f"{ax}lo")
                b = number(k, words[1], f"{ax}hi")
                if not a < b:
                    raise fail(k, f"{ax}lo < {ax}hi")
                lo[axis], hi[axis] = a, b
                continue
            if words[-3:] == ["xy", "xz", "yz"]:
                if len(words) != 6:
                    raise fail(k, "three tilt factors before 'xy xz yz'")
                tilt = [number(k, w, t) for w, t in zip(words[:3], ("xy", "xz", "yz"), strict=True)]
                if any(t != 0.0 for t in tilt):
                    raise FileFormatError(
                        f"{path}:{k + 1}: a triclinic box (tilt factors xy xz yz = "
                        f"{' '.join(words[:3])}); only orthogonal boxes are read",
                        path=path,
                    )
                continue
            try:
                int(words[0])
            except ValueError:
                raise fail(
                    k,
                    "a header line (a count and a keyword, such as '12 atoms', or box "
                    "bounds such as '0 1 xlo xhi') or a section name such as 'Atoms'",
                ) from None
            if len(words) < 2:
                raise fail(k, "a keyword after the count (such as '12 atoms')")
            continue
        if current in sections:
            sections[current].append(k)

    if n_atoms is None:
        raise FileFormatError(
            f"{path}: no 'N atoms' line in the header: not a LAMMPS data file", path=path
        )
    rows = sections["Atoms"]
    if n_atoms > 0 and "Atoms" not in section_line:
        raise FileFormatError(
            f"{path}: no Atoms section (the header says {n_atoms} atoms at line {n_line + 1})",
            path=path,
        )
    if len(rows) != n_atoms:
        raise FileFormatError(
            f"{path}:{section_line['Atoms'] + 1}: the header says {n_atoms} atoms (line "
            f"{n_line + 1}), the Atoms section has {len(rows)} rows: a truncated or "
            "inconsistent file",
            path=path,
        )
    names = ("id", "type", "diameter", "density", "x", "y", "z", "ix", "iy", "iz")
    ncol = len(lines[rows[0]].split("#", 1)[0].split()) if rows else 7
    if ncol not in (7, 10):
        raise FileFormatError(
            f"{path}:{rows[0] + 1}: expected 7 values ({' '.join(names[:7])}) or 10 (with "
            f"the image flags ix iy iz) in an Atoms row of {sphere}, found {ncol}",
            path=path,
        )
    ids = np.zeros(n_atoms, dtype=np.int64)
    types = np.zeros(n_atoms, dtype=np.int64)
    atoms = np.zeros((n_atoms, 5))  # diameter density x y z
    image = np.zeros((n_atoms, 3), dtype=np.int64)
    fast = _data_rows(lines, rows, ncol, (0, 1, *range(7, ncol)))
    if fast is not None:
        ids, types = fast[:, 0].astype(np.int64), fast[:, 1].astype(np.int64)
        atoms = np.ascontiguousarray(fast[:, 2:7])
        if ncol == 10:
            image = fast[:, 7:10].astype(np.int64)
    for j, k in enumerate(rows if fast is None else ()):
        words = lines[k].split("#", 1)[0].split()
        if len(words) != ncol:
            raise FileFormatError(
                f"{path}:{k + 1}: expected {ncol} values ({' '.join(names[:ncol])}) as on "
                f"line {rows[0] + 1}, found {len(words)}",
                path=path,
            )
        ids[j] = integer(k, words[0], "atom id")
        types[j] = integer(k, words[1], "atom type")
        for c in range(2, 7):
            atoms[j, c - 2] = number(k, words[c], names[c])
        for c in range(7, ncol):
            image[j, c - 7] = integer(k, words[c], f"image flag {names[c]}")
    order = np.argsort(ids, kind="stable")
    dup = np.flatnonzero(ids[order][1:] == ids[order][:-1])
    if dup.size:
        a, b = sorted((rows[order[dup[0]]], rows[order[dup[0] + 1]]))
        raise FileFormatError(
            f"{path}:{b + 1}: atom id {ids[order[dup[0]]]} repeats the id of line {a + 1}; "
            "ids must be unique",
            path=path,
        )
    ids, types, atoms, image = ids[order], types[order], atoms[order], image[order]
    line_of = np.array(rows, dtype=np.int64)[order] + 1
    vel = np.zeros((n_atoms, 6))
    if "Velocities" in section_line:
        vrows = sections["Velocities"]
        if len(vrows) != n_atoms:
            raise FileFormatError(
                f"{path}:{section_line['Velocities'] + 1}: the header says {n_atoms} atoms "
                f"(line {n_line + 1}), the Velocities section has {len(vrows)} rows: a "
                "truncated or inconsistent file",
                path=path,
            )
        vfast = _data_rows(lines, vrows, 7, (0,))
        if vfast is not None:
            # every id once, and each an atom's: then the rows go to their atoms at once
            vid = vfast[:, 0].astype(np.int64)
            where = np.searchsorted(ids, vid)
            where = np.minimum(where, n_atoms - 1)
            if np.array_equal(np.sort(vid), ids) and np.array_equal(ids[where], vid):
                vel[where] = vfast[:, 1:]
            else:
                vfast = None
        at = {int(i): j for j, i in enumerate(ids)} if vfast is None else {}
        seen: dict[int, int] = {}
        vnames = ("id", "vx", "vy", "vz", "wx", "wy", "wz")
        for k in vrows if vfast is None else ():
            words = lines[k].split("#", 1)[0].split()
            if len(words) != 7:
                raise FileFormatError(
                    f"{path}:{k + 1}: expected 7 values ({' '.join(vnames)}) in a Velocities "
                    f"row of atom_style sphere, found {len(words)}",
                    path=path,
                )
            i = integer(k, words[0], "atom id")
            if i not in at:
                raise FileFormatError(
                    f"{path}:{k + 1}: Velocities row for atom id {i}, which the Atoms "
                    "section does not hold",
                    path=path,
                )
            if i in seen:
                raise FileFormatError(
                    f"{path}:{k + 1}: atom id {i} repeats the Velocities row of line {seen[i] + 1}",
                    path=path,
                )
            seen[i] = k
            vel[at[i]] = [number(k, w, c) for w, c in zip(words[1:], vnames[1:], strict=True)]
    return {
        "id": ids,
        "type": types,
        "diameter": atoms[:, 0],
        "density": atoms[:, 1],
        "positions": atoms[:, 2:5],
        "image": image,
        "velocities": vel[:, :3],
        "spins": vel[:, 3:],
        "line": line_of,
        "box": (lo, hi),
        "style": style,
        "title": lines[0],
    }


def _write_with_input(pack: Pack, path: str | Path, code: str) -> list[Path]:
    path = Path(path)
    # the input first: it refuses a 2D pack for LIGGGHTS before anything is written
    text = input_text(pack, path.name, code)
    return [write_lammps(pack, path), atomic_write(path.with_name(SNIPPET_NAME), text.encode())]


def write_lammps_files(pack: Pack, path: str | Path) -> list[Path]:
    """The data file at `path` and ``in.granpack`` beside it, the LAMMPS input that
    continues the run (`granpack.io.lammps_input`)."""
    return _write_with_input(pack, path, "lammps")


def write_liggghts_files(pack: Pack, path: str | Path) -> list[Path]:
    """The data file at `path` and ``in.granpack`` beside it, the LIGGGHTS input (3D)."""
    return _write_with_input(pack, path, "liggghts")
