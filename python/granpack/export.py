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

gsd
    HOOMD-blue's schema (OVITO, freud, HOOMD-blue), one frame, float32 positions centred
    on the origin, with the container in log data (`granpack.io.gsd`).

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

from collections.abc import Sequence
from pathlib import Path

from ._validate import GranpackError, InvalidParameterError, check_outputs
from .dem_input import SNIPPET_NAME
from .io.lammps import input_text, lammps_positions, read_lammps_data, write_lammps
from .io.tables import _table_paths, contact_table, particle_table, write_csv, write_parquet
from .io.vtk import (
    container_path,
    write_vtk,
    write_vtk_container,
)
from .io.xyz import write_xyz
from .io.yade import write_yade
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
    "gsd": ".gsd",
    # the DEM codes, one module each in granpack.io (kratos, mercurydpm, pfc, demengine)
    "kratos": ".mdpa",
    "mercurydpm": ".data",
    "pfc": ".dat",
    "demengine": ".csv",
}



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
    format : {"vtk", "lammps", "liggghts", "yade", "xyz", "csv", "parquet", "gsd", \
"kratos", "mercurydpm", "pfc", "demengine"}, optional
        Default: from the suffix of `path` (.vtu/.vtk, .data/.lmp, .xyz, .csv,
        .parquet, .gsd, .mdpa (kratos), .p3dat/.p2dat (pfc); yade, liggghts, mercurydpm
        and demengine are named, not guessed). demengine also writes
        ``<stem>.templates.csv``. lammps and liggghts also
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
    if format == "gsd":
        from .io.gsd import write_gsd  # HOOMD-blue's schema, through the optional gsd package

        return [write_gsd(pack, path)]
    if format in ("kratos", "mercurydpm", "pfc", "demengine"):
        from importlib import import_module

        # granpack.io.<format>.write_<format>
        writer = getattr(import_module(f".io.{format}", __package__), f"write_{format}")
        written = writer(pack, path)
        return written if isinstance(written, list) else [written]
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
    if format == "demengine":
        from .io.demengine import templates_path

        return [path, templates_path(path)]
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
        ".gsd": "gsd",
        ".mdpa": "kratos",
        ".p3dat": "pfc",
        ".p2dat": "pfc",
    }
    if suffix not in table:
        raise GranpackError(
            f"cannot tell the export format from {path.name!r}: give format= ({', '.join(FORMATS)})"
        )
    return table[suffix]


# -- per-particle helpers ------------------------------------------------------------------








# -- VTK -----------------------------------------------------------------------------------




















# -- LAMMPS --------------------------------------------------------------------------------










# -- YADE and extended XYZ -----------------------------------------------------------------












# -- tables --------------------------------------------------------------------------------










