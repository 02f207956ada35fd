"""VTK XML unstructured grids (``.vtu``) for ParaView: particles, contact lines, the container."""

from __future__ import annotations

import base64
import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .._files import atomic_write
from ..analysis.container import Container

if TYPE_CHECKING:
    from ..pack import Pack

from ._text import (
    _pad3,
    contact_counts,
)

_VTK_VERTEX = 1


_VTK_LINE = 3


_VTK_QUAD = 9


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
    if Container.of_pack(pack).kind != "periodic" or ci.shape[0] == 0:
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
    container = Container.of_pack(pack)
    kind, radius = container.kind, container.radius
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
    container = Container.of_pack(pack)
    kind, radius = container.kind, container.radius
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


def write_vtk_files(pack: Pack, path: str | Path) -> list[Path]:
    """The particles' VTK file at `path` and the container's beside it
    (``<stem>.container.vtu``)."""
    return [write_vtk(pack, path), write_vtk_container(pack, container_path(path))]
