"""Structure beyond contacts: the pair correlation g(r) and Steinhardt's bond order of a
pack or of arrays (the kernels on arrays are in `granpack.analysis.order`).

Both know the container: distances are minimum images along periodic axes, and g(r) is
edge-corrected for the container's shape (box, periodic cell or cylinder).
"""

from __future__ import annotations

from typing import Unpack

import numpy as np

from .._validate import InvalidParameterError, as_int, as_real
from .container import Container
from .order import CRYSTAL_THRESHOLD as CRYSTAL_THRESHOLD
from .order import R_MAX_FLOOR, bond_order, pair_correlation
from .order import BondOrder as BondOrder
from .order import spherical_harmonics as spherical_harmonics
from .system import ContainerArgs, System

__all__ = ["rdf", "steinhardt"]


def rdf(
    positions,
    radii=None,
    *,
    r_max: float | None = None,
    bins: int = 100,
    margin: float = 0.1,
    **where: Unpack[ContainerArgs],
) -> tuple[np.ndarray, np.ndarray]:
    """Pair correlation function g(r) of the particle centres, edge-corrected.

    Parameters
    ----------
    positions : (N, D) array, or a System / Pack / ParticleFile (then leave out radii and box)
        Centres (m).
    radii : (N,) array
        Radii (m), > 0.
    r_max : float, optional
        Largest distance (m), from a hundredth of the smallest radius (below the smallest
        radius g is 0 in any pack) to half the container's smallest extent (its height,
        its side, or its diameter). Default: 3 mean diameters (6 mean radii), at most
        that half extent; a window whose half extent is below the contact distance
        2 r_min (where g is 0 by construction) is refused, naming ``margin``.
    bins : int
        Number of bins of equal width from 0 to r_max (default 100; 1 to 100 000).
    margin : float
        Only the centres in the core window count (inset by ``margin`` from the floor, from
        H_top and from every wall, as phi_core's; none along a periodic axis), so that the
        loose top and the layers at the walls do not bias the mean density. Default 0.1 m.


    Other Parameters
    ----------------
    box, periodic, cylinder_radius, container, contacts : optional
        The container, as in :func:`granpack.microstructure` (default: a Pack's own; for
        arrays, the bounding box). Periodic axes use the minimum image.
    Returns
    -------
    r : (bins,) float64
        Bin centres (m).
    g : (bins,) float64
        g(r) of the window's centres by the translation edge correction for the window (see
        ``pair_correlation``): tends to 1 at large r in the bulk; 0 below the closest
        approach; peaks at the neighbour shells.
    """
    prep = System.from_any(positions, radii=radii, **where)
    n_bins = as_int("bins", bins, 1, 100_000)
    m = as_real("margin", margin, 0.0, unit="m")
    cont, keep = _core_window(prep.container, prep.x, m)
    extents = [cont.height]
    if cont.radius is not None:
        extents.append(2.0 * cont.radius)
    else:
        extents += [float(cont.hi[k] - cont.lo[k]) for k in range(prep.d - 1)]
    limit = 0.5 * min(extents)
    floor = R_MAX_FLOOR * float(np.min(prep.r))
    if r_max is None:
        contact = 2.0 * float(np.min(prep.r))
        if limit < contact:
            # no two centres come closer than a contact: g would be 0 over every bin
            what = f"margin = {m:g} m: it leaves" if m > 0 else "r_max: the container is"
            raise InvalidParameterError(
                f"invalid {what} a window whose half extent, {limit:.4g} m (the largest "
                f"r_max), is below the contact distance 2 r_min = {contact:.4g} m, where "
                "g(r) is 0 by construction; "
                + ("give a smaller margin" if m > 0 else "analyse a larger pack"),
                parameter="margin" if m > 0 else "r_max",
                value=m if m > 0 else None,
                expected=f"a window whose half extent exceeds {contact:.4g} m",
            )
        r_max = min(6.0 * float(np.mean(prep.r)), limit)
    r_max = as_real("r_max", r_max, unit="m")
    allowed = (
        f"[{floor:.4g}, {limit:.4g}] m (from a hundredth of the smallest radius to half "
        "the container's smallest extent)"
    )
    if not floor <= r_max <= limit:
        raise InvalidParameterError(
            f"invalid r_max = {r_max}: must lie in {allowed}",
            parameter="r_max",
            value=r_max,
            expected=allowed,
        )
    if int(np.sum(keep)) < 2:
        raise InvalidParameterError(
            f"invalid margin = {m}: fewer than two centres lie in the window it leaves",
            parameter="margin",
        )
    return pair_correlation(prep.x[keep], cont, r_max, n_bins)


def _core_window(cont: Container, x: np.ndarray, margin: float):
    """The container inset by margin (see rdf), and which centres lie in it."""
    lo = cont.lo.astype(float).copy()
    hi = cont.hi.astype(float).copy()
    d = lo.shape[0]
    lo[-1] += margin
    hi[-1] -= margin
    radius = None
    if cont.radius is not None:
        radius = cont.radius - margin
        lo[:2] += margin
        hi[:2] -= margin
    else:
        for k in range(d - 1):
            if not cont.periodic[k]:
                lo[k] += margin
                hi[k] -= margin
    if not (np.all(hi > lo) and (radius is None or radius > 0.0)):
        raise InvalidParameterError(
            f"invalid margin = {margin}: it leaves no window inside the container",
            parameter="margin",
        )
    win = Container(cont.kind, lo, hi, cont.periodic, radius)
    if radius is not None:
        ax = lo[:2] + radius
        inside = np.hypot(x[:, 0] - ax[0], x[:, 1] - ax[1]) <= radius
    else:
        inside = np.all((x[:, :-1] >= lo[:-1]) & (x[:, :-1] <= hi[:-1]), axis=1)
    inside &= (x[:, -1] >= lo[-1]) & (x[:, -1] <= hi[-1])
    return win, inside


def steinhardt(
    positions,
    radii=None,
    l: int = 6,  # noqa: E741
    *,
    threshold: float | None = None,
    **where: Unpack[ContainerArgs],
) -> BondOrder:
    """Steinhardt bond order q_l per particle over its contact neighbours, the global Q_l, and
    the crystallised fraction.

    Parameters
    ----------
    positions : (N, D) array, or a System / Pack / ParticleFile (then leave out radii and box)
    radii : (N,) array (m)
    l : int
        The order (default 6; 1 to 16). In 2D the order of psi_l.
    threshold : float, optional
        Local order a crystalline particle needs (default 0.45 in 3D, 0.7 in 2D).

    Other Parameters
    ----------------
    contacts : optional
        As in :func:`granpack.microstructure`; default: a Pack's contacts, or the geometric
        contacts (overlap > 0) of the arrays, across periodic seams by minimum image.
    box, periodic, cylinder_radius, container : optional
        The container, as in :func:`granpack.microstructure`.

    Returns
    -------
    BondOrder
        On ideal lattices (every bond a contact): q6 = 0.5745 (FCC), 0.4848 (HCP), 0.3536
        (simple cubic); psi6 = 1 on the triangular lattice.
    """
    l_deg = as_int("l", l, 1, 16)
    if threshold is not None:
        threshold = as_real("threshold", threshold, 0.0, 1.0)
    prep = System.from_any(positions, radii=radii, **where)
    pp = prep.contacts.particle_pairs()
    nrm = pp.normal / np.linalg.norm(pp.normal, axis=1)[:, None] if len(pp) else pp.normal
    return bond_order(pp.i, pp.j, nrm, prep.n, prep.d, l_deg, threshold)
