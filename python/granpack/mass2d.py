"""The two 2D mass conventions side by side: `granpack.paper.mass2d`, under the name it
had before the paper's reproduction became a package (kept for existing scripts)."""

from .paper.mass2d import (
    OTHER,
    case_dir,
    convention_table,
    lammps_phi,
    other_convention_tasks,
    report_lines,
)

__all__ = [
    "OTHER",
    "case_dir",
    "lammps_phi",
    "other_convention_tasks",
    "convention_table",
    "report_lines",
]
