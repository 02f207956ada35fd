"""Exact volume (3D) or area (2D) of discs and spheres inside a window."""

from __future__ import annotations

import math

import numpy as np

__all__ = ["window_volumes"]

#: Gauss-Legendre nodes per smooth piece in the 3D sphere-box volume (see window_volumes).
_QUAD_ORDER = 16


def _p(x):
    """int_0^x sqrt(1 - t^2) dt for x in [-1, 1] (odd; P(1) = pi/4)."""
    x = np.clip(x, -1.0, 1.0)
    return 0.5 * (x * np.sqrt(np.maximum(0.0, 1.0 - x * x)) + np.arcsin(x))


def _corner_area(a, b):
    """Area of the unit disc in the quadrant {x > a, y > b}, exact, any real a, b.

    Integrates the chord length over x: where |x| < sqrt(1 - b^2) the chord above y = b is
    sqrt(1 - x^2) - b; where |x| >= sqrt(1 - b^2) it is the whole chord 2 sqrt(1 - x^2) if
    b < 0 and nothing if b >= 0.
    """
    a = np.clip(a, -1.0, 1.0)
    b = np.clip(b, -1.0, 1.0)
    xb = np.sqrt(np.maximum(0.0, 1.0 - b * b))
    lo = np.maximum(a, -xb)
    inner = np.where(lo < xb, (_p(xb) - _p(lo)) - b * (xb - lo), 0.0)
    right = _p(1.0) - _p(np.maximum(a, xb))
    left = np.where(a < -xb, _p(-xb) - _p(a), 0.0)
    return inner + np.where(b < 0.0, 2.0 * (right + left), 0.0)


def _disc_rect_area(rho, x0, x1, y0, y1):
    """Area of a disc of radius rho at the origin inside [x0, x1] x [y0, y1] (broadcasting),
    by inclusion-exclusion of the four quadrant areas."""
    pos = rho > 0.0
    s = np.where(pos, rho, 1.0)
    area = (
        _corner_area(x0 / s, y0 / s)
        - _corner_area(x1 / s, y0 / s)
        - _corner_area(x0 / s, y1 / s)
        + _corner_area(x1 / s, y1 / s)
    )
    return np.where(pos, rho * rho * area, 0.0)


def _ball_box_volume(c, r, lo, hi, order):
    """Volume of spheres (K,) inside the box [lo, hi] (3D), to ~1e-11 relative.

    With the height t = r sin(theta) the slice is a disc of radius r cos(theta), entire in
    theta (t itself would put the branch points of sqrt(r^2 - t^2) next to every cap). The
    slice's area in the rectangle is exact; it is smooth in theta except where the slice
    circle touches a side line or passes a corner (cos(theta) = d/r). Splitting there and
    mapping each piece with theta = a + (b - a)(1 - cos u)/2 turns the (theta* - theta)^(3/2)
    end behaviour into a smooth function of u, so Gauss-Legendre converges spectrally
    (16 nodes: ~1e-11 of the sphere's volume at worst over random placements).
    """
    k = c.shape[0]
    t_lo = np.clip((lo[2] - c[:, 2]) / r, -1.0, 1.0)
    t_hi = np.clip((hi[2] - c[:, 2]) / r, -1.0, 1.0)
    a_lo, a_hi = np.arcsin(t_lo), np.arcsin(t_hi)
    x0, x1 = lo[0] - c[:, 0], hi[0] - c[:, 0]
    y0, y1 = lo[1] - c[:, 1], hi[1] - c[:, 1]
    d_lines = np.abs(np.stack([x0, x1, y0, y1], 1))
    d_corners = np.sqrt(
        np.stack([x0 * x0 + y0 * y0, x0 * x0 + y1 * y1, x1 * x1 + y0 * y0, x1 * x1 + y1 * y1], 1)
    )
    dist = np.concatenate([d_lines, d_corners], 1)
    s = np.arccos(np.clip(dist / r[:, None], 0.0, 1.0))
    brk = np.concatenate([a_lo[:, None], a_hi[:, None], s, -s], 1)
    brk = np.sort(np.clip(brk, a_lo[:, None], np.maximum(a_lo, a_hi)[:, None]), axis=1)
    ta, tb = brk[:, :-1, None], brk[:, 1:, None]
    xi, wi = np.polynomial.legendre.leggauss(order)
    u = 0.5 * math.pi * (xi + 1.0)
    wu = 0.5 * math.pi * wi
    theta = ta + (tb - ta) * (0.5 * (1.0 - np.cos(u)))
    e = (slice(None), None, None)
    rho = r[e] * np.cos(theta)
    jac = (tb - ta) * (0.5 * np.sin(u) * wu) * rho  # dt = r cos(theta) dtheta
    area = _disc_rect_area(rho, x0[e], x1[e], y0[e], y1[e])
    vol = np.sum(area * jac, axis=(1, 2))
    return np.where(a_hi > a_lo, vol, 0.0).reshape(k)


def window_volumes(positions, radii, lo, hi, order: int = _QUAD_ORDER) -> np.ndarray:
    """Volume (3D, m^3) or area (2D, m^2) of each particle inside the box [lo, hi].

    2D is exact (closed-form circular segments by inclusion-exclusion of quadrant areas).
    3D integrates exact slice areas over the height with piecewise Gauss-Legendre
    quadrature split at every kink (see ``_ball_box_volume``): within ~1e-11 of each sphere's
    volume, far inside the 1e-4 asked of phi_core. Particles wholly inside or outside are not
    integrated.

    Parameters
    ----------
    positions : (N, D) array of centres (m)
    radii : (N,) array (m), > 0
    lo, hi : (D,) arrays, the window's corners (m), hi > lo
    order : int
        Gauss-Legendre nodes per piece in 3D (default 16).

    Returns
    -------
    (N,) float64
    """
    x = np.asarray(positions, dtype=float)
    r = np.asarray(radii, dtype=float)
    lo = np.asarray(lo, dtype=float)
    hi = np.asarray(hi, dtype=float)
    d = x.shape[1]
    full = (math.pi * r * r) if d == 2 else (4.0 / 3.0 * math.pi * r**3)
    inside = np.all((x - r[:, None] >= lo) & (x + r[:, None] <= hi), axis=1)
    outside = np.any((x + r[:, None] <= lo) | (x - r[:, None] >= hi), axis=1)
    out = np.where(inside, full, 0.0)
    cut = ~inside & ~outside
    if np.any(cut):
        c, rc = x[cut], r[cut]
        if d == 2:
            out[cut] = _disc_rect_area(
                rc, lo[0] - c[:, 0], hi[0] - c[:, 0], lo[1] - c[:, 1], hi[1] - c[:, 1]
            )
        else:
            out[cut] = _ball_box_volume(c, rc, lo, hi, order)
    return out
