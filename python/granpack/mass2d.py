"""The former home of `granpack.paper.mass2d` (the two 2D mass conventions side by side),
from before the paper's reproduction became a package. Importing it still works for one
release, with a `DeprecationWarning`; import `granpack.paper.mass2d` in new code."""

import warnings

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

warnings.warn(
    "granpack.mass2d is now granpack.paper.mass2d; import from granpack.paper.mass2d in"
    " new code: granpack.mass2d is removed in the next release",
    DeprecationWarning,
    stacklevel=2,
)
