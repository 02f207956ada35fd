"""The kernels of the structure beyond contacts, on arrays: the pair correlation g(r) and
Steinhardt's bond order (`granpack.analysis.structure` applies them to a pack).

Both know the container: distances are minimum images along periodic axes, and g(r) is
edge-corrected for the container's shape (box, periodic cell or cylinder).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from .volumes import _lens_area

__all__ = [
    "BondOrder",
    "CRYSTAL_THRESHOLD",
    "bond_order",
    "pair_correlation",
    "spherical_harmonics",
]

#: Local order a crystalline particle needs: q6 (3D) or psi6 (2D) over its contact neighbours
#: at least this. 3D: 0.45, below the HCP (0.4848) and FCC (0.5745) values (simple cubic,
#: 0.3536, is not close packed and does not count); 2D: 0.7 (the triangular lattice has 1).
CRYSTAL_THRESHOLD = {2: 0.7, 3: 0.45}
#: Solid-like contacts a crystalline particle needs (see bond_order): 4 in 3D, 3 in 2D.
CRYSTAL_MIN_BONDS = {2: 3, 3: 4}
#: A contact is solid-like when the normalised bond-order vectors of its two particles
#: correlate by at least this (ten Wolde, Ruiz-Montero & Frenkel 1996).
SOLID_BOND = 0.7


def spherical_harmonics(l_deg: int, normals) -> np.ndarray:
    """(M, l + 1) complex: Y_lm(n) for m = 0..l, orthonormal on the sphere (the negative
    orders follow from Y_l,-m = (-1)^m conj(Y_lm)).

    Associated Legendre functions by the standard three-term recurrence in l, with the
    Condon-Shortley phase; stable to well past l = 12.
    """
    n = np.asarray(normals, dtype=float)
    out = np.empty((n.shape[0], l_deg + 1), dtype=complex)
    for m, column in _harmonic_columns(l_deg, n):
        out[:, m] = column
    return out


def _harmonic_columns(l_deg: int, normals: np.ndarray):
    """Yields (m, Y_lm(n) for every normal) for m = 0..l: `spherical_harmonics` a column at
    a time, so that a caller that uses one order at a time never holds the whole table."""
    n = normals / np.linalg.norm(normals, axis=1)[:, None]
    x = np.clip(n[:, 2], -1.0, 1.0)
    phi = np.arctan2(n[:, 1], n[:, 0])
    s = np.sqrt(np.maximum(0.0, 1.0 - x * x))
    del n
    for m in range(l_deg + 1):
        # P_m^m = (-1)^m (2m-1)!! s^m, then up in l
        pmm = np.full_like(x, (-1.0) ** m * math.prod(range(1, 2 * m, 2)))
        pmm = pmm * s**m
        if l_deg == m:
            plm = pmm
        else:
            p1 = x * (2 * m + 1) * pmm
            p0 = pmm
            plm = p1
            for ll in range(m + 2, l_deg + 1):
                p0, p1 = p1, ((2 * ll - 1) * x * p1 - (ll + m - 1) * p0) / (ll - m)
                plm = p1
        norm = math.sqrt(
            (2 * l_deg + 1) / (4 * math.pi) * math.factorial(l_deg - m) / math.factorial(l_deg + m)
        )
        yield m, norm * plm * np.exp(1j * m * phi)


class BondOrder(NamedTuple):
    """Steinhardt bond-orientational order over contact neighbours.

    Attributes
    ----------
    l : int
        The order l.
    q : (N,) float64
        Local q_l of each particle (NaN for a particle without contacts). 3D:
        q_l = sqrt(4 pi/(2l + 1) sum_m |q_lm|^2), q_lm = (1/N_b) sum_b Y_lm(n_b) over the
        particle's N_b contact normals (Steinhardt, Nelson & Ronchetti 1983). 2D: psi_l =
        |(1/N_b) sum_b exp(i l theta_b)| (Nelson & Halperin), the 2D bond order.
    global_q : float
        Q_l of the whole pack: the same with q_lm averaged over all bonds (NaN without
        contacts).
    n_bonds : (N,) int64
        N_b, the contact neighbours of each particle.
    solid_bonds : (N,) int64
        Contacts of each particle that are solid-like: the correlation
        s_ij = Re(sum_m q_lm(i) q_lm(j)*) / (|q(i)| |q(j)|) (2D: of psi_l) is >= 0.7.
    crystal : (N,) bool
        Crystalline: q >= ``threshold`` and solid_bonds >= ``min_bonds``. The bond
        correlation keeps the few-bond noise of q out: with 4-6 random bonds q is 0.4-0.5
        by chance, but such a particle's neighbours do not share its orientation.
    crystal_fraction : float
        Fraction of all particles that are crystalline (-).
    threshold : float
    min_bonds : int
    """

    l: int  # noqa: E741
    q: np.ndarray
    global_q: float
    n_bonds: np.ndarray
    solid_bonds: np.ndarray
    crystal: np.ndarray
    crystal_fraction: float
    threshold: float
    min_bonds: int


#: Contacts per block when the bond correlation is summed: the temporaries then stay a
#: few megabytes at any pack size, where the whole (contacts x orders) complex tables
#: took about 1.8 KB a particle.
_BLOCK = 1 << 14


def _column_sum(v: np.ndarray, columns: int) -> complex:
    """The sum of one column `v` of a `columns`-wide table, rounded as numpy's sum of
    the whole table down its rows: term after term where the table has several columns,
    pairwise where it has one (then it is one run). Q_l keeps its value to the bit."""
    if columns == 1:
        return np.sum(v)
    return np.add.reduce(np.broadcast_to(v[:, None], (v.shape[0], 2)), axis=0)[0]


def bond_order(
    i, j, normals, n: int, d: int, l_deg: int = 6, threshold=None, min_bonds=None
) -> BondOrder:
    """Bond order from particle-particle contacts (i, j, unit normal i -> j); see
    :class:`BondOrder`. Each contact is a bond of both particles (of j with -n)."""
    i = np.asarray(i, dtype=np.int64)
    j = np.asarray(j, dtype=np.int64)
    nrm = np.asarray(normals, dtype=float)
    ends = np.concatenate([i, j])
    nb = np.bincount(ends, minlength=n)
    threshold = CRYSTAL_THRESHOLD[d] if threshold is None else float(threshold)
    min_bonds = CRYSTAL_MIN_BONDS[d] if min_bonds is None else int(min_bonds)
    if d == 2:
        theta = np.arctan2(nrm[:, 1], nrm[:, 0])
        columns = iter([(0, np.exp(1j * l_deg * theta))])
        w = np.ones(1)
        fac = 1.0
    else:
        columns = _harmonic_columns(l_deg, nrm.reshape(-1, 3))
        w = np.full(l_deg + 1, 2.0)
        w[0] = 1.0  # orders m and -m have equal |q_lm|
        fac = 4.0 * math.pi / (2 * l_deg + 1)
    # j's bond is along -n: Y_lm(-n) = (-1)^l Y_lm(n)
    sign = (-1.0) ** l_deg
    orders = w.shape[0]
    qlm = np.empty((n, orders), dtype=complex)
    glm = np.empty(orders, dtype=complex)
    with np.errstate(invalid="ignore", divide="ignore"):
        # one order at a time, each bond's term in the order of (i ends, then j ends)
        for m, y in columns:
            ym = np.concatenate([y, y * sign])
            del y
            qlm[:, m] = (
                np.bincount(ends, weights=ym.real, minlength=n)
                + 1j * np.bincount(ends, weights=ym.imag, minlength=n)
            ) / nb
            glm[m] = _column_sum(ym, orders) / ym.shape[0] if ym.shape[0] else 0.0
        del ym
        norm2 = np.sum(w * np.abs(qlm) ** 2, axis=1)
        q = np.sqrt(fac * norm2)
        corr = np.empty(i.shape[0])
        for a in range(0, i.shape[0], _BLOCK):
            ib, jb = i[a : a + _BLOCK], j[a : a + _BLOCK]
            corr[a : a + _BLOCK] = np.sum(w * (qlm[ib] * np.conj(qlm[jb])).real, axis=1) / np.sqrt(
                norm2[ib] * norm2[jb]
            )
    if ends.shape[0]:
        global_q = float(math.sqrt(fac * np.sum(w * np.abs(glm) ** 2)))
    else:
        global_q = math.nan
    q = np.where(nb > 0, q, np.nan)
    solid = np.nan_to_num(corr, nan=-1.0) >= SOLID_BOND
    solid_bonds = np.bincount(i[solid], minlength=n) + np.bincount(j[solid], minlength=n)
    crystal = (solid_bonds >= min_bonds) & (np.nan_to_num(q, nan=-1.0) >= threshold)
    return BondOrder(
        l_deg,
        q,
        global_q,
        nb,
        solid_bonds,
        crystal,
        float(np.mean(crystal)),
        threshold,
        min_bonds,
    )


def _pairs_within(x, r_max: float, container, chunk: int = 512):
    """Yields difference vectors (K, D) x_j - x_i (minimum image) of the pairs i < j closer
    than r_max, in chunks, with the vertical sweep: particles sorted by height, each compared
    only with those above it within r_max."""
    order = np.argsort(x[:, -1], kind="stable")
    xs = x[order]
    z = xs[:, -1]
    n = xs.shape[0]
    hi_idx = np.searchsorted(z, z + r_max, side="right")
    start = 0
    while start < n:
        stop = min(n, start + chunk)
        top = int(hi_idx[start:stop].max())
        a = xs[start:stop]
        b = xs[start:top]
        dx = container.minimum_image(b[None, :, :] - a[:, None, :])
        ia = np.arange(start, stop)[:, None]
        ib = np.arange(start, top)[None, :]
        dist2 = np.sum(dx * dx, axis=-1)
        keep = (ib > ia) & (dist2 < r_max * r_max)
        yield dx[keep]
        start = stop


def _overlap_volume(dx, container) -> np.ndarray:
    """gamma(h): the volume of the container intersected with itself shifted by h (the
    translation edge correction), for difference vectors (K, D)."""
    d = container.dim
    height = container.height - np.abs(dx[:, -1])
    if container.radius is not None:
        s = np.hypot(dx[:, 0], dx[:, 1])
        big_r = container.radius
        base = _lens_area(np.full_like(s, big_r), big_r, s)
    else:
        base = np.ones(dx.shape[0])
        for k in range(d - 1):
            ext = container.hi[k] - container.lo[k]
            base = base * (ext if container.periodic[k] else ext - np.abs(dx[:, k]))
    return np.maximum(base, 0.0) * np.maximum(height, 0.0)


#: The smallest r_max of rdf, in units of the smallest radius (g is 0 below that radius
#: in any pack: two centres lie at least the larger radius apart).
R_MAX_FLOOR = 0.01


def pair_correlation(x, container, r_max: float, bins: int) -> tuple[np.ndarray, np.ndarray]:
    """g(r) of centres in a container, translation edge-corrected (Ohser & Stoyan 1981).

    With gamma(h) = |W ∩ (W + h)| the volume the container W shares with its copy shifted by
    h (the product of L_k - |h_k| over the walled axes in a box, the lens of two discs of
    radius R times H - |h_z| in a cylinder, L_k along a periodic axis),

        g(r) = V^2 / (N (N - 1)) sum_{i != j, |h_ij| in bin} 1/gamma(h_ij) / V_shell(bin),

    which is unbiased for a statistically homogeneous pack in any window, so g -> 1 at large
    r in the bulk. V_shell = 4/3 pi (r_2^3 - r_1^3) (3D) or pi (r_2^2 - r_1^2) (2D).
    """
    n, d = x.shape
    edges = np.linspace(0.0, r_max, bins + 1)
    acc = np.zeros(bins)
    for dx in _pairs_within(x, r_max, container):
        dist = np.sqrt(np.sum(dx * dx, axis=1))
        w = 1.0 / _overlap_volume(dx, container)
        k = np.minimum((dist / r_max * bins).astype(np.int64), bins - 1)
        acc += np.bincount(k, weights=w, minlength=bins)
    # the shells and the container in units of r_max^D: no bin underflows however small
    # r_max, and V^2 never overflows however large the container
    rel = np.linspace(0.0, 1.0, bins + 1)
    if d == 3:
        shell = 4.0 / 3.0 * math.pi * (rel[1:] ** 3 - rel[:-1] ** 3)
    else:
        shell = math.pi * (rel[1:] ** 2 - rel[:-1] ** 2)
    vol = container.volume
    vol_rel = math.exp(math.log(vol) - d * math.log(r_max))
    g = 2.0 * (acc * vol) * vol_rel / (n * (n - 1)) / shell if n > 1 else np.zeros(bins)
    return 0.5 * (edges[1:] + edges[:-1]), g
