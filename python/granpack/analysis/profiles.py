"""Depth profiles (horizontal slices) and, in a cylinder, radial profiles (coaxial shells)."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Unpack

import numpy as np

from .._validate import InvalidParameterError, as_int
from .coordination import degrees
from .prepare import MAX_SLICES, stress_slices
from .stress import contact_forces
from .system import System, SystemArgs
from .tensors import _bin_free
from .volumes import cylinder_volumes, slab_volumes

if TYPE_CHECKING:
    import polars as pl

__all__ = ["profiles", "radial_profiles"]


def _z_mech(deg: np.ndarray) -> float:
    n0 = int(np.sum(deg == 0))
    n1 = int(np.sum(deg == 1))
    active = deg.shape[0] - n0 - n1
    return float((np.sum(deg) - n1) / active) if active > 0 else math.nan


def _per_group(group: np.ndarray, count: int, deg: np.ndarray):
    z = np.full(count, np.nan)
    zm = np.full(count, np.nan)
    npart = np.bincount(group, minlength=count)
    for k in range(count):
        sel = group == k
        if npart[k]:
            z[k] = float(np.mean(deg[sel]))
            zm[k] = _z_mech(deg[sel])
    return npart, z, zm


def profiles(pack=None, *, slices: int = 10, **where: Unpack[SystemArgs]) -> pl.DataFrame:
    """Depth profile of a pack: one row per horizontal slice, from the floor to H_top.

    Parameters
    ----------
    pack : granpack.Pack, granpack.ParticleFile or System, optional
        As in :func:`granpack.microstructure`.
    slices : int
        Number of slices of equal thickness (default 10; 1 to 10 000).

    Other Parameters
    ----------------
    positions, radii, contacts, box, periodic, cylinder_radius, container : optional
        As in :func:`granpack.microstructure`: the particles as arrays, and the container.

    Returns
    -------
    polars.DataFrame
        Columns:

        - ``z_lo``, ``z_hi``: the slice's bounds (m);
        - ``phi``: solid volume inside the slice (exact spherical or circular segments; the
          bottom slice also holds what overlaps the floor) over the container's
          cross-section x thickness (-). The thickness-weighted mean of the slices is the
          pack's phi;
        - ``n_particles``, ``Z``, ``Z_m``: the particles whose centres lie in the slice, their
          mean particle-particle contacts and the one-pass mechanical coordination
          (2 N_c - N_1)/(N_p - N_0 - N_1) over them (NaN for an empty slice; Z_m also
          NaN where no particle of the slice has two or more contacts, as
          ``Microstructure.z_mech`` for the whole pack);
        - ``n_contacts``, ``fabric_zz``, ``f0``: the particle-particle contacts whose contact
          point (branch midpoint) lies in the slice, their fabric R_zz = <n_z^2> and bin-free
          mean normal force f0 (N; NaN without forces);
        - ``stress_zz``: the vertical Love-Weber stress of the slice (Pa; N/m in 2D), every
          contact (walls included) given to the slice of its contact point.
    """
    n_s = as_int("slices", slices, 1, MAX_SLICES)
    prep = System.from_any(pack, **where)
    x, r, d, cont = prep.x, prep.r, prep.d, prep.container
    c = prep.contacts
    edges = np.linspace(prep.lo[-1], prep.hi[-1], n_s + 1)
    area = cont.base_area
    phi = np.empty(n_s)
    for k in range(n_s):
        z0 = -math.inf if k == 0 else edges[k]
        z1 = math.inf if k == n_s - 1 else edges[k + 1]
        phi[k] = float(np.sum(slab_volumes(x, r, z0, z1))) / (area * (edges[k + 1] - edges[k]))
    deg = degrees(c.i, c.j, prep.n)
    group = np.clip(np.searchsorted(edges, x[:, -1], side="right") - 1, 0, n_s - 1)
    npart, z, zm = _per_group(group, n_s, deg)

    pp = c.particle_pairs()
    points = prep.contact_points()
    pp_mask = c.j >= 0
    cz = points[pp_mask, -1]
    cg = np.clip(np.searchsorted(edges, cz, side="right") - 1, 0, n_s - 1)
    n_cont = np.bincount(cg, minlength=n_s)
    nz2 = np.bincount(cg, weights=pp.normal[:, -1] ** 2, minlength=n_s)
    with np.errstate(invalid="ignore", divide="ignore"):
        fabric_zz = np.where(n_cont > 0, nz2 / np.maximum(n_cont, 1), np.nan)
    has_forces = bool(prep.contacts_given and len(pp) and np.any(pp.force_normal > 0.0))
    f0 = np.full(n_s, np.nan)
    szz = np.full(n_s, np.nan)
    if has_forces:
        for k in range(n_s):
            sel = cg == k
            if np.any(pp.force_normal[sel] > 0.0):
                nrm = pp.normal[sel]
                out = _bin_free(nrm, pp.force_normal[sel], pp.force_tangential[sel])
                f0[k] = out.f0 if out is not None else np.nan
        forces = contact_forces(c.normal, c.force_normal, c.force_tangential)
        szz = stress_slices(prep, edges, forces, prep.branches())[:, d - 1, d - 1]
    # polars is imported when a table is made, not with granpack: its wheels need AVX2
    # (a CPU without it crashes on import), and the engine runs on any x86-64 CPU
    import polars as pl

    return pl.DataFrame(
        {
            "z_lo": edges[:-1],
            "z_hi": edges[1:],
            "phi": phi,
            "n_particles": npart.astype(np.int64),
            "Z": z,
            "Z_m": zm,
            "n_contacts": n_cont.astype(np.int64),
            "fabric_zz": fabric_zz,
            "f0": f0,
            "stress_zz": szz,
        }
    )


def radial_profiles(pack=None, *, shells: int = 10, **where: Unpack[SystemArgs]) -> pl.DataFrame:
    """Radial profile of a pack in a cylinder: one row per coaxial shell of equal width, from
    the axis to the wall, over the whole height. It shows the layering the wall imposes.

    Parameters
    ----------
    pack : granpack.Pack, granpack.ParticleFile or System, optional
        As in :func:`granpack.microstructure`; the container must be a cylinder.
    shells : int
        Number of shells (default 10; 1 to 10 000).

    Other Parameters
    ----------------
    positions, radii, contacts, box, cylinder_radius, container : optional
        As in :func:`granpack.microstructure`: the particles as arrays, and the container.

    Returns
    -------
    polars.DataFrame
        ``r_lo``, ``r_hi`` (m, from the axis); ``phi``: the solid volume inside the shell
        (exact, integrated slice by slice; the outer shell also holds what overlaps the
        wall) over pi (r_hi^2 - r_lo^2) (H_top - floor) (-), whose volume-weighted mean is the
        pack's phi; ``n_particles``, ``Z``, ``Z_m`` of the particles whose centres lie in the
        shell.
    """
    n_s = as_int("shells", shells, 1, MAX_SLICES)
    prep = System.from_any(pack, **where)
    cont = prep.container
    if cont.radius is None:
        raise InvalidParameterError(
            f"invalid container = {cont.kind!r}: radial profiles need a cylinder "
            "(give cylinder_radius, or a pack made in a cylinder)",
            parameter="container",
        )
    x, r = prep.x, prep.r
    big_r = cont.radius
    ax = cont.lo[:2] + big_r  # the axis
    edges = np.linspace(0.0, big_r, n_s + 1)
    lo_z, hi_z = -math.inf, math.inf
    reach = big_r + 2.0 * float(np.max(r))
    inside = np.array(
        [0.0]
        + [
            float(np.sum(cylinder_volumes(x, r, ax, reach if k == n_s else edges[k], lo_z, hi_z)))
            for k in range(1, n_s + 1)
        ]
    )
    shell_v = math.pi * (edges[1:] ** 2 - edges[:-1] ** 2) * cont.height
    phi = np.diff(inside) / shell_v
    s = np.hypot(x[:, 0] - ax[0], x[:, 1] - ax[1])
    group = np.asarray(np.clip(np.searchsorted(edges, s, side="right") - 1, 0, n_s - 1))
    c = prep.contacts
    deg = degrees(c.i, c.j, prep.n)
    npart, z, zm = _per_group(group, n_s, deg)
    import polars as pl

    return pl.DataFrame(
        {
            "r_lo": edges[:-1],
            "r_hi": edges[1:],
            "phi": phi,
            "n_particles": npart.astype(np.int64),
            "Z": z,
            "Z_m": zm,
        }
    )
