"""Contact forces from other codes: :func:`read_contacts`.

LAMMPS and LIGGGHTS write the forces of every contact with ``dump local``. Read together
with the particles of the same timestep (:func:`granpack.read_particles`), they give a
pack from another code the whole microstructure: fabric, f0, a^n and a^t.

The two layouts read (``docs/interop.md`` gives the commands that write them):

- ``"liggghts"``: LIGGGHTS ``compute pair/gran/local pos id force`` (12 columns: the two
  positions, the two ids and the periodic flag, the force on the first particle);
  ``"liggghts-full"`` adds ``force_normal force_tangential delta`` (19 columns);
- ``"lammps"``: LAMMPS ``compute property/local patom1 patom2`` and ``compute pair/local
  fx fy fz p1 p2 p3`` of ``pair_style granular``, in one ``dump local`` (8 columns: the
  two ids, the normal force on the first particle, its tangential force).

Other layouts are given column by column (`columns`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .._validate import FileFormatError, InvalidParameterError, is_number, short_repr
from ..analysis.inputs import check_contacts_touch, verge_note
from ..contacts import Contacts
from ._text import (
    DumpBlock,
    _frame_index,
    _integer_ids,
    _read_text_cut,
    as_path,
    scan_complete_dump,
)
from .particle_file import ParticleFile

__all__ = ["LAYOUTS", "COLUMN_NAMES", "ContactFile", "read_contacts"]

#: What a column may hold: the two particle ids, the force on the first particle
#: (fx fy fz: all of it; fnx.. its normal part; ftx.. its tangential part, N), and
#: "-" for a column that is not read.
COLUMN_NAMES = ("id1", "id2", "fx", "fy", "fz", "fnx", "fny", "fnz", "ftx", "fty", "ftz", "-")

_POS = ["-"] * 6
#: The layouts read by name, and the columns each holds.
LAYOUTS: dict[str, tuple[str, ...]] = {
    # compute pair/gran/local pos id force
    "liggghts": (*_POS, "id1", "id2", "-", "fx", "fy", "fz"),
    # compute pair/gran/local pos id force force_normal force_tangential delta
    "liggghts-full": (
        *_POS,
        *("id1", "id2", "-", "fx", "fy", "fz", "fnx", "fny", "fnz", "ftx", "fty", "ftz", "-"),
    ),
    # property/local patom1 patom2, then pair/local fx fy fz p1 p2 p3 (pair granular)
    "lammps": ("id1", "id2", "fnx", "fny", "fnz", "ftx", "fty", "ftz"),
}
# A layout found by its column count alone, where that count is unambiguous.
_BY_COUNT = {len(v): k for k, v in LAYOUTS.items()}


class ContactFile:
    """The contacts of one ``dump local`` snapshot, matched to particles.

    Attributes
    ----------
    path : Path
    layout : str
        The layout read: a name of `LAYOUTS`, or "columns" for columns given one by one.
    contacts : granpack.Contacts
        Particle-particle contacts, indices into the particles' rows (as
        ``ParticleFile.positions``), i the first particle of each row; normals and
        branches from the particles' positions; f_n and f_t from the file's forces.
    timestep : int or None
        The snapshot's ``TIMESTEP`` (None for a plain table).
    snapshot, n_snapshots : int
        Which snapshot was read (0-based) and how many the file holds.
    notes : tuple of str
        What the reader changed or assumed (repeated pairs dropped, attractive normal
        forces set to 0, ids taken as 1..N, verge contacts counted).
    carries_force : (M,) bool
        Whether the file gives each contact a force (any component nonzero, before an
        attractive normal force is set to 0).
    """

    def __init__(self, path, layout, contacts, timestep, snapshot, n_snapshots, notes):
        self.carries_force = None
        self.path = path
        self.layout = layout
        self.contacts = contacts
        self.timestep = timestep
        self.snapshot = snapshot
        self.n_snapshots = n_snapshots
        self.notes = notes

    def __len__(self) -> int:
        return len(self.contacts)

    def __repr__(self) -> str:
        return (
            f"ContactFile({str(self.path)!r}, layout={self.layout!r}, contacts={len(self)}, "
            f"timestep={self.timestep})"
        )


def _columns(layout, columns) -> tuple[str, tuple[str, ...] | None]:
    if columns is not None:
        if layout is not None:
            raise InvalidParameterError(
                "give layout or columns, not both", parameter="columns", value=columns
            )
        cols = tuple(columns.split()) if isinstance(columns, str) else tuple(columns)
        bad = [c for c in cols if c not in COLUMN_NAMES]
        has_force = {"fx", "fy", "fz"} <= set(cols) or {"fnx", "fny", "fnz"} <= set(cols)
        if bad or "id1" not in cols or "id2" not in cols or not has_force:
            raise InvalidParameterError(
                f"invalid columns = {short_repr(columns)}: each one of {', '.join(COLUMN_NAMES)}"
                ", with id1, id2 and either fx fy fz or fnx fny fnz (with ftx fty ftz)",
                parameter="columns",
                value=columns,
            )
        return "columns", cols
    if layout is None:
        return "", None
    if layout not in LAYOUTS:
        raise InvalidParameterError(
            f"invalid layout = {short_repr(layout)}: must be one of {', '.join(LAYOUTS)} "
            "(or None to tell it from the column count)",
            parameter="layout",
            value=layout,
        )
    return layout, LAYOUTS[layout]


def _plain_table(path: Path, lines: list[str], ncol: int) -> DumpBlock:
    """A plain table of contacts (what a YADE script writes from ``O.interactions``): `#`
    comment lines, then one contact a line, as one snapshot without a timestep."""
    b = DumpBlock(0)
    first = next(
        (k for k, ln in enumerate(lines) if ln.strip() and not ln.lstrip().startswith("#")), None
    )
    if first is None:
        raise FileFormatError(f"{path}: no contacts (only comments or blank lines)", path=path)
    end = len(lines)
    while end > first and not lines[end - 1].strip():
        end -= 1
    b.first, b.n, b.names = first, end - first, ["-"] * ncol
    return b


def read_contacts(
    path,
    particles: ParticleFile,
    *,
    layout: str | None = None,
    columns=None,
    snapshot: int | None = None,
) -> ContactFile:
    """Reads the contact forces a LAMMPS or LIGGGHTS ``dump local`` file holds.

    Parameters
    ----------
    path : str or Path
        The dump local file.
    particles : granpack.ParticleFile
        The particles of the same moment (:func:`granpack.read_particles` of a dump, a
        data file or a pack); the contacts' ids are looked up among ``particles.ids``.
        Particles without ids (text, a granpack pack) are taken as ids 1..N in their
        order, the numbering of granpack's LAMMPS export.
    layout : str, optional
        One of `LAYOUTS` ("liggghts", "liggghts-full", "lammps"). Default None: told
        from the number of columns (12, 19 and 8).
    columns : str or sequence of str, optional
        Instead of `layout`: what each column holds, one of `COLUMN_NAMES` each (such as
        ``"id1 id2 fx fy fz"``), for a dump local of other columns, or for a plain table
        (``#`` comment lines, then one contact a line), such as YADE's interactions
        written by a script (``"id2 id1 fnx fny fnz ftx fty ftz"``: YADE's forces act on
        id2).
    snapshot : int, optional
        Which snapshot (0 the first, -1 the last). Default None: the snapshot with the
        particles' timestep where both are known, else the last.

    Returns
    -------
    ContactFile
        Its `contacts` go to ``gp.microstructure`` with the particles:
        ``gp.microstructure(particles.with_contacts(c.contacts))``.

    Notes
    -----
    The normal n of each contact points from the first particle to the second, from the
    particles' positions (the branch vector; the minimum image across a periodic side
    of the particles' box). The file gives the force F on the first particle (its
    normal and tangential parts, or their sum); then f_n = -F . n and the tangential
    force on the second particle is f_t = -(F - (F . n) n). A net attractive f_n (the
    damping of a separating pair) is set to 0, as granpack's own law clamps it; the
    notes count such contacts. A pair listed twice (LAMMPS and LIGGGHTS list a pair
    across a periodic side once for each of its particles) is read once, and a pair with
    neither overlap nor force (LAMMPS' pair/local without ``cutoff radius`` lists every
    pair within the force cutoff) is left out under the named layouts, as LAMMPS counts
    only overlapping pairs; a table given by `columns` is counted as its code lists it,
    pairs at zero force on the verge of contact included (YADE keeps them in its list),
    with a note. Wall contacts are not in these dumps: the analysis then counts none. A
    dump whose last snapshot stops short (a file still being written) is read up to its
    last complete one, with a note; gzip-compressed files are read; ids of 2**53 and
    above are matched exactly.

    Raises
    ------
    FileFormatError
        Naming the line: a truncated dump, a row of the wrong length, a value that is not
        a number, an id that none of the particles has, a pair of a particle with itself,
        a snapshot of another timestep than the particles', a column count that names no
        layout; a pair whose particles do not touch (ids of another run, step or
        numbering): their centres farther apart than r_i + r_j by more than 1e-6 of the
        smaller radius (1e-2 for a pair at zero force) plus what the printed precision
        of the positions allows (their file's digits, at least six), named with its ids
        and the gap.
    InvalidParameterError
        A bad `layout`, `columns` or `snapshot`.
    """
    path = as_path(path)
    if not isinstance(particles, ParticleFile):
        raise InvalidParameterError(
            f"invalid particles = {type(particles).__name__}: expected the result of "
            "granpack.read_particles",
            parameter="particles",
        )
    name, cols = _columns(layout, columns)
    if snapshot is not None and (
        isinstance(snapshot, bool) or not isinstance(snapshot, int | np.integer)
    ):
        raise InvalidParameterError(
            f"invalid snapshot = {short_repr(snapshot)}: must be an integer or None",
            parameter="snapshot",
            value=snapshot,
        )
    text, cut = _read_text_cut(path)
    lines = text.splitlines()
    first_word = next((ln.split()[0] for ln in lines if ln.strip()), "")
    if first_word.startswith("ITEM:") or cols is None or name != "columns":
        blocks, short = scan_complete_dump(path, lines, local=True, cut=cut)
    else:
        blocks, short = [_plain_table(path, lines, len(cols))], None
    n_snap = len(blocks)
    want_step = particles.timestep
    if snapshot is None:
        k_snap = n_snap - 1
        if want_step is not None:
            k_snap = next((k for k, b in enumerate(blocks) if b.timestep == want_step), n_snap - 1)
    else:
        k_snap = _frame_index(path, int(snapshot), n_snap, "dump", "snapshot")
    b = blocks[k_snap]
    assert b.names is not None and b.n is not None
    if want_step is not None and b.timestep is not None and b.timestep != want_step:
        raise FileFormatError(
            f"{path}:{b.start + 2}: the contacts are of timestep {b.timestep}, the particles "
            f"({particles.path}) of timestep {want_step}: write both at the same step",
            path=path,
        )
    ncol = len(b.names)
    if cols is None:
        if ncol not in _BY_COUNT:
            raise FileFormatError(
                f"{path}:{b.first}: {ncol} columns ({' '.join(b.names)}) name none of the "
                "layouts read ("
                + ", ".join(f"{k}: {len(v)} columns" for k, v in LAYOUTS.items())
                + "); give layout= or columns=",
                path=path,
                reason="unknown layout",
            )
        name = _BY_COUNT[ncol]
        cols = LAYOUTS[name]
    elif len(cols) != ncol:
        raise FileFormatError(
            f"{path}:{b.first}: the layout {name} has {len(cols)} columns, the file's ENTRIES "
            f"line names {ncol} ({' '.join(b.names)})",
            path=path,
        )
    rows = [ln.split() for ln in lines[b.first : b.first + b.n]]
    for k, t in enumerate(rows):
        if len(t) != ncol:
            raise FileFormatError(
                f"{path}:{b.first + k + 1}: expected {ncol} values, found {len(t)}", path=path
            )
    try:
        a = np.array(rows, dtype=np.float64).reshape(b.n, ncol)
    except ValueError:
        for k, t in enumerate(rows):
            bad = next((v for v in t if not is_number(v)), None)
            if bad is not None:
                raise FileFormatError(
                    f"{path}:{b.first + k + 1}: {bad!r} is not a number", path=path
                ) from None
        raise

    def line(k: int) -> int:
        return b.first + k + 1

    def col(c: str) -> np.ndarray:
        return a[:, cols.index(c)]

    bad_rows = ~np.all(np.isfinite(a), axis=1)
    if np.any(bad_rows):
        k = int(np.argmax(bad_rows))
        raise FileFormatError(f"{path}:{line(k)}: non-finite value", path=path)

    notes: list[str] = [] if short is None else [short]
    n = len(particles)
    d = particles.dim
    ids = particles.ids
    if ids is None:
        ids = np.arange(1, n + 1, dtype=np.int64)
        if particles.format != "npz":
            notes.append(f"{particles.path.name} has no ids: particle k is taken as id k + 1")
    index = []
    for c in ("id1", "id2"):
        at_c = cols.index(c)
        # exact from the text where ids pass 2**53 (64-bit tags), so that none merge
        v = _integer_ids(path, col(c), line, lambda at_c=at_c: [t[at_c] for t in rows])
        at = np.clip(np.searchsorted(ids, v), 0, max(n - 1, 0))
        unknown = ids[at] != v
        if np.any(unknown):
            k = int(np.argmax(unknown))
            raise FileFormatError(
                f"{path}:{line(k)}: {c} = {int(v[k])} names no particle of "
                f"{particles.path} ({n} particles, ids {int(ids[0])} to {int(ids[-1])}): the "
                "contacts and the particles come from different runs or steps",
                path=path,
                reason="unknown id",
            )
        index.append(at.astype(np.int64))
    i, j = index
    same = i == j
    if np.any(same):
        k = int(np.argmax(same))
        raise FileFormatError(
            f"{path}:{line(k)}: a contact of particle id {int(ids[i[k]])} with itself", path=path
        )

    # each pair once: a pair across a periodic side is listed for both of its particles
    lo_, hi_ = np.minimum(i, j), np.maximum(i, j)
    _, first = np.unique(np.stack([lo_, hi_], axis=1), axis=0, return_index=True)
    rows_kept = np.arange(i.size)
    if first.size < i.size:
        keep = np.sort(first)
        notes.append(f"{i.size - keep.size} pairs listed twice were read once")
        a, i, j, rows_kept = a[keep], i[keep], j[keep], rows_kept[keep]

    x = np.asarray(particles.positions, dtype=np.float64)
    r = np.asarray(particles.radii, dtype=np.float64)
    branch = x[j] - x[i]
    periods = np.full(d, np.inf)
    if particles.periodic is not None and particles.box is not None:
        size = np.asarray(particles.box[1]) - np.asarray(particles.box[0])
        for ax, p in enumerate(particles.periodic):
            if p:
                periods[ax] = size[ax]
                branch[:, ax] -= size[ax] * np.round(branch[:, ax] / size[ax])
    dist = np.linalg.norm(branch, axis=1)
    if np.any(dist == 0.0):
        k = int(np.argmax(dist == 0.0))
        raise FileFormatError(
            f"{path}: the pair of ids {int(ids[i[k]])} and {int(ids[j[k]])} has coincident "
            "centres: no normal",
            path=path,
        )
    normal = branch / dist[:, None]
    cols_now = cols

    def vec(prefix: str) -> np.ndarray:
        return np.column_stack([a[:, cols_now.index(prefix + ax)] for ax in "xyz"])

    if {"fx", "fy", "fz"} <= set(cols):
        force = vec("f")
    else:
        force = vec("fn")
        if {"ftx", "fty", "ftz"} <= set(cols):
            force = force + vec("ft")
    if d == 2:
        force = force[:, :2]
    no_force = np.all(force == 0.0, axis=1)
    # LAMMPS lists every pair within the force cutoff unless told "cutoff radius", and
    # counts (contact/atom) only the overlapping ones: a pair of the named layouts
    # without overlap or force is none. A list given column by column (YADE's
    # interactions) is counted as its code counts it: a pair at zero force is a
    # contact where the check takes it (a verge contact), refused farther apart
    idle = no_force & (r[i] + r[j] - dist <= 0.0) & (name != "columns")
    if np.any(idle):
        notes.append(f"{int(idle.sum())} pairs without overlap or force were left out")
        keep = ~idle
        i, j, force, branch, dist, normal, rows_kept = (
            i[keep],
            j[keep],
            force[keep],
            branch[keep],
            dist[keep],
            normal[keep],
            rows_kept[keep],
        )
        no_force = no_force[keep]
    # every pair left must touch: ids of another run or numbering name particles apart
    n_verge, widest = check_contacts_touch(
        i,
        j,
        x,
        r,
        periods=periods,
        box=particles.box,
        path=path,
        lines=b.first + rows_kept + 1,
        ids=ids,
        force=~no_force,
        digits=particles.digits,
    )
    if n_verge:
        notes.append(verge_note(n_verge, widest))
    fn_on_i = np.einsum("md,md->m", force, normal)
    f_n = -fn_on_i
    attractive = f_n < 0.0
    if np.any(attractive):
        notes.append(
            f"{int(attractive.sum())} of {f_n.size} contacts have a net attractive normal "
            "force (damping); set to 0"
        )
        f_n = np.where(attractive, 0.0, f_n)
    f_t = -(force - fn_on_i[:, None] * normal)
    contacts = Contacts(
        i=i,
        j=j,
        normal=normal,
        overlap=r[i] + r[j] - dist,
        force_normal=f_n,
        force_tangential=f_t,
        branch=branch,
    )
    out = ContactFile(path, name, contacts, b.timestep, k_snap, n_snap, tuple(notes))
    out.carries_force = ~no_force
    return out
