"""``granpack export``: a saved pack in another program's format."""

from __future__ import annotations

import argparse

from .._console import Console
from .._outputs import sweep_written
from .._validate import GranpackError
from . import _args

HELP = (
    "write a pack for ParaView (vtk), LAMMPS, LIGGGHTS, YADE, OVITO/ASE (xyz), "
    "OVITO/freud/HOOMD-blue (gsd), csv, parquet, or the DEM codes Kratos, MercuryDPM, "
    "PFC and DEM-Engine"
)
DESCRIPTION = (
    "Writes a saved pack as a VTK XML unstructured grid (.vtu: particles "
    "with radius, layer, velocity, spin, contact count; contacts as lines with their "
    "forces; the container in <stem>.container.vtu), a LAMMPS data file for atom_style "
    "sphere with in.granpack, the input that continues the run in LAMMPS (lammps) or "
    "LIGGGHTS (liggghts), YADE's text format (yade), extended XYZ (xyz), a gsd file "
    "for OVITO, freud and HOOMD-blue (gsd), CSV/Parquet tables of particles and "
    "contacts, or the particles for another DEM code: a Kratos DEM model part (kratos, "
    ".mdpa), a MercuryDPM .data file (mercurydpm), a PFC 7 command file (pfc) or "
    "DEM-Engine's clump CSV with its sphere templates (demengine)."
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    e = parser
    _args.add_pack(e, "a pack file (.npz)")
    e.add_argument(
        "--format",
        choices=(
            *("vtk", "lammps-data", "liggghts", "yade", "xyz", "csv", "parquet", "gsd"),
            *("kratos", "mercurydpm", "pfc", "demengine", "npz"),
            "lammps",  # the former name of lammps-data, until the next release
        ),
        default=None,
        help="output format (default: from the suffix of --out)",
    )
    _args.add_out(e, "output file (default: beside PACK)")


def run(args: argparse.Namespace, console: Console) -> int:
    from ..io import EXPORT_FORMATS as FORMATS
    from ..io import FORMER_FORMAT_NAMES, export
    from ..pack import load_pack

    fmt = args.format
    if fmt is None and args.out is None:
        raise GranpackError(
            "give --format (vtk, lammps-data, liggghts, yade, xyz, csv, parquet, gsd, kratos, "
            "mercurydpm, pfc, demengine, npz) or an --out file name"
        )
    out = args.out
    if out is None:
        out = args.pack.with_suffix(FORMATS[FORMER_FORMAT_NAMES.get(fmt, fmt)])
    pack = load_pack(args.pack)
    files = export(pack, out, fmt, refuse=[args.pack], parameter="--out")
    for f in files:
        console.say(str(f))
    sweep_written(files, console)
    return 0
