"""Pack files for other tools: ParaView (VTK), LAMMPS/LIGGGHTS (data file), CSV, Parquet.

Every writer goes through `granpack.pack.atomic_write`, so an interrupted export never
leaves a half-written file behind.

VTK
    A hand-written VTK XML unstructured grid (``.vtu``, inline base64 binary, float64,
    no compression). No VTK library is needed: the format is small and fixed, and writing
    it directly keeps the output identical whatever is installed (meshio, which the
    tests use to read the files back, is an optional dependency). One file holds

    * the particles, as points with ``vertex`` cells; point data ``id``, ``radius``,
      ``diameter``, ``layer``, ``velocity`` (3 components), ``spin`` (3 components;
      (0, 0, w) in 2D), ``n_contacts`` (particle-particle plus wall contacts);
    * the contacts, as ``line`` cells from centre i to centre j, or to the contact
      point for wall contacts (these contact points are extra points after the
      particles, with ``id`` = -1, radius 0 and layer -1); cell data ``kind``
      (0 particle, 1 particle-particle contact, 2 wall contact), ``i``, ``j``
      (j < 0 names the wall), ``overlap`` (m), ``force_normal`` (N), ``normal``,
      ``force_tangential`` (N, on j) and ``force`` (N, on j: f_n n + f_t); zero on
      the vertex cells.

    In ParaView: Glyph (Sphere, scale array ``diameter``, factor 1) on the points;
    Threshold ``kind`` >= 1 and Tube (radius by ``force_normal``) for force chains.
    2D packs lie in the plane z = 0.

LAMMPS / LIGGGHTS
    A data file for ``atom_style sphere`` (``read_data``): Atoms columns
    ``atom-ID atom-type diameter density x y z`` and a Velocities section
    ``atom-ID vx vy vz wx wy wz``. LAMMPS sets mass = density * 4/3 pi r^3 even in 2D,
    so the density column is the one that gives granpack's mass (the material density
    for the default ``inertia_2d = "sphere"``; rho pi r^2 / (4/3 pi r^3) for "disc").
    The box is [0, L] x [0, B2] x [0, H_top] (3D); 2D packs lie at z = 0 in a thin slab
    [-r_max, r_max] (LAMMPS' ``dimension 2`` needs a periodic z; the vertical is y).

CSV / Parquet
    Two polars tables, ``<stem>.particles.<ext>`` and ``<stem>.contacts.<ext>``
    (columns in `particle_table` and `contact_table`).
"""

from __future__ import annotations

import base64
import io
import math
import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import polars as pl

from ._validate import FileFormatError, GranpackError, InvalidParameterError
from .pack import Pack, atomic_write

__all__ = [
    "FORMATS",
    "export",
    "write_vtk",
    "write_lammps",
    "write_csv",
    "write_parquet",
    "particle_table",
    "contact_table",
    "read_lammps_data",
]

#: Export formats and the suffix of the file they write.
FORMATS = {"vtk": ".vtu", "lammps": ".data", "csv": ".csv", "parquet": ".parquet"}

_VTK_VERTEX = 1
_VTK_LINE = 3


def export(
    pack: Pack, path: str | Path, format: str | None = None, *, refuse: Sequence = ()
) -> list[Path]:
    """Writes `pack` in one of `FORMATS` and returns the files written.

    Parameters
    ----------
    pack : Pack
    path : path
        Output file. For csv/parquet its stem names the two tables
        (``<stem>.particles.csv``, ``<stem>.contacts.csv``).
    format : {"vtk", "lammps", "csv", "parquet"}, optional
        Default: from the suffix of `path` (.vtu/.vtk, .data/.lmp, .csv, .parquet).
    refuse : sequence of paths
        Files that must not be overwritten (the pack file read, say): an output that is
        one of them is a GranpackError before anything is written.
    """
    path = Path(path)
    if format is None:
        format = _format_from_suffix(path)
    if format not in FORMATS:
        raise InvalidParameterError(
            f"invalid format = {format!r}: choose one of {', '.join(FORMATS)}"
        )
    targets = _table_paths(path, FORMATS[format]) if format in ("csv", "parquet") else (path,)
    for target in targets:
        for source in map(Path, refuse):
            if _same_file(target, source):
                raise GranpackError(
                    f"the export would overwrite its input {source} ({target} is that "
                    "file); choose another --out"
                )
    if format == "vtk":
        return [write_vtk(pack, path)]
    if format == "lammps":
        return [write_lammps(pack, path)]
    if format == "csv":
        return write_csv(pack, path)
    return write_parquet(pack, path)


