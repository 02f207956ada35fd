"""MercuryDPM: the ``.data`` file of particle states (what ``DPMBase::writeDataFile``
writes and ``DPMBase::readDataFile`` reads).

The layout is taken from MercuryDPM's source (``Kernel/DPMBase.cc``:
``DPMBase::outputXBallsData`` writes the header, ``DPMBase::readNextDataFile`` reads the
file; ``Kernel/DPMBaseXBalls.icc``: ``DPMBase::outputXBallsDataParticle`` writes a particle),
as of MercuryDPM's master of July 2024. One header line, then one line a particle:

3D (format 14)::

    N time xmin ymin zmin xmax ymax zmax
    x y z vx vy vz r alpha beta gamma wx wy wz info

2D (format 8, ``Mercury2D``; the plane is x-y, gravity along -y as granpack's)::

    N time xmin ymin xmax ymax
    x y vx vy r alpha -wz info

``alpha beta gamma`` are the orientation's Euler angles (2D: the angle about z), written 0
(granpack does not track orientations); the 2D file holds minus the angular velocity about
z (MercuryDPM writes ``-getAngularVelocity().Z`` and reads it back negated); ``info`` is
the species index MercuryDPM reads when ``readSpeciesFromDataFile`` is set, written 0.
The time is 0, the box is the pack's box up to H_top (xmin = ymin = zmin = 0).

MercuryDPM's reader takes the numbers it needs from the header line and ignores the rest
of it (``readNextDataFile`` reads the line into a string stream), so the header carries
granpack's container tag after the box: ``container=periodic lo=... hi=...`` (the
horizontal axes are periodic: add MercuryDPM ``PeriodicBoundary`` objects there), or the
cylinder and its radius. The data file has no place for the material: set the species in
the driver code (``readDataFile("pack.data")`` after the species exists). Every number is
written at full precision (``repr``). A periodic pack's centres are wrapped into [0, L).
"""

from __future__ import annotations

import io
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .._files import atomic_write
from ..analysis.container import Container
from ._text import _format_lines

if TYPE_CHECKING:
    from ..pack import Pack

__all__ = ["write_mercurydpm", "COLUMNS_3D", "COLUMNS_2D"]

#: The columns of a particle line, as MercuryDPM's ``readNextDataFile`` reads them.
COLUMNS_3D = (
    "x",
    "y",
    "z",
    "vx",
    "vy",
    "vz",
    "r",
    "alpha",
    "beta",
    "gamma",
    "wx",
    "wy",
    "wz",
    "info",
)
COLUMNS_2D = ("x", "y", "vx", "vy", "r", "alpha", "-wz", "info")


def write_mercurydpm(pack: Pack, path: str | Path) -> Path:
    """Writes the pack as a MercuryDPM ``.data`` file (format 14 in 3D, 8 in 2D; layout in
    the module docstring), which ``DPMBase::readDataFile`` reads into a ``Mercury3D`` or
    ``Mercury2D`` problem. Returns the path."""
    from ._text import lammps_positions

    s = pack.scene
    d = s.dim
    x = lammps_positions(pack)
    v = np.asarray(pack.velocities, dtype=np.float64)
    r = np.asarray(pack.radii, dtype=np.float64)
    spins = np.asarray(pack.spins, dtype=np.float64)
    lo, hi = pack.box
    container = Container.of_pack(pack)
    n = len(pack)
    out = io.StringIO()
    box = " ".join(repr(float(a)) for a in (*lo, *hi))
    out.write(f"{n} 0.0 {box} granpack: dim={d} {container.tag_words()}\n")
    if d == 3:
        cols = [*x.T, *v.T, r, *np.zeros((3, n)), *spins.T]
    else:
        # 0.0 - w: never a negative zero
        cols = [x[:, 0], x[:, 1], v[:, 0], v[:, 1], r, np.zeros(n), 0.0 - spins]
    out.write(_format_lines(" ".join(["{}"] * len(cols)) + " 0", *cols))
    return atomic_write(Path(path), out.getvalue().encode())
