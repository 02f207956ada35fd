"""The former home of :func:`export` and the writers: every format now lives in
`granpack.io`, one module per format family (its writer beside its reader), behind one
registry (`granpack.io.registry`). Importing this module still works for one release, with
a `DeprecationWarning`; import from `granpack.io` in new code."""

import warnings

from .io._text import contact_counts
from .io.lammps import (
    input_text,
    lammps_density,
    lammps_positions,
    read_lammps_data,
    write_lammps,
)
from .io.registry import EXPORT_FORMATS as FORMATS
from .io.registry import export, output_paths
from .io.tables import contact_table, particle_table, write_csv, write_parquet
from .io.vtk import (
    CYLINDER_SEGMENTS,
    container_geometry,
    container_path,
    write_vtk,
    write_vtk_container,
)
from .io.xyz import write_xyz
from .io.yade import write_yade

__all__ = [
    "CYLINDER_SEGMENTS",
    "FORMATS",
    "contact_counts",
    "contact_table",
    "container_geometry",
    "container_path",
    "export",
    "input_text",
    "lammps_density",
    "lammps_positions",
    "output_paths",
    "particle_table",
    "read_lammps_data",
    "write_csv",
    "write_lammps",
    "write_parquet",
    "write_vtk",
    "write_vtk_container",
    "write_xyz",
    "write_yade",
]

warnings.warn(
    "granpack.export is now granpack.io; import from granpack.io in new code: "
    "granpack.export is removed in the next release",
    DeprecationWarning,
    stacklevel=2,
)
