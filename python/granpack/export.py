"""Pack files for other tools: ParaView (VTK), LAMMPS/LIGGGHTS (data file and input
snippet), YADE (text), OVITO/ASE (extended XYZ), CSV, Parquet.

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
      (0 particle, 1 particle-particle contact, 2 wall contact, 3 the image of a contact
      across a periodic seam), ``i``, ``j``
      (j < 0 names the wall), ``overlap`` (m), ``force_normal`` (N), ``normal``,
      ``force_tangential`` (N, on j) and ``force`` (N, on j: f_n n + f_t); zero on
      the vertex cells.

    A contact across a periodic seam is drawn as its short minimum-image segment on both
    sides of the cell: from centre i to x_i + l (kind 1), and from centre j to x_j - l
    (kind 3, the same cell data), so that no line crosses the cell; count contacts with
    kind 1 and 2 only.

    In ParaView: Glyph (Sphere, scale array ``diameter``, factor 1) on the points;
    Threshold ``kind`` >= 1 and Tube (radius by ``force_normal``) for force chains.
    2D packs lie in the plane z = 0.

    A second file, ``<stem>.container.vtu``, draws the container up to H_top: the box's
    edges (line cells), the periodic cell's outline (line cells; `kind` 1, where the
    walls' are 0), or the cylinder's side as quads (24 around) with its floor and top
    circles as lines; cell data ``kind`` (0 wall, 1 periodic side).

LAMMPS / LIGGGHTS
    A data file for ``atom_style sphere`` (``read_data``): Atoms columns
    ``atom-ID atom-type diameter density x y z`` and a Velocities section
    ``atom-ID vx vy vz wx wy wz``. LAMMPS sets mass = density * 4/3 pi r^3 even in 2D,
    so the density column is the one that gives granpack's mass (the material density
    for the default ``inertia_2d = "sphere"``; rho pi r^2 / (4/3 pi r^3) for "disc").
    The box is [0, L] x [0, B2] x [0, H_top] (3D); 2D packs lie at z = 0 in a thin slab
    [-r_max, r_max] (LAMMPS' ``dimension 2`` needs a periodic z; the vertical is y).
    A periodic pack's centres are wrapped into [0, L) (its images across the seam are
    LAMMPS' own). The header names the 2D mass convention.

    Beside it, ``in.granpack`` continues the run (`granpack.dem_input`): the LAMMPS input
    for format ``lammps``, the LIGGGHTS one for ``liggghts``. The data file is the same for
    both: LIGGGHTS 3.8 reads it for ``atom_style granular`` with the same masses.

YADE
    ``#format x_y_z_r`` then ``x y z r`` a line, full precision: what YADE's
    ``export.text`` writes and ``ymport.text`` reads. 2D packs lie at z = 0. A comment
    line ``# granpack: dim=.. container=..`` (`granpack.container_tag`) after the header
    carries the container and its box, which ``ymport.text`` skips.

Extended XYZ
    As OVITO and ASE read it: the count, a comment line with
    ``Lattice="L 0 0 0 B2 0 0 0 H_top"`` (2D: L, H_top and 2 r_max), ``Origin``,
    ``pbc`` and ``Properties=species:S:1:pos:R:3:radius:R:1``, then ``X x y z r`` a line
    (species X, ASE's placeholder element).

CSV / Parquet
    Two polars tables, ``<stem>.particles.<ext>`` and ``<stem>.contacts.<ext>``
    (columns in `particle_table` and `contact_table`). The particle CSV opens with a
    comment line ``# granpack: dim=.. container=..`` (the container tag); each Parquet
    file carries the same words as key-value metadata under ``granpack``.

The container
    Every text export carries the pack's container, so that `granpack.read_particles`
    reads it back in it: the LAMMPS data file on its title line, extended XYZ in its
    ``pbc`` and its ``granpack="..."`` key, YADE and CSV on a comment line, Parquet in
    its metadata (`granpack.container_tag` gives the words).
"""

from __future__ import annotations

import base64
import io
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import polars as pl

from ._validate import FileFormatError, GranpackError, InvalidParameterError, check_outputs
from .container_tag import container_tag
from .dem_input import SNIPPET_NAME, container_of, lammps_input, liggghts_input
from .pack import Pack, atomic_write

