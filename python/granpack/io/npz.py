"""granpack's own pack files (``Pack.save``; the format is `granpack.packfile`'s), read
as particles."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .._validate import (
    FileFormatError,
)

if TYPE_CHECKING:
    from ..pack import Pack

from .particle_file import ParticleFile


def read_npz(path: Path, dim: int | None) -> ParticleFile:
    from ..analysis.container import Container
    from ..pack import load_pack

    pack = load_pack(path)
    if dim is not None and dim != pack.dim:
        raise FileFormatError(f"{path}: dim = {dim} asked for a {pack.dim}D pack", path=path)
    container = Container.of_pack(pack)
    kind, radius = container.kind, container.radius
    return ParticleFile(
        path=path,
        format="npz",
        positions=np.asarray(pack.positions),
        radii=np.asarray(pack.radii),
        box=pack.box,
        periodic=(kind == "periodic",) * (pack.dim - 1),
        container=kind,
        cylinder_radius=radius,
        lid=container.lid_height,
        contacts=pack.contacts,
        pack=pack,
    )


def write_npz(pack: Pack, path: Path) -> Path:
    """Writes `pack` as granpack's own pack file (`Pack.save`)."""
    return pack.save(path)