def _same_file(a: Path, b: Path) -> bool:
    try:
        return a.exists() and b.exists() and os.path.samefile(a, b)
    except OSError:
        return False


def _format_from_suffix(path: Path) -> str:
    suffix = path.suffix.lower()
    table = {
        ".vtu": "vtk",
        ".vtk": "vtk",
        ".data": "lammps",
        ".lmp": "lammps",
        ".csv": "csv",
        ".parquet": "parquet",
    }
    if suffix not in table:
        raise GranpackError(
            f"cannot tell the export format from {path.name!r}: give format= ({', '.join(FORMATS)})"
        )
    return table[suffix]


# -- per-particle helpers ------------------------------------------------------------------


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


# -- VTK -----------------------------------------------------------------------------------


def _b64(a: np.ndarray) -> str:
    """Inline binary VTK data: base64 of (UInt64 byte count, little-endian data) as one
    stream, which is how VTK's own writer encodes uncompressed data."""
    a = np.ascontiguousarray(a)
    raw = a.astype(a.dtype.newbyteorder("<"), copy=False).tobytes()
    return base64.b64encode(np.uint64(len(raw)).tobytes() + raw).decode("ascii")


_VTK_TYPES = {
    np.dtype(np.float64): "Float64",
    np.dtype(np.int64): "Int64",
    np.dtype(np.uint8): "UInt8",
}


def _data_array(name: str | None, a: np.ndarray) -> str:
    kind = _VTK_TYPES[a.dtype]
    ncomp = 1 if a.ndim == 1 else a.shape[1]
    attrs = f'type="{kind}"'
    if name is not None:
        attrs += f' Name="{name}"'
    if ncomp > 1:
        attrs += f' NumberOfComponents="{ncomp}"'
    return f'<DataArray {attrs} format="binary">{_b64(a)}</DataArray>'


def write_vtk(pack: Pack, path: str | Path) -> Path:
    """Writes the pack as a VTK XML unstructured grid (``.vtu``) that ParaView opens:
    particles as points (vertex cells) with their data, contacts as lines with their
    forces (layout in the module docstring). Returns the path."""
    path = Path(path)
    n = len(pack)
    c = pack.contacts
    m = len(c)
    x = _pad3(pack.positions)
    ci = np.asarray(c.i, dtype=np.int64)
    cj = np.asarray(c.j, dtype=np.int64)
    wall = cj < 0
    n_wall = int(wall.sum())
    # Wall contacts end at the contact point, stored as extra points after the particles.
    wall_points = x[ci[wall]] + _pad3(c.branch)[wall]
    points = np.vstack([x, wall_points]) if n_wall else x
    n_points = n + n_wall
    end = cj.copy()
    end[wall] = n + np.arange(n_wall)

    def point_field(a: np.ndarray, fill) -> np.ndarray:
        if not n_wall:
            return a
        pad = np.full((n_wall, *a.shape[1:]), fill, dtype=a.dtype)
        return np.concatenate([a, pad])

    point_data = {
        "id": point_field(np.arange(n, dtype=np.int64), -1),
        "radius": point_field(np.asarray(pack.radii, np.float64), 0.0),
        "diameter": point_field(2.0 * np.asarray(pack.radii, np.float64), 0.0),
        "layer": point_field(np.asarray(pack.layer, np.int64), -1),
        "velocity": point_field(_pad3(pack.velocities), 0.0),
        "spin": point_field(_pad3(pack.spins), 0.0),
        "n_contacts": point_field(contact_counts(pack), 0),
    }

    normal = _pad3(c.normal)
    fn = np.asarray(c.force_normal, dtype=np.float64)
    ft = _pad3(c.force_tangential)

    def cell_field(vertex_value: np.ndarray, line_value: np.ndarray) -> np.ndarray:
        return np.concatenate([vertex_value, line_value])

    zeros3 = np.zeros((n, 3))
    cell_data = {
        "kind": cell_field(np.zeros(n, np.uint8), np.where(wall, 2, 1).astype(np.uint8)),
        "i": cell_field(np.arange(n, dtype=np.int64), ci),
        "j": cell_field(np.arange(n, dtype=np.int64), cj),
        "overlap": cell_field(np.zeros(n), np.asarray(c.overlap, dtype=np.float64)),
        "force_normal": cell_field(np.zeros(n), fn),
        "normal": cell_field(zeros3, normal),
        "force_tangential": cell_field(zeros3, ft),
        "force": cell_field(zeros3, fn[:, None] * normal + ft),
    }

    connectivity = np.concatenate(
        [np.arange(n, dtype=np.int64), np.column_stack([ci, end]).ravel()]
    )
    offsets = np.concatenate(
        [np.arange(1, n + 1, dtype=np.int64), n + 2 * np.arange(1, m + 1, dtype=np.int64)]
    )
    types = np.concatenate([np.full(n, _VTK_VERTEX, np.uint8), np.full(m, _VTK_LINE, np.uint8)])

    s = pack.scene
    lines = [
        '<?xml version="1.0"?>',
        f"<!-- granpack pack: dim={s.dim} N={n} contacts={m} seed={s.seed} "
        f"stream={s.stream} rotations={s.rotations} H_top={pack.height!r} m -->",
        '<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian" '
        'header_type="UInt64">',
        "<UnstructuredGrid>",
        f'<Piece NumberOfPoints="{n_points}" NumberOfCells="{n + m}">',
        '<PointData Scalars="radius" Vectors="velocity">',
        *(_data_array(k, v) for k, v in point_data.items()),
        "</PointData>",
        '<CellData Scalars="force_normal" Vectors="force">',
        *(_data_array(k, v) for k, v in cell_data.items()),
        "</CellData>",
        "<Points>",
        _data_array("Points", points),
        "</Points>",
        "<Cells>",
        _data_array("connectivity", connectivity),
        _data_array("offsets", offsets),
        _data_array("types", types),
        "</Cells>",
        "</Piece>",
        "</UnstructuredGrid>",
        "</VTKFile>",
        "",
    ]
    return atomic_write(path, "\n".join(lines).encode())