__all__ = [
    "FORMATS",
    "export",
    "write_vtk",
    "write_lammps",
    "input_text",
    "write_yade",
    "write_xyz",
    "write_vtk_container",
    "lammps_positions",
    "write_csv",
    "write_parquet",
    "particle_table",
    "contact_table",
    "read_lammps_data",
]

#: Export formats and the suffix of the file they write.
FORMATS = {
    "vtk": ".vtu",
    "lammps": ".data",
    "liggghts": ".data",
    "yade": ".txt",
    "xyz": ".xyz",
    "csv": ".csv",
    "parquet": ".parquet",
}

_VTK_VERTEX = 1
_VTK_LINE = 3
_VTK_QUAD = 9


def export(
    pack: Pack,
    path: str | Path,
    format: str | None = None,
    *,
    refuse: Sequence = (),
    parameter: str = "path",
) -> list[Path]:
    """Writes `pack` in one of `FORMATS` and returns the files written.

    Parameters
    ----------
    pack : Pack
    path : path
        Output file. For csv/parquet its stem names the two tables
        (``<stem>.particles.csv``, ``<stem>.contacts.csv``).
    format : {"vtk", "lammps", "liggghts", "yade", "xyz", "csv", "parquet"}, optional
        Default: from the suffix of `path` (.vtu/.vtk, .data/.lmp, .xyz, .csv,
        .parquet; yade and liggghts are named, not guessed). lammps and liggghts also
        write ``in.granpack`` beside the data file; vtk also writes
        ``<stem>.container.vtu``.
    refuse : sequence of paths
        Files that must not be overwritten (the pack file read, say).
    parameter : str
        The name errors give `path` (the command line passes ``"--out"``).

    Raises
    ------
    InvalidParameterError
        Before anything is written, naming `parameter`: two of the files the format
        writes would be one file (``--out DIR/in.granpack`` for lammps, whose input
        script is ``in.granpack``), or one would be a file of `refuse`.
    """
    path = Path(path)
    if format is None:
        format = _format_from_suffix(path)
    if format not in FORMATS:
        raise InvalidParameterError(
            f"invalid format = {format!r}: choose one of {', '.join(FORMATS)}"
        )
    check_outputs(output_paths(path, format), refuse, parameter)
    if format == "vtk":
        return [write_vtk(pack, path), write_vtk_container(pack, container_path(path))]
    if format in ("lammps", "liggghts"):
        # the input first: it refuses a 2D pack for LIGGGHTS before anything is written
        text = input_text(pack, path.name, format)
        return [write_lammps(pack, path), atomic_write(path.with_name(SNIPPET_NAME), text.encode())]
    if format == "yade":
        return [write_yade(pack, path)]
    if format == "xyz":
        return [write_xyz(pack, path)]
    if format == "csv":
        return write_csv(pack, path)
    return write_parquet(pack, path)


def output_paths(path: str | Path, format: str) -> list[Path]:
    """Every file `export` writes for `path` in `format`, in the order it writes them."""
    path = Path(path)
    if format in ("csv", "parquet"):
        return list(_table_paths(path, FORMATS[format]))
    if format in ("lammps", "liggghts"):
        return [path, path.with_name(SNIPPET_NAME)]
    if format == "vtk":
        return [path, container_path(path)]
    return [path]


