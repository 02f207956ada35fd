"""Local packing fraction per particle from the radical (power, Laguerre) Voronoi
tessellation, through the optional ``pyvoro2`` package (``pip install "granpack[voronoi]"``),
a maintained wrapper of Voro++ with power diagrams in 2D and 3D, boxes and per-axis periodic
cells."""

from __future__ import annotations

from typing import Unpack

import numpy as np

from .._validate import GranpackError, InvalidParameterError
from .system import System, SystemArgs

__all__ = ["local_phi"]


def local_phi(pack=None, **where: Unpack[SystemArgs]) -> np.ndarray:
    """Local packing fraction of each particle: its volume over its radical Voronoi cell.

    The radical tessellation cuts space between two particles at the plane of equal power
    |x - x_i|^2 - r_i^2 = |x - x_j|^2 - r_j^2, so that a cell holds its whole particle for
    non-overlapping particles of any sizes (Gellatly & Finney 1982). The cells tile the
    container (the box up to H_top, or the periodic cell), so the particles' volumes over the
    sum of the cells is the pack's phi.

    Parameters
    ----------
    pack : granpack.Pack, granpack.ParticleFile or System, optional
        As in :func:`granpack.microstructure`; the container must be the box or the
        periodic cell (no cylinder: the tessellation library has no curved walls).

    Other Parameters
    ----------------
    positions, radii, contacts, box, periodic, cylinder_radius, container : optional
        As in :func:`granpack.microstructure`: the particles as arrays, and the container.

    Returns
    -------
    (N,) float64
        phi_i = V_i / V_cell,i (-); in 2D areas.

    Raises
    ------
    GranpackError
        ``pyvoro2`` is not installed, or the container is a cylinder.
    """
    try:
        import pyvoro2
        import pyvoro2.planar
    except ImportError:
        raise GranpackError(
            'local_phi needs the optional package pyvoro2: pip install "granpack[voronoi]"'
        ) from None
    scene = getattr(pack, "scene", None)
    asked = where.get("container") or getattr(scene, "container", None)
    if where.get("cylinder_radius") is not None or asked == "cylinder":
        _no_cylinder()
    prep = System.from_any(pack, **where)
    cont = prep.container
    if cont.kind == "cylinder":
        _no_cylinder()
    bounds = tuple((float(a), float(b)) for a, b in zip(cont.lo, cont.hi, strict=True))
    per = (*cont.periodic, False)
    x = prep.x
    if prep.d == 3:
        domain = pyvoro2.OrthorhombicCell(bounds, periodic=per) if any(per) else pyvoro2.Box(bounds)
        cells = pyvoro2.compute(
            x,
            domain=domain,
            mode="power",
            radii=prep.r,
            output="cells",
            return_vertices=False,
            return_faces=False,
            return_adjacency=False,
        )
        key = "volume"
    else:
        planar = pyvoro2.planar
        domain = planar.RectangularCell(bounds, periodic=per) if any(per) else planar.Box(bounds)
        cells = planar.compute(x, domain=domain, mode="power", radii=prep.r, output="cells")
        key = "area"
    cell = np.full(prep.n, np.nan)
    for c in cells:
        cell[int(c["id"])] = float(c[key])
    return prep.vol / cell


def _no_cylinder() -> None:
    raise InvalidParameterError(
        "invalid container = 'cylinder': the radical Voronoi tessellation is available "
        "for the box and the periodic cell only",
        parameter="container",
    )
