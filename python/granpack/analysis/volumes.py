"""Exact volume (3D) or area (2D) of discs and spheres inside a window."""

from __future__ import annotations

import math

import numpy as np

__all__ = ["window_volumes", "slab_volumes", "cylinder_volumes", "container_window_volumes"]

#: Gauss-Legendre nodes per smooth piece in the 3D sphere-box volume (see window_volumes).
_QUAD_ORDER = 16

#: Spheres integrated at a time: the quadrature holds about 20 arrays of (rows, 17 pieces,
#: order) float64, some 45 KB a row, so that blocks of 512 cap it near 23 MB whatever the
#: pack's size. Each row's sum is the same in any block, so the volumes do not depend on it.
_QUAD_ROWS = 512


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
    x0, x1 = lo[0] - c[:, 0], hi[0] - c[:, 0]
    y0, y1 = lo[1] - c[:, 1], hi[1] - c[:, 1]
    d_lines = np.abs(np.stack([x0, x1, y0, y1], 1))
    d_corners = np.sqrt(
        np.stack([x0 * x0 + y0 * y0, x0 * x0 + y1 * y1, x1 * x1 + y0 * y0, x1 * x1 + y1 * y1], 1)
    )
    dist = np.concatenate([d_lines, d_corners], 1)
    vol, empty = _slice_quadrature(
        c[:, 2],
        r,
        lo[2],
        hi[2],
        dist,
        order,
        lambda rho, rows: _disc_rect_area(
            rho,
            x0[rows, None, None],
            x1[rows, None, None],
            y0[rows, None, None],
            y1[rows, None, None],
        ),
    )
    return np.where(empty, 0.0, vol).reshape(k)


def _slice_quadrature(cz, r, z0, z1, dist, order, slice_area):
    """The volume of each sphere (centre heights cz, radii r; (K,)) between the heights z0
    and z1 inside a region whose horizontal slice at radius rho has the area
    ``slice_area(rho, rows)`` (rho (k, pieces, order) for the spheres ``rows``, a slice of
    the K; the area of the same shape out), and whether the sphere misses the slab (then
    the volume is not used). The spheres go in blocks of ``_QUAD_ROWS``.

    With the height t = r sin(theta) the slice is a disc of radius r cos(theta). The
    integrand is smooth in theta except where the slice circle reaches a distance of
    ``dist`` ((K, m): a side, a corner, the cylinder's wall), cos(theta) = dist / r; the
    integral is split there and each piece mapped by theta = a + (b - a)(1 - cos u)/2, so
    that Gauss-Legendre with `order` nodes converges spectrally (see _ball_box_volume).
    """
    k = len(cz)
    vol = np.empty(k)
    empty = np.empty(k, dtype=bool)
    for start in range(0, k, _QUAD_ROWS):
        rows = slice(start, min(k, start + _QUAD_ROWS))
        vol[rows], empty[rows] = _slice_quadrature_rows(
            cz[rows], r[rows], z0, z1, dist[rows], order, slice_area, rows
        )
    return vol, empty


def _slice_quadrature_rows(cz, r, z0, z1, dist, order, slice_area, rows):
    """`_slice_quadrature` for the block of spheres `rows` (cz, r and dist already cut to
    it); ``slice_area(rho, rows)`` is its slices' area."""
    t_lo = np.clip((z0 - cz) / r, -1.0, 1.0)
    t_hi = np.clip((z1 - cz) / r, -1.0, 1.0)
    a_lo, a_hi = np.arcsin(t_lo), np.arcsin(t_hi)
    kinks = np.arccos(np.clip(dist / r[:, None], 0.0, 1.0))
    brk = np.concatenate([a_lo[:, None], a_hi[:, None], kinks, -kinks], 1)
    brk = np.sort(np.clip(brk, a_lo[:, None], np.maximum(a_lo, a_hi)[:, None]), axis=1)
    ta, tb = brk[:, :-1, None], brk[:, 1:, None]
    xi, wi = np.polynomial.legendre.leggauss(order)
    u = 0.5 * math.pi * (xi + 1.0)
    wu = 0.5 * math.pi * wi
    theta = ta + (tb - ta) * (0.5 * (1.0 - np.cos(u)))
    rho = r[:, None, None] * np.cos(theta)
    jac = (tb - ta) * (0.5 * np.sin(u) * wu) * rho  # dt = r cos(theta) dtheta
    return np.sum(slice_area(rho, rows) * jac, axis=(1, 2)), ~(a_hi > a_lo)


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


def _slab_volume_3d(z, r, z0, z1):
    """Volume of spheres of radius r at heights z between the planes z0 and z1, exact:
    V(u) = pi (r^2 u - u^3/3) is the volume below u - z within [-r, r], plus the lower half."""

    def below(u):
        u = np.clip(u, -r, r)
        return math.pi * (r * r * u - u**3 / 3.0)

    return np.maximum(below(z1 - z) - below(z0 - z), 0.0)


def _slab_area_2d(y, r, y0, y1):
    """Area of discs of radius r at heights y between y0 and y1, exact (circular segments)."""
    s = np.where(r > 0, r, 1.0)
    return np.maximum(2.0 * r * r * (_p((y1 - y) / s) - _p((y0 - y) / s)), 0.0)