def _format_from_suffix(path: Path) -> str:
    suffix = path.suffix.lower()
    table = {
        ".vtu": "vtk",
        ".vtk": "vtk",
        ".data": "lammps",
        ".lmp": "lammps",
        ".xyz": "xyz",
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
    branch = _pad3(c.branch)
    # Wall contacts end at the contact point, stored as extra points after the particles.
    wall_points = x[ci[wall]] + branch[wall]
    # A contact across a periodic seam is drawn as its short minimum-image segment on
    # both sides: from x_i to x_i + l (the contact), and from x_j to x_j - l (its image,
    # kind 3), never as a line across the cell.
    seam = _seam_contacts(pack, x, ci, cj, branch)
    n_seam = int(seam.sum())
    seam_i_points = x[ci[seam]] + branch[seam]
    seam_j_points = x[cj[seam]] - branch[seam]
    points = np.vstack([x, wall_points, seam_i_points, seam_j_points])
    n_extra = n_wall + 2 * n_seam
    n_points = n + n_extra
    end = cj.copy()
    end[wall] = n + np.arange(n_wall)
    end[seam] = n + n_wall + np.arange(n_seam)
    image_start = cj[seam]
    image_end = n + n_wall + n_seam + np.arange(n_seam)

    def point_field(a: np.ndarray, fill) -> np.ndarray:
        if not n_extra:
            return a
        pad = np.full((n_extra, *a.shape[1:]), fill, dtype=a.dtype)
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
        # the seam images repeat their contact's values
        return np.concatenate([vertex_value, line_value, line_value[seam]])

    zeros3 = np.zeros((n, 3))
    cell_data = {
        "kind": np.concatenate(
            [
                np.zeros(n, np.uint8),
                np.where(wall, 2, 1).astype(np.uint8),
                np.full(n_seam, 3, np.uint8),
            ]
        ),
        "i": cell_field(np.arange(n, dtype=np.int64), ci),
        "j": cell_field(np.arange(n, dtype=np.int64), cj),
        "overlap": cell_field(np.zeros(n), np.asarray(c.overlap, dtype=np.float64)),
        "force_normal": cell_field(np.zeros(n), fn),
        "normal": cell_field(zeros3, normal),
        "force_tangential": cell_field(zeros3, ft),
        "force": cell_field(zeros3, fn[:, None] * normal + ft),
    }

    connectivity = np.concatenate(
        [
            np.arange(n, dtype=np.int64),
            np.column_stack([ci, end]).ravel(),
            np.column_stack([image_start, image_end]).ravel(),
        ]
    )
    n_lines = m + n_seam
    offsets = np.concatenate(
        [np.arange(1, n + 1, dtype=np.int64), n + 2 * np.arange(1, n_lines + 1, dtype=np.int64)]
    )
    types = np.concatenate(
        [np.full(n, _VTK_VERTEX, np.uint8), np.full(n_lines, _VTK_LINE, np.uint8)]
    )

    s = pack.scene
    lines = [
        '<?xml version="1.0"?>',
        f"<!-- granpack pack: dim={s.dim} N={n} contacts={m} seed={s.seed} "
        f"stream={s.stream} rotations={s.rotations} H_top={pack.height!r} m -->",
        '<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian" '
        'header_type="UInt64">',
        "<UnstructuredGrid>",
        f'<Piece NumberOfPoints="{n_points}" NumberOfCells="{n + n_lines}">',
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


def _seam_contacts(
    pack: Pack, x: np.ndarray, ci: np.ndarray, cj: np.ndarray, branch: np.ndarray
) -> np.ndarray:
    """(M,) bool: particle pairs whose branch (the minimum image) is not x_j - x_i, the
    contacts across a periodic seam."""
    if container_of(pack)[0] != "periodic" or ci.shape[0] == 0:
        return np.zeros(ci.shape[0], dtype=bool)
    pair = cj >= 0
    jj = np.where(pair, cj, ci)
    # off by a period where the seam is crossed; rounding leaves far less than a radius
    gap = np.max(np.abs(x[jj] - x[ci] - branch), axis=1)
    return pair & (gap > float(np.min(pack.radii)))


def container_path(path: str | Path) -> Path:
    """``<stem>.container.vtu`` beside the particles' VTK file."""
    path = Path(path)
    stem = path.name[: -len(path.suffix)] if path.suffix else path.name
    return path.with_name(f"{stem}.container.vtu")


#: Quads around the cylinder's side in the container file.
CYLINDER_SEGMENTS = 24


def container_geometry(pack: Pack) -> tuple[np.ndarray, list[tuple[int, np.ndarray]], np.ndarray]:
    """(points (P, 3), [(VTK cell type, connectivity (C, k))...], kind per cell) drawing
    the pack's container up to H_top (2D in the plane z = 0, vertical y)."""
    s = pack.scene
    kind, radius = container_of(pack)
    h = float(pack.height)
    if kind == "cylinder":
        assert radius is not None
        k = CYLINDER_SEGMENTS
        t = 2.0 * math.pi * np.arange(k) / k
        ring = np.column_stack([radius + radius * np.cos(t), radius + radius * np.sin(t)])
        points = np.vstack(
            [np.column_stack([ring, np.zeros(k)]), np.column_stack([ring, np.full(k, h)])]
        )
        a = np.arange(k)
        b = (a + 1) % k
        quads = np.column_stack([a, b, b + k, a + k])
        rims = np.vstack([np.column_stack([a, b]), np.column_stack([a + k, b + k])])
        cells = [(_VTK_QUAD, quads), (_VTK_LINE, rims)]
        return points, cells, np.zeros(k + 2 * k, dtype=np.uint8)
    if s.dim == 2:
        length = s.base[0]
        points = np.array([[0.0, 0.0, 0.0], [length, 0.0, 0.0], [length, h, 0.0], [0.0, h, 0.0]])
        edges = np.array([[0, 1], [1, 2], [3, 0], [2, 3]])
        # floor, the two sides, the open top (drawn so the cell is closed); the sides are
        # periodic in a periodic cell
        side = 1 if kind == "periodic" else 0
        kinds = np.array([0, side, side, 1 if kind == "periodic" else 0], dtype=np.uint8)
        return points, [(_VTK_LINE, edges)], kinds
    lx, ly = s.base
    corners = np.array(
        [[x, y, z] for z in (0.0, h) for y in (0.0, ly) for x in (0.0, lx)], dtype=np.float64
    )
    bottom = [[0, 1], [1, 3], [3, 2], [2, 0]]
    top = [[a + 4, b + 4] for a, b in bottom]
    vertical = [[a, a + 4] for a in range(4)]
    edges = np.array(bottom + top + vertical)
    kinds = np.zeros(len(edges), dtype=np.uint8)
    if kind == "periodic":
        kinds[4:] = 1  # only the floor's edges are a wall
    return corners, [(_VTK_LINE, edges)], kinds


def write_vtk_container(pack: Pack, path: str | Path) -> Path:
    """Writes the pack's container (box edges, periodic cell outline, or cylinder side) as
    a VTK XML unstructured grid, to open beside the particles in ParaView. Returns the
    path."""
    points, cells, kinds = container_geometry(pack)
    conn = np.concatenate([c.ravel() for _, c in cells]).astype(np.int64)
    sizes = np.concatenate([np.full(len(c), c.shape[1]) for _, c in cells]).astype(np.int64)
    types = np.concatenate([np.full(len(c), t, np.uint8) for t, c in cells])
    kind, radius = container_of(pack)
    lines = [
        '<?xml version="1.0"?>',
        f"<!-- granpack container: {kind}"
        + (f" radius={radius!r} m" if radius is not None else "")
        + f" H_top={pack.height!r} m -->",
        '<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian" '
        'header_type="UInt64">',
        "<UnstructuredGrid>",
        f'<Piece NumberOfPoints="{len(points)}" NumberOfCells="{len(types)}">',
        '<CellData Scalars="kind">',
        _data_array("kind", kinds),
        "</CellData>",
        "<Points>",
        _data_array("Points", np.ascontiguousarray(points, dtype=np.float64)),
        "</Points>",
        "<Cells>",
        _data_array("connectivity", conn),
        _data_array("offsets", np.cumsum(sizes)),
        _data_array("types", types),
        "</Cells>",
        "</Piece>",
        "</UnstructuredGrid>",
        "</VTKFile>",
        "",
    ]
    return atomic_write(Path(path), "\n".join(lines).encode())


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


def input_text(pack: Pack, data_name: str, code: str) -> str:
    """The text of ``in.granpack`` for `code` ("lammps" or "liggghts") reading the data
    file `data_name` (see `granpack.dem_input`)."""
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
    ``dimension 2`` and ``boundary f f p``). Returns the path. `export` also writes the
    input ``in.granpack`` beside it (`input_text`)."""
    path = Path(path)
    s = pack.scene
    n = len(pack)
    x = lammps_positions(pack)
    d = 2.0 * np.asarray(pack.radii, dtype=np.float64)
    rho = lammps_density(pack)
    v = _pad3(pack.velocities)
    w = _pad3(pack.spins)
    kind, radius = container_of(pack)
    if s.dim == 3:
        bounds = [(0.0, s.base[0]), (0.0, s.base[1]), (0.0, pack.height)]
    else:
        half = float(np.max(pack.radii)) if n else float(s.r_max or 0.0)
        bounds = [(0.0, s.base[0]), (0.0, pack.height), (-half, half)]
    mass = ""
    if s.dim == 2:
        mass = f", mass convention {s.inertia_2d}" + (
            " (disc of unit thickness: m = pi r^2 rho)"
            if s.inertia_2d == "disc"
            else " (sphere: m = 4/3 pi r^3 rho)"
        )
    # the container tag (granpack.container_tag): read_particles analyses the file in it
    where = ", " + container_tag(kind, radius)
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
    atoms = np.column_stack([d, rho, x])
    for k in range(n):
        out.write(f"{ids[k]} 1 " + " ".join(repr(float(val)) for val in atoms[k]) + "\n")
    out.write("\nVelocities\n\n")
    vel = np.column_stack([v, w])
    for k in range(n):
        out.write(f"{ids[k]} " + " ".join(repr(float(val)) for val in vel[k]) + "\n")
    return atomic_write(path, out.getvalue().encode())


# -- YADE and extended XYZ -----------------------------------------------------------------


def write_yade(pack: Pack, path: str | Path) -> Path:
    """Writes YADE's text format (``#format x_y_z_r``, then ``x y z r`` a line at full
    precision), which ``yade.ymport.text`` reads. Returns the path."""
    x = _pad3(pack.positions)
    r = np.asarray(pack.radii, dtype=np.float64)
    out = io.StringIO()
    out.write("#format x_y_z_r\n")
    # ymport.text skips comment lines; read_particles takes the container from this one
    out.write(f"# granpack: dim={pack.dim} {_tag(pack)}\n")
    for (x0, x1, x2), rk in zip(x.tolist(), r.tolist(), strict=True):
        out.write(f"{x0!r} {x1!r} {x2!r} {rk!r}\n")
    return atomic_write(Path(path), out.getvalue().encode())


def _tag(pack: Pack) -> str:
    """The container tag of `pack`, with its box corners (lo = 0, hi = (base, H_top))."""
    lo, hi = pack.box
    return container_tag(*container_of(pack), lo, hi)


def _cell(pack: Pack) -> tuple[list[float], list[bool]]:
    """Lattice lengths (3) and periodic flags (3) of the pack's cell up to H_top."""
    s = pack.scene
    kind, _ = container_of(pack)
    periodic = kind == "periodic"
    if s.dim == 3:
        return [s.base[0], s.base[1], pack.height], [periodic, periodic, False]
    half = float(np.max(pack.radii)) if len(pack) else float(s.r_max or 0.0)
    return [s.base[0], pack.height, 2.0 * half], [periodic, False, False]


