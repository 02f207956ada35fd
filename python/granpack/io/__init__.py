"""Files of granpack and of other codes: one module per format family, its reader and its
writer side by side, and one registry (`granpack.io.registry`) behind
:func:`read_particles`, :func:`export` and :func:`read_contacts`.

Read (``read_particles(path, format=None)``; the names ``format=`` takes and
``ParticleFile.format`` gives, detected from the content first):

- ``"lammps-dump"``: a LAMMPS or LIGGGHTS ``dump custom`` (or ``write_dump ... custom``)
  text file, one or more snapshots; columns found by name (`granpack.io.lammps`);
- ``"lammps-data"``: a data file for ``atom_style sphere`` (granpack's export, LAMMPS'
  and LIGGGHTS' ``write_data``; another atom style is refused) (`granpack.io.lammps`);
- ``"yade"``: YADE's text export (``#format x_y_z_r``, ``x_y_z_r_matId``,
  ``id_x_y_z_r_matId``) (`granpack.io.yade`);
- ``"xyz"``: extended XYZ (OVITO, ASE) with ``pos`` and ``radius``, one or more frames
  (`granpack.io.xyz`);
- ``"xyzr"``: plain text, ``x y z r`` or ``x y r`` a line (`granpack.io.xyzr`);
- ``"csv"``, ``"parquet"``: tables with columns ``x y (z)`` and ``r``/``radius``/
  ``diameter`` (`granpack.io.tables`);
- ``"npz"``: a granpack pack file (``Pack.save``), contacts and forces included
  (`granpack.io.npz`);
- ``"gsd"``: HOOMD-blue's schema, one or more frames (`granpack.io.gsd`; the ``gsd``
  package);
- ``"kratos"``: a Kratos DEM model part (``.mdpa``), as granpack and DEMGen write it
  (`granpack.io.kratos`).

Written (``export(pack, path, format=None)``): ``vtk`` (ParaView), ``lammps`` and
``liggghts`` (a data file and the input that continues the run), ``yade``, ``xyz``,
``csv``, ``parquet``, ``gsd``, ``kratos``, ``mercurydpm``, ``pfc``, ``demengine``.

Contact forces of other codes (``read_contacts``): LIGGGHTS ``pair/gran/local``, LAMMPS
``pair/local`` (`granpack.io.contacts`).

Every writer writes through `granpack._files.atomic_write` (a temporary file and a rename),
so that nothing is half-written if a run is cut off.
"""

from .contacts import COLUMN_NAMES, LAYOUTS, ContactFile, read_contacts
from .particle_file import ParticleFile
from .registry import (
    EXPORT_FORMATS,
    FORMATS,
    FORMER_FORMAT_NAMES,
    READERS,
    WRITERS,
    detect_format,
    export,
    output_paths,
    read_particles,
    write,
)

__all__ = [
    "COLUMN_NAMES",
    "ContactFile",
    "EXPORT_FORMATS",
    "FORMATS",
    "FORMER_FORMAT_NAMES",
    "LAYOUTS",
    "ParticleFile",
    "READERS",
    "WRITERS",
    "detect_format",
    "export",
    "output_paths",
    "read_contacts",
    "read_particles",
    "write",
]