def slab_volumes(positions, radii, z0: float, z1: float) -> np.ndarray:
    """Volume (3D, m^3) or area (2D, m^2) of each particle between the horizontal planes
    z0 < z1 (vertical axis last), in closed form.

    3D: spherical segments, pi (r^2 u - u^3/3) between the cut heights u relative to the
    centre. 2D: circular segments. The lateral position does not enter, so the same holds in
    a periodic cell (a particle across the seam is counted whole) and in a cylinder.

    Returns
    -------
    (N,) float64
    """
    x = np.asarray(positions, dtype=float)
    r = np.asarray(radii, dtype=float)
    z = x[:, -1]
    if x.shape[1] == 2:
        return _slab_area_2d(z, r, z0, z1)
    return _slab_volume_3d(z, r, z0, z1)


def _lens_area(a, big_r, s):
    """Area of the intersection of a disc of radius a with a disc of radius big_r whose
    centres are s apart (broadcasting), exact."""
    a = np.maximum(a, 0.0)
    s = np.abs(s)
    with np.errstate(invalid="ignore", divide="ignore"):
        sa = np.where(s * a > 0, 2.0 * s * a, 1.0)
        sr = np.where(s * big_r > 0, 2.0 * s * big_r, 1.0)
        c1 = np.clip((s * s + a * a - big_r * big_r) / sa, -1.0, 1.0)
        c2 = np.clip((s * s + big_r * big_r - a * a) / sr, -1.0, 1.0)
        k = (-s + a + big_r) * (s + a - big_r) * (s - a + big_r) * (s + a + big_r)
        lens = (
            a * a * np.arccos(c1)
            + big_r * big_r * np.arccos(c2)
            - 0.5 * np.sqrt(np.maximum(k, 0.0))
        )
    inner = math.pi * np.minimum(a, big_r) ** 2
    return np.where(s >= a + big_r, 0.0, np.where(s <= np.abs(big_r - a), inner, lens))


def cylinder_volumes(
    positions, radii, axis, cylinder_radius: float, z0: float, z1: float, order: int = _QUAD_ORDER
) -> np.ndarray:
    """Volume (m^3) of each sphere inside the vertical cylinder of radius R about
    ``axis`` = (x, y), between the planes z0 < z1.

    Each horizontal slice is a disc of radius r cos(theta) at height r sin(theta); its area
    inside the cylinder is the exact lens of two circles. The lens is smooth in theta except
    where the circles touch (r cos(theta) = |R - s| or R + s, s the centre's distance from the
    axis); the height integral is split there and integrated by Gauss-Legendre on each piece
    with the same end mapping as :func:`window_volumes` (~1e-11 of a sphere's volume).
    Spheres wholly inside are not integrated.

    Returns
    -------
    (N,) float64
    """
    x = np.asarray(positions, dtype=float)
    r = np.asarray(radii, dtype=float)
    big_r = float(cylinder_radius)
    s = np.hypot(x[:, 0] - axis[0], x[:, 1] - axis[1])
    seg = _slab_volume_3d(x[:, 2], r, z0, z1)
    out = np.where(s + r <= big_r, seg, 0.0)
    cut = (s + r > big_r) & (s - r < big_r) & (seg > 0.0)
    if not np.any(cut):
        return out
    c, rc, sc = x[cut, 2], r[cut], s[cut]
    dist = np.stack([np.abs(big_r - sc), big_r + sc], 1)
    out[cut], _ = _slice_quadrature(
        c, rc, z0, z1, dist, order, lambda rho, rows: _lens_area(rho, big_r, sc[rows, None, None])
    )
    return out


def container_window_volumes(positions, radii, container, margin: float) -> tuple | None:
    """The core window of a container and each particle's volume inside it.

    The window is inset by ``margin`` from the floor and from H_top; laterally from each
    side wall of the box, by a coaxial cylinder of radius R - margin in the cylinder, and
    not at all along a periodic axis (whose particles are counted whole).

    Returns
    -------
    (volumes (N,), window volume, in_window (N,) bool: centre inside the window), or None
    when the window is empty.
    """
    x = np.asarray(positions, dtype=float)
    r = np.asarray(radii, dtype=float)
    lo, hi = container.lo, container.hi
    z0, z1 = lo[-1] + margin, hi[-1] - margin
    if not z1 > z0:
        return None
    if container.radius is not None:
        rc = container.radius - margin
        if not rc > 0.0:
            return None
        ax = container.axis
        vols = cylinder_volumes(x, r, ax, rc, z0, z1)
        s = np.hypot(x[:, 0] - ax[0], x[:, 1] - ax[1])
        inside = (s <= rc) & (x[:, 2] >= z0) & (x[:, 2] <= z1)
        return vols, math.pi * rc * rc * (z1 - z0), inside
    d = x.shape[1]
    wlo = lo.astype(float).copy()
    whi = hi.astype(float).copy()
    for k in range(d):
        if k == d - 1 or not container.periodic[k]:
            wlo[k] += margin
            whi[k] -= margin
    if not np.all(whi > wlo):
        return None
    if container.any_periodic:
        # periodic axes: the window spans the whole period, and a particle across the seam
        # counts whole; cut only along the walled axes
        big = np.max(r) * 4.0 + 1.0
        cut_lo = wlo.copy()
        cut_hi = whi.copy()
        for k in range(d - 1):
            if container.periodic[k]:
                cut_lo[k] = x[:, k].min() - big
                cut_hi[k] = x[:, k].max() + big
        vols = window_volumes(x, r, cut_lo, cut_hi)
    else:
        vols = window_volumes(x, r, wlo, whi)
    inside = np.all((x >= wlo) & (x <= whi), axis=1)
    return vols, float(np.prod(whi - wlo)), inside