# -- LAMMPS --------------------------------------------------------------------------------


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


def write_lammps(pack: Pack, path: str | Path) -> Path:
    """Writes a LAMMPS/LIGGGHTS data file for ``atom_style sphere`` (SI units; read it
    with ``units si``, ``atom_style sphere`` and ``read_data``; 2D needs
    ``dimension 2`` and ``boundary f f p``). Returns the path."""
    path = Path(path)
    s = pack.scene
    n = len(pack)
    x = _pad3(pack.positions)
    d = 2.0 * np.asarray(pack.radii, dtype=np.float64)
    rho = lammps_density(pack)
    v = _pad3(pack.velocities)
    w = _pad3(pack.spins)
    if s.dim == 3:
        bounds = [(0.0, s.base[0]), (0.0, s.base[1]), (0.0, pack.height)]
    else:
        half = float(np.max(pack.radii)) if n else float(s.r_max or 0.0)
        bounds = [(0.0, s.base[0]), (0.0, pack.height), (-half, half)]
    # A particle touching the top sits exactly on H_top; nothing is outside the box.
    out = io.StringIO()
    out.write(
        f"LAMMPS data file from granpack: dim={s.dim} N={n} seed={s.seed} "
        f"stream={s.stream} rotations={'on' if s.rotations else 'off'} (SI units, "
        f"atom_style sphere{', dimension 2, vertical y' if s.dim == 2 else ', vertical z'})\n\n"
    )
    out.write(f"{n} atoms\n1 atom types\n\n")
    for (lo, hi), ax in zip(bounds, "xyz", strict=True):
        out.write(f"{lo!r} {hi!r} {ax}lo {ax}hi\n")
    out.write("\nAtoms # sphere\n\n")
    ids = np.arange(1, n + 1)
    atoms = np.column_stack([d, rho, x])
    for k in range(n):
        out.write(f"{ids[k]} 1 " + " ".join(repr(float(val)) for val in atoms[k]) + "\n")
    out.write("\nVelocities\n\n")
    vel = np.column_stack([v, w])
    for k in range(n):
        out.write(f"{ids[k]} " + " ".join(repr(float(val)) for val in vel[k]) + "\n")
    return atomic_write(path, out.getvalue().encode())


