"""Plain ``x y (z) r`` text (`granpack.analysis.read_xyzr`)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    pass

from .particle_file import ParticleFile


def read_xyzr_file(path: Path, dim: int | None) -> ParticleFile:
    from ..analysis import read_xyzr

    x, r, d = read_xyzr(path, dim=dim)
    return ParticleFile(path=path, format="xyzr", positions=x, radii=r)
