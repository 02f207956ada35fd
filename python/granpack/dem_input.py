"""Former home of the LAMMPS and LIGGGHTS input that continues a run, kept for one
release: it is now `granpack.io.lammps_input`, beside the data file's writer, and
``container_of(pack)`` is `granpack.analysis.Container.of_pack`. Importing this module
warns."""

from __future__ import annotations

import warnings
from typing import TYPE_CHECKING

from .analysis.container import Container
from .io.lammps_input import (
    SNIPPET_NAME,
    lammps_input,
    lammps_restitution,
    lid_area,
    lid_force,
    lid_height,
    liggghts_input,
    liggghts_restitution,
    tsuji_alpha,
)

if TYPE_CHECKING:
    from .pack import Pack

__all__ = [
    "SNIPPET_NAME",
    "liggghts_restitution",
    "lammps_restitution",
    "tsuji_alpha",
    "lammps_input",
    "liggghts_input",
    "container_of",
    "lid_force",
    "lid_area",
    "lid_height",
]

warnings.warn(
    "granpack.dem_input is now granpack.io.lammps_input (and container_of(pack) is "
    "granpack.analysis.Container.of_pack(pack)); granpack.dem_input will be removed in the "
    "next release",
    DeprecationWarning,
    stacklevel=2,
)


def container_of(pack: Pack) -> tuple[str, float | None]:
    """The pack's container kind and cylinder radius (m, None for the others); now
    ``Container.of_pack(pack)`` (its ``kind`` and ``radius``)."""
    c = Container.of_pack(pack)
    return c.kind, c.radius
