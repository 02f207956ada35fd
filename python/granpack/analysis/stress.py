"""Stress of a pack from its contact forces (Love-Weber), and K0.

With the force f_c that contact c exerts on its second body (particle j, or the wall) and
its branch vector l_c (centre i to centre j, by the minimum image in a periodic cell; centre
to the contact point for a wall contact),

    sigma_ab = (1/V) sum_c f_c,a l_c,b       (compression positive),

V the container's volume up to H_top. A pair pushed together has f along +n and l along +n,
so a compressive contact adds a positive n (x) n. Wall contacts are part of the sum, so that
sigma V is the whole pack's virial: in static equilibrium (no resultant force on any
particle) sum_c l_c (x) f_c = -sum_i m_i x_i (x) g + sum_w x_w (x) f_w (x_w the wall contact
points, f_w the forces on the walls); see the tests' static-equilibrium check.
"""

from __future__ import annotations

import numpy as np

__all__ = ["contact_forces", "love_weber", "k0"]


def contact_forces(normal, force_normal, force_tangential) -> np.ndarray:
    """(M, D) force of each contact on its second body (N): f_n n + f_t."""
    n = np.asarray(normal, dtype=float)
    fn = np.asarray(force_normal, dtype=float)
    ft = np.asarray(force_tangential, dtype=float)
    return fn[:, None] * n + ft


def love_weber(forces, branches, volume: float, symmetric: bool = True) -> np.ndarray:
    """sigma = (1/V) sum_c f_c (x) l_c (Pa in 3D; N/m in 2D), compression positive.

    Parameters
    ----------
    forces : (M, D) forces on the second body of each contact (N)
    branches : (M, D) branch vectors (m)
    volume : float
        V (m^3; m^2 in 2D), > 0.
    symmetric : bool
        Return the symmetric part (default); the antisymmetric part is the resultant torque
        density and vanishes in moment equilibrium.
    """
    f = np.asarray(forces, dtype=float)
    b = np.asarray(branches, dtype=float)
    s = f.T @ b / volume
    return 0.5 * (s + s.T) if symmetric else s


def k0(stress) -> float:
    """K0 = mean horizontal normal stress / vertical normal stress (-): (s_xx + s_yy)/(2 s_zz)
    in 3D, s_xx/s_yy in 2D. NaN when the vertical stress is not positive."""
    s = np.asarray(stress, dtype=float)
    d = s.shape[0]
    v = s[d - 1, d - 1]
    if not (np.isfinite(v) and v > 0.0):
        return float("nan")
    return float(np.trace(s[: d - 1, : d - 1]) / (d - 1) / v)