def write_xyz(pack: Pack, path: str | Path) -> Path:
    """Writes extended XYZ with a radius column, as OVITO and ASE read it (layout in the
    module docstring). Returns the path."""
    s = pack.scene
    x = lammps_positions(pack)
    r = np.asarray(pack.radii, dtype=np.float64)
    lengths, pbc = _cell(pack)
    origin = [0.0, 0.0, 0.0 if s.dim == 3 else -lengths[2] / 2.0]
    lattice = " ".join(
        repr(float(lengths[a])) if a == b else "0.0" for a in range(3) for b in range(3)
    )
    comment = (
        f'Lattice="{lattice}" Origin="{" ".join(repr(float(o)) for o in origin)}" '
        "Properties=species:S:1:pos:R:3:radius:R:1 "
        f'pbc="{" ".join("T" if p else "F" for p in pbc)}" '
        f'granpack="dim={s.dim} seed={s.seed} stream={s.stream} H_top={pack.height!r} '
        f'{container_tag(*container_of(pack))}"'
    )
    out = io.StringIO()
    out.write(f"{len(pack)}\n{comment}\n")
    for (x0, x1, x2), rk in zip(x.tolist(), r.tolist(), strict=True):
        out.write(f"X {x0!r} {x1!r} {x2!r} {rk!r}\n")
    return atomic_write(Path(path), out.getvalue().encode())


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
    from ._validate import is_number

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
    for j, k in enumerate(rows):
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
        at = {int(i): j for j, i in enumerate(ids)}
        seen: dict[int, int] = {}
        vnames = ("id", "vx", "vy", "vz", "wx", "wy", "wz")
        for k in vrows:
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