def read_lammps_data(path: str | Path) -> dict:
    """Reads the particles of a LAMMPS data file for ``atom_style sphere`` (Atoms
    ``id type diameter density x y z``, optional Velocities ``id vx vy vz wx wy wz``).

    Returns a dict of arrays sorted by atom id: ``id``, ``type``, ``diameter``,
    ``density``, ``positions`` (N, 3), ``velocities`` and ``spins`` (N, 3; zeros when
    the file has no Velocities section), and ``box`` ((lo, hi) corners, 3 each).
    """
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise GranpackError(f"cannot read LAMMPS data file {path}: {exc.strerror}") from None
    lines = [ln.split("#", 1)[0].strip() for ln in text.splitlines()[1:]]
    n_atoms = None
    lo = np.zeros(3)
    hi = np.zeros(3)
    sections: dict[str, list[list[float]]] = {}
    current = None
    try:
        for ln in lines:
            if not ln:
                continue
            words = ln.split()
            if ln in ("Atoms", "Velocities") or words[0] in ("Atoms", "Velocities"):
                current = words[0]
                sections[current] = []
                continue
            if current is None:
                if words[-1] == "atoms":
                    n_atoms = int(words[0])
                for k, ax in enumerate("xyz"):
                    if words[-2:] == [f"{ax}lo", f"{ax}hi"]:
                        lo[k], hi[k] = float(words[0]), float(words[1])
                continue
            if words[0][0].isalpha():  # a section this reader does not need
                current = "skip"
                sections[current] = []
                continue
            sections[current].append([float(wd) for wd in words])
        atoms = np.array(sections.get("Atoms", []), dtype=np.float64).reshape(-1, 7)
    except (ValueError, IndexError) as exc:
        raise FileFormatError(f"cannot read LAMMPS data file {path}: {exc}", path=path) from None
    if n_atoms is None or atoms.shape[0] != n_atoms:
        raise FileFormatError(
            f"cannot read LAMMPS data file {path}: header says {n_atoms} atoms, "
            f"Atoms section has {atoms.shape[0]} (atom_style sphere expected)",
            path=path,
        )
    order = np.argsort(atoms[:, 0], kind="stable")
    atoms = atoms[order]
    vel = np.zeros((n_atoms, 6))
    if "Velocities" in sections:
        v = np.array(sections["Velocities"], dtype=np.float64).reshape(-1, 7)
        v = v[np.argsort(v[:, 0], kind="stable")]
        if v.shape[0] != n_atoms or np.any(v[:, 0] != atoms[:, 0]):
            raise FileFormatError(
                f"cannot read LAMMPS data file {path}: Velocities do not match Atoms", path=path
            )
        vel = v[:, 1:]
    return {
        "id": atoms[:, 0].astype(np.int64),
        "type": atoms[:, 1].astype(np.int64),
        "diameter": atoms[:, 2],
        "density": atoms[:, 3],
        "positions": atoms[:, 4:7],
        "velocities": vel[:, :3],
        "spins": vel[:, 3:],
        "box": (lo, hi),
    }


# -- tables --------------------------------------------------------------------------------


def particle_table(pack: Pack) -> pl.DataFrame:
    """One row per particle: ``id``, ``x``, ``y`` (, ``z``) (m), ``radius`` (m),
    ``layer``, ``vx``, ``vy`` (, ``vz``) (m/s), spin ``w`` (2D, rad/s) or ``wx``,
    ``wy``, ``wz`` (3D), ``n_contacts`` (particle-particle plus wall)."""
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
    for suffix in (ext, FORMATS["vtk"], ".vtk", ".data", ".npz"):
        if stem.endswith(suffix):
            stem = stem[: -len(suffix)]
            break
    return path.with_name(f"{stem}.particles{ext}"), path.with_name(f"{stem}.contacts{ext}")


def write_csv(pack: Pack, path: str | Path) -> list[Path]:
    """Writes ``<stem>.particles.csv`` and ``<stem>.contacts.csv`` (full float64
    precision). Returns both paths."""
    p_path, c_path = _table_paths(Path(path), ".csv")
    return [
        atomic_write(p_path, particle_table(pack).write_csv().encode()),
        atomic_write(c_path, contact_table(pack).write_csv().encode()),
    ]


def write_parquet(pack: Pack, path: str | Path) -> list[Path]:
    """Writes ``<stem>.particles.parquet`` and ``<stem>.contacts.parquet``. Returns
    both paths."""
    p_path, c_path = _table_paths(Path(path), ".parquet")
    out = []
    for target, df in ((p_path, particle_table(pack)), (c_path, contact_table(pack))):
        buf = io.BytesIO()
        df.write_parquet(buf)
        out.append(atomic_write(target, buf.getvalue()))
    return out
