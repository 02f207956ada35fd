"""Microstructure of a pack: packing fraction, coordination, fabric and contact-force tensors.

The definitions are those of the paper's section 3, read as the documentation's
microstructure page gives them (docs/microstructure.md); D is the dimension (2: discs,
vertical y; 3: spheres, vertical z). Every quantity is computed with numpy over whole
arrays (no Python loop over particles or contacts).

Entry points
------------
``microstructure(pack)`` or ``microstructure(positions=..., radii=..., box=...)`` returns a
:class:`Microstructure`. The building blocks are public too: :func:`fabric_tensor`,
:func:`force_tensors` (bin-free), :func:`force_tensors_binned` (the paper's equal-area
orientation groups), :func:`anisotropy_tensor`, :func:`eigen_sorted`, :func:`phi_d`,
:func:`anisotropy_measures`, :func:`empirical_z`, :func:`void_ratio`,
:func:`phi_from_void_ratio`, :func:`window_volumes` and :func:`read_xyzr` (``x y z r`` text
files from other DEM codes).

``granpack.microstructure`` is the function (the package re-exports it), so these helpers are
also attached to it as attributes: ``granpack.microstructure.read_xyzr(path)`` works as well
as ``from granpack.microstructure import read_xyzr``.

Readings of the paper
---------------------
- Eq. 2 writes R = 1/(2 N_c) sum n n over both particles' normals; with one normal per
  contact that is R = 1/N_c sum n n (trace 1), which is what is computed.
- Eqs. 10-11 drop the 1/f0 and the identity; the standard forms are used:
  a^n = 15/2 (F^n/f0 - I/3) in 3D, 4 (F^n/f0 - I/2) in 2D (Ouadfel & Rothenburg 2001;
  Rothenburg & Bathurst 1989); a^t = 5 F^t/f0 (3D), 4 F^t/f0 (2D).
- Eq. 17 is garbled in print; Athanasiou-Grivas & Harr's Z = 3(1 + e)/e reproduces the tables.
- Table 1 is garbled; the measures are Curry (Phi_1 - Phi_min)/2, Thornton Phi_1 - Phi_min,
  Ibraim Phi_1/Phi_min and Maeda Z (Phi_1 - Phi_min).

Warnings
--------
:class:`MicrostructureWarning` is emitted (and the affected quantities are NaN) when a
quantity is undefined: no particle-particle contacts (fabric and force tensors), an empty
core window (phi_core), or a fabric so anisotropic that the second-order contact density
1 + a^r_kl n_k n_l is not positive at some contact (bin-free force tensors). Nothing else
warns; in particular a pack given by positions and radii only has NaN force quantities
without a warning (``has_forces`` is False).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import NamedTuple

import numpy as np

from . import _core
from ._validate import (
    FileFormatError,
    GranpackError,
    InvalidParameterError,
    as_int,
    as_real,
    is_number,
)
from .contacts import Contacts

__all__ = [
    "Microstructure",
    "MicrostructureWarning",
    "ForceTensors",
    "microstructure",
    "read_xyzr",
    "fabric_tensor",
    "force_tensors",
    "force_tensors_binned",
    "anisotropy_tensor",
    "anisotropy_magnitude",
    "eigen_sorted",
    "phi_d",
    "anisotropy_measures",
    "empirical_z",
    "void_ratio",
    "phi_from_void_ratio",
    "window_volumes",
    "DEFAULT_N_BINS",
]

#: Factor c_D in a = c_D (T/tr T - I/D) for the fabric and normal-force anisotropies.
ANISOTROPY_FACTOR = {2: 4.0, 3: 7.5}
#: Factor in a^t = c F^t/f0 (5 in 3D, 4 in 2D).
TANGENTIAL_FACTOR = {2: 4.0, 3: 5.0}
#: Default orientation-group resolution of the binned estimator: 36 sectors of 10 degrees in
#: 2D; 10 bands in cos(gamma) x 20 azimuthal sectors (200 equal-area groups) in 3D, about 200
#: contact orientations a group for the paper's packs. The binning bias falls as the square
#: of the group width (about 1 % of a^n in 2D and 4 % in 3D at these defaults).
DEFAULT_N_BINS = {2: 36, 3: 10}
#: Gauss-Legendre nodes per smooth piece in the 3D sphere-box volume (see window_volumes).
_QUAD_ORDER = 16
_AXES = "xyz"
#: Wall ids of the contact table (j < 0).
_MIN_WALL_ID = -5


class MicrostructureWarning(UserWarning):
    """A quantity is undefined for this pack and is reported as NaN (see the module doc)."""


# --------------------------------------------------------------------------------------
# scalar relations
# --------------------------------------------------------------------------------------
def void_ratio(phi):
    """Void ratio e = (1 - phi)/phi (-), float or array like `phi` (phi > 0)."""
    phi = np.asarray(phi, dtype=float)
    out = (1.0 - phi) / phi
    return float(out) if out.ndim == 0 else out


def phi_from_void_ratio(e):
    """Packing fraction phi = 1/(1 + e) (-), the inverse of :func:`void_ratio`."""
    e = np.asarray(e, dtype=float)
    out = 1.0 / (1.0 + e)
    return float(out) if out.ndim == 0 else out


def empirical_z(e) -> dict:
    """The paper's empirical coordination numbers Z(e), eqs. 16-19.

    Parameters
    ----------
    e : float or array
        Void ratio (-), > 0.

    Returns
    -------
    dict
        ``"field"``: 12/(1 + e) (Field 1963); ``"athanasiou"``: 3(1 + e)/e
        (Athanasiou-Grivas & Harr 1982; eq. 17 is garbled in print, this form reproduces the
        paper's tables); ``"yanagisawa"``: 3.183^(2.469 - e) (Yanagisawa 1983);
        ``"chang"``: 13.28 - 8 e (Chang, Misra & Sundaram 1990). Floats for a float `e`.

    Examples
    --------
    >>> {k: round(v, 3) for k, v in empirical_z(0.171).items()}
    {'field': 10.248, 'athanasiou': 20.544, 'yanagisawa': 14.306, 'chang': 11.912}
    """
    e_arr = np.asarray(e, dtype=float)
    # e = 0 (no voids) is the formula's pole: +inf, not an error.
    with np.errstate(divide="ignore"):
        out = {
            "field": 12.0 / (1.0 + e_arr),
            "athanasiou": 3.0 * (1.0 + e_arr) / e_arr,
            "yanagisawa": 3.183 ** (2.469 - e_arr),
            "chang": 13.28 - 8.0 * e_arr,
        }
    if e_arr.ndim == 0:
        return {k: float(v) for k, v in out.items()}
    return out


# --------------------------------------------------------------------------------------
# tensors of contact normals and forces
# --------------------------------------------------------------------------------------
def _unit_rows(name: str, normals) -> np.ndarray:
    n = np.asarray(normals, dtype=float)
    if n.ndim != 2 or n.shape[1] not in (2, 3):
        raise InvalidParameterError(f"invalid {name}: shape {n.shape}, expected (M, 2) or (M, 3)")
    if n.shape[0] == 0:
        raise InvalidParameterError(f"invalid {name}: no contacts (M = 0); the tensor is undefined")
    if not np.all(np.isfinite(n)):
        raise InvalidParameterError(f"invalid {name}: non-finite values")
    norm = np.linalg.norm(n, axis=1)
    if np.any(norm == 0.0):
        raise InvalidParameterError(f"invalid {name}: row {int(np.argmin(norm))} has zero length")
    return n / norm[:, None]


def fabric_tensor(normals) -> np.ndarray:
    """Fabric tensor R_ij = (1/N_c) sum_c n_i n_j (the paper's eq. 2 with one normal per
    contact).

    Parameters
    ----------
    normals : (M, D) array
        Contact normals, M >= 1; rows are normalised to unit length (a zero row is an error).

    Returns
    -------
    (D, D) float64
        Symmetric, positive semi-definite, trace 1; invariant under n -> -n.
    """
    n = _unit_rows("normals", normals)
    return n.T @ n / n.shape[0]


def anisotropy_tensor(tensor) -> np.ndarray:
    """Deviatoric anisotropy a = c_D (T/tr T - I/D), c_3 = 15/2, c_2 = 4.

    For the fabric (tr R = 1) this is a^r = 15/2 R' (3D, eq. 5) or 4 R' (2D); for the
    normal-force tensor (tr F^n = f0) it is a^n. Traceless by construction.

    Parameters
    ----------
    tensor : (D, D) array, D = 2 or 3, with a non-zero trace.

    Returns
    -------
    (D, D) float64
    """
    t = np.asarray(tensor, dtype=float)
    if t.ndim != 2 or t.shape[0] != t.shape[1] or t.shape[0] not in (2, 3):
        raise InvalidParameterError(f"invalid tensor: shape {t.shape}, expected (2, 2) or (3, 3)")
    d = t.shape[0]
    tr = np.trace(t)
    if not np.isfinite(tr) or tr == 0.0:
        raise InvalidParameterError(f"invalid tensor: trace {tr}, must be finite and non-zero")
    return ANISOTROPY_FACTOR[d] * (t / tr - np.eye(d) / d)


def anisotropy_magnitude(a) -> float:
    """Scalar amplitude of a symmetric traceless anisotropy tensor a (-).

    2D: sqrt(a_ij a_ij / 2), the amplitude a of E(theta) = (1 + a cos 2(theta - theta_a))/2pi.
    3D: sqrt(2/3 a_ij a_ij), the amplitude a of the transversely isotropic
    a = a diag(-1/2, -1/2, 1), i.e. E(n) = (1 + a (3 cos^2 gamma - 1)/2)/4pi. NaN in, NaN out.
    """
    a = np.asarray(a, dtype=float)
    s = float(np.sum(a * a))
    return math.sqrt(s / 2.0) if a.shape[0] == 2 else math.sqrt(2.0 * s / 3.0)


def eigen_sorted(tensor) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues (descending) and unit eigenvectors (columns) of the symmetric part of
    `tensor`.

    Each eigenvector's largest-magnitude component is made positive so the result is
    deterministic. A tensor with NaN gives NaN values and vectors.

    Returns
    -------
    values : (D,) float64, Phi_1 >= Phi_2 (>= Phi_3)
    vectors : (D, D) float64, column k belongs to values[k]
    """
    t = np.asarray(tensor, dtype=float)
    d = t.shape[0]
    if not np.all(np.isfinite(t)):
        return np.full(d, np.nan), np.full((d, d), np.nan)
    w, v = np.linalg.eigh(0.5 * (t + t.T))
    order = np.argsort(w)[::-1]
    w, v = w[order], v[:, order]
    big = v[np.argmax(np.abs(v), axis=0), np.arange(d)]
    v = v * np.where(big < 0, -1.0, 1.0)
    return w, v


def phi_d(eigenvalues) -> float:
    """Barreto's (2009) deviatoric fabric measure, eq. 15 (-).

    3D: Phi_d = sqrt((Phi_1 - Phi_2)^2 + (Phi_2 - Phi_3)^2 + (Phi_3 - Phi_1)^2)/sqrt(2).
    2D (the same formula over two eigenvalues): Phi_1 - Phi_2. 0 for an isotropic fabric,
    1 when every contact lies along one line; invariant under rotations.
    """
    w = np.asarray(eigenvalues, dtype=float)
    if w.shape[0] == 2:
        return float(abs(w[0] - w[1]))
    s = (w[0] - w[1]) ** 2 + (w[1] - w[2]) ** 2 + (w[2] - w[0]) ** 2
    return float(math.sqrt(s / 2.0))


def anisotropy_measures(eigenvalues, z: float) -> dict[str, float]:
    """The anisotropy measures of the paper's Table 1 (printed garbled; read as
    docs/microstructure.md gives it).

    Parameters
    ----------
    eigenvalues : (D,) array, descending (Phi_1 first, Phi_min last)
    z : float
        Coordination number used by Maeda's measure.

    Returns
    -------
    dict
        ``curry`` (Phi_1 - Phi_min)/2 (Curry 1956); ``thornton`` Phi_1 - Phi_min (Thornton
        2000); ``ibraim`` Phi_1/Phi_min (Ibraim et al. 2006; +inf when Phi_min = 0, i.e. all
        contacts on one line in 2D); ``maeda`` Z (Phi_1 - Phi_min) (Maeda 2009). In 3D
        Phi_min = Phi_3.
    """
    w = np.asarray(eigenvalues, dtype=float)
    p1, pmin = float(w[0]), float(w[-1])
    if math.isnan(p1) or math.isnan(pmin):
        ibraim = math.nan
    elif pmin > 0.0:
        ibraim = p1 / pmin
    else:
        ibraim = math.inf
    return {
        "curry": (p1 - pmin) / 2.0,
        "thornton": p1 - pmin,
        "ibraim": ibraim,
        "maeda": float(z) * (p1 - pmin),
    }


class ForceTensors(NamedTuple):
    """Contact-force tensors of one estimator (all in N, anisotropies dimensionless).

    Attributes
    ----------
    f0 : float
        Mean normal force over orientation groups of equal weight, eq. 8 (N).
    normal : (D, D) float64
        Normal-force tensor F^n, eq. 9 (N); tr F^n = f0.
    tangential : (D, D) float64
        Tangential-force tensor F^t_ij = <f^t_i n_j>, eq. 13 (N).
    a_n : (D, D) float64
        a^n = c_D (F^n/f0 - I/D), c_3 = 15/2, c_2 = 4; traceless.
    a_t : (D, D) float64
        a^t = c'_D sym(F^t)/f0 (c'_3 = 5, c'_2 = 4), symmetric and traceless: the model of
        eq. 12 has a symmetric a^t, so the antisymmetric part of F^t (zero for a pack in
        moment equilibrium) is left out.
    """

    f0: float
    normal: np.ndarray
    tangential: np.ndarray
    a_n: np.ndarray
    a_t: np.ndarray


def _force_columns(normals, force_normal, force_tangential):
    n = _unit_rows("normals", normals)
    m, d = n.shape
    fn = np.asarray(force_normal, dtype=float)
    ft = np.asarray(force_tangential, dtype=float)
    if fn.shape != (m,):
        raise InvalidParameterError(f"invalid force_normal: shape {fn.shape}, expected ({m},)")
    if ft.shape != (m, d):
        raise InvalidParameterError(
            f"invalid force_tangential: shape {ft.shape}, expected ({m}, {d})"
        )
    if not (np.all(np.isfinite(fn)) and np.all(np.isfinite(ft))):
        raise InvalidParameterError("invalid forces: non-finite values")
    if np.any(fn < 0.0):
        k = int(np.argmin(fn))
        raise InvalidParameterError(f"invalid force_normal[{k}] = {fn[k]}: must be >= 0 (N)")
    if not np.any(fn > 0.0):
        raise InvalidParameterError(
            "invalid force_normal: all zero, so f0 = 0 and a^n, a^t are undefined"
        )
    # Only the part in the tangent plane is a tangential force; dropping a stray normal
    # component also keeps tr F^t = 0 exactly.
    ft = ft - np.sum(ft * n, axis=1)[:, None] * n
    return n, fn, ft


def _finish(f0, fn_tensor, ft_tensor, d) -> ForceTensors:
    a_n = ANISOTROPY_FACTOR[d] * (fn_tensor / f0 - np.eye(d) / d)
    sym = 0.5 * (ft_tensor + ft_tensor.T)
    sym = sym - np.trace(sym) / d * np.eye(d)
    a_t = TANGENTIAL_FACTOR[d] * sym / f0
    return ForceTensors(float(f0), fn_tensor, ft_tensor, a_n, a_t)


def _bin_free(n, fn, ft) -> ForceTensors | None:
    m, d = n.shape
    a_r = ANISOTROPY_FACTOR[d] * (n.T @ n / m - np.eye(d) / d)
    w = 1.0 + np.einsum("ci,ij,cj->c", n, a_r, n)
    if np.min(w) <= 0.0:
        return None
    fn_tensor = (n * (fn / w)[:, None]).T @ n / m
    ft_tensor = (ft / w[:, None]).T @ n / m
    return _finish(np.trace(fn_tensor), fn_tensor, ft_tensor, d)


def force_tensors(normals, force_normal, force_tangential) -> ForceTensors:
    """Bin-free contact-force tensors (Ouadfel & Rothenburg 2001; LAMMPS ``compute fabric``).

    Each contact is weighted by the inverse of the second-order contact density
    w_c = 1 + a^r_kl n_k n_l (a^r from the fabric of the same normals), so that the contact
    average estimates the orientation average of eqs. 8, 9 and 13 with groups of equal weight:

        X^n = (1/N_c) sum_c f_n n n / w_c,   f0 = tr X^n,   F^n = X^n,
        F^t = (1/N_c) sum_c f_t (x) n / w_c  (f_t projected on the tangent plane).

    Parameters
    ----------
    normals : (M, D) array
        Unit contact normals (normalised here).
    force_normal : (M,) array
        Normal force magnitudes (N), >= 0, not all zero.
    force_tangential : (M, D) array
        Tangential force vectors (N), same side as the normal (force on j, normal i -> j).

    Returns
    -------
    ForceTensors

    Raises
    ------
    GranpackError
        On bad shapes, negative or all-zero normal forces, or when w_c <= 0 at some contact
        (a fabric too anisotropic for the second-order density; use the binned estimator).
    """
    n, fn, ft = _force_columns(normals, force_normal, force_tangential)
    out = _bin_free(n, fn, ft)
    if out is None:
        raise GranpackError(
            "fabric too anisotropic for the bin-free estimator: 1 + a^r_kl n_k n_l <= 0 at some "
            "contact; use force_tensors_binned"
        )
    return out


def _orientation_groups(n: np.ndarray, n_bins: int):
    """Equal-area orientation groups of the full circle/sphere.

    2D: `n_bins` sectors of the angle. 3D: `n_bins` bands equal in cos(gamma) (equal area by
    Archimedes' hat-box theorem) times 2 `n_bins` azimuthal sectors. Returns the group of each
    row, the solid angle of each group, its first moment int n dOmega and second moment
    int n n dOmega (exact, so that an isotropic force distribution is reproduced exactly).
    """
    d = n.shape[1]
    two_pi = 2.0 * math.pi
    if d == 2:
        g_count = n_bins
        theta = np.arctan2(n[:, 1], n[:, 0])
        g = np.clip(np.floor((theta + math.pi) / two_pi * g_count).astype(np.int64), 0, g_count - 1)
        e = -math.pi + two_pi * np.arange(g_count + 1) / g_count
        t0, t1 = e[:-1], e[1:]
        omega = t1 - t0
        first = np.stack([np.sin(t1) - np.sin(t0), np.cos(t0) - np.cos(t1)], axis=1)
        cc = (t1 - t0) / 2 + (np.sin(2 * t1) - np.sin(2 * t0)) / 4
        ss = (t1 - t0) / 2 - (np.sin(2 * t1) - np.sin(2 * t0)) / 4
        cs = (np.sin(t1) ** 2 - np.sin(t0) ** 2) / 2
        second = np.stack([np.stack([cc, cs], 1), np.stack([cs, ss], 1)], 1)
        return g, g_count, omega, first, second
    nb, ns = n_bins, 2 * n_bins
    z = np.clip(n[:, 2], -1.0, 1.0)
    phi = np.arctan2(n[:, 1], n[:, 0])
    kb = np.clip(np.floor((z + 1.0) / 2.0 * nb).astype(np.int64), 0, nb - 1)
    ks = np.clip(np.floor((phi + math.pi) / two_pi * ns).astype(np.int64), 0, ns - 1)
    g = kb * ns + ks
    ze = -1.0 + 2.0 * np.arange(nb + 1) / nb
    pe = -math.pi + two_pi * np.arange(ns + 1) / ns
    z0, z1 = np.repeat(ze[:-1], ns), np.repeat(ze[1:], ns)
    p0, p1 = np.tile(pe[:-1], nb), np.tile(pe[1:], nb)

    def s1(z):  # int sqrt(1 - z^2) dz
        return 0.5 * (z * np.sqrt(np.maximum(0.0, 1 - z * z)) + np.arcsin(z))

    def zs1(z):  # int z sqrt(1 - z^2) dz
        return -(np.maximum(0.0, 1 - z * z) ** 1.5) / 3.0

    dz = z1 - z0
    dp = p1 - p0
    i_1mz2 = dz - (z1**3 - z0**3) / 3.0
    i_z2 = (z1**3 - z0**3) / 3.0
    i_s = s1(z1) - s1(z0)
    i_zs = zs1(z1) - zs1(z0)
    i_cos = np.sin(p1) - np.sin(p0)
    i_sin = np.cos(p0) - np.cos(p1)
    i_cc = dp / 2 + (np.sin(2 * p1) - np.sin(2 * p0)) / 4
    i_ss = dp / 2 - (np.sin(2 * p1) - np.sin(2 * p0)) / 4
    i_cs = (np.sin(p1) ** 2 - np.sin(p0) ** 2) / 2
    omega = dz * dp
    first = np.stack([i_s * i_cos, i_s * i_sin, (z1**2 - z0**2) / 2 * dp], axis=1)
    xx, yy, zz = i_1mz2 * i_cc, i_1mz2 * i_ss, i_z2 * dp
    xy, xz, yz = i_1mz2 * i_cs, i_zs * i_cos, i_zs * i_sin
    second = np.stack(
        [np.stack([xx, xy, xz], 1), np.stack([xy, yy, yz], 1), np.stack([xz, yz, zz], 1)], 1
    )
    return g, nb * ns, omega, first, second


def _n_bins(n_bins, d: int) -> int:
    if n_bins is None:
        return DEFAULT_N_BINS[d]
    # 3D has 2 n_bins^2 groups: keep the per-group arrays to a few million entries.
    return as_int("n_bins", n_bins, 1, 100_000 if d == 2 else 1000)


def force_tensors_binned(normals, force_normal, force_tangential, n_bins=None) -> ForceTensors:
    """The paper's binned estimator over equal-area orientation groups (eqs. 8, 9, 13).

    Every contact enters with both orientations, (n, f_n, f_t) and (-n, f_n, -f_t), so the
    result does not depend on which particle is called i. For each group g with solid angle
    dOmega_g (2D: angle), the mean normal force fbar_g and mean tangential force vector
    fbart_g are taken over its contacts; then, over the groups that hold contacts
    (Omega = sum of their dOmega_g, 4 pi or 2 pi when none is empty):

        f0 = sum_g fbar_g dOmega_g / Omega                    (eq. 8)
        F^n = sum_g fbar_g int_g n n dOmega / Omega           (eq. 9)
        F^t = sum_g fbart_g (x) int_g n dOmega / Omega        (eq. 13)

    The exact moments int_g n n dOmega make an isotropic force field give F^n = f0 I/D for
    any grouping; the result converges to the bin-free one as the groups are refined (in 2D
    with an isotropic fabric, E[a^n] = a^n (sin h/h)^2 for sectors of width h). Empty groups
    are left out rather than counted as zero force.

    Parameters
    ----------
    normals, force_normal, force_tangential
        As in :func:`force_tensors`.
    n_bins : int, optional
        2D: number of sectors of the full circle (default 36, 10 degrees). 3D: number of
        bands in cos(gamma); each band has 2 n_bins azimuthal sectors, 2 n_bins^2 groups in
        all (default 10: 200 groups).

    Returns
    -------
    ForceTensors (a_t made traceless: binning leaves a small trace in F^t)
    """
    n, fn, ft = _force_columns(normals, force_normal, force_tangential)
    d = n.shape[1]
    nb = _n_bins(n_bins, d)
    n2 = np.concatenate([n, -n])
    fn2 = np.concatenate([fn, fn])
    ft2 = np.concatenate([ft, -ft])
    g, g_count, omega, first, second = _orientation_groups(n2, nb)
    count = np.bincount(g, minlength=g_count).astype(float)
    sum_fn = np.bincount(g, weights=fn2, minlength=g_count)
    sum_ft = np.stack([np.bincount(g, weights=ft2[:, k], minlength=g_count) for k in range(d)], 1)
    full = count > 0
    fbar = sum_fn[full] / count[full]
    ftbar = sum_ft[full] / count[full][:, None]
    total = np.sum(omega[full])
    f0 = np.sum(fbar * omega[full]) / total
    fn_tensor = np.einsum("g,gij->ij", fbar, second[full]) / total
    ft_tensor = np.einsum("gi,gj->ij", ftbar, first[full]) / total
    if f0 <= 0.0:
        raise InvalidParameterError("invalid force_normal: f0 = 0, a^n and a^t are undefined")
    return _finish(f0, fn_tensor, ft_tensor, d)


# --------------------------------------------------------------------------------------
# exact volume of discs/spheres inside an axis-aligned window
# --------------------------------------------------------------------------------------
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


# --------------------------------------------------------------------------------------
# files from other DEM codes
# --------------------------------------------------------------------------------------
def read_xyzr(path, dim: int | None = None) -> tuple[np.ndarray, np.ndarray, int]:
    """Reads a pack written as text, one particle a line: ``x y z r`` (or ``x y r`` in 2D).

    Blank lines and everything after ``#`` are ignored; commas count as spaces. A 2D pack
    in four columns has one all-zero coordinate column: z (then y is vertical, as LAMMPS
    writes 2D) or y (then z is vertical); that column is dropped.

    Parameters
    ----------
    path : str or Path
    dim : {None, 2, 3}
        None (default): 2 if a three-column file or the z (else y) column is all zero,
        otherwise 3.

    Returns
    -------
    positions : (N, D) float64, vertical axis last (m)
    radii : (N,) float64 (m)
    dim : int

    Raises
    ------
    GranpackError
        Unreadable file, a line that is not 3 or 4 numbers (named by its line number),
        non-finite values, radii <= 0, or a 2D request with no all-zero column.
    """
    path = Path(path)
    if dim is not None and dim not in (2, 3):
        raise InvalidParameterError(f"invalid dim = {dim!r}: must be None, 2 or 3")
    try:
        text = path.read_text()
    except FileNotFoundError:
        raise GranpackError(f"cannot read {path}: no such file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise GranpackError(f"cannot read {path}: {exc}") from None
    rows: list[list[float]] = []
    lines: list[int] = []
    ncol = None
    for lineno, line in enumerate(text.splitlines(), 1):
        body = line.split("#", 1)[0].replace(",", " ").split()
        if not body:
            continue
        if len(body) not in (3, 4) or (ncol is not None and len(body) != ncol):
            want = "4 numbers (x y z r) or 3 (x y r)" if ncol is None else f"{ncol} numbers"
            raise FileFormatError(
                f"{path}:{lineno}: expected {want}, found {len(body)} fields", path=path
            )
        ncol = len(body)
        try:
            vals = [float(v) for v in body]
        except ValueError:
            bad = next(v for v in body if not is_number(v))
            raise FileFormatError(f"{path}:{lineno}: {bad!r} is not a number", path=path) from None
        if not all(math.isfinite(v) for v in vals):
            raise FileFormatError(f"{path}:{lineno}: non-finite value", path=path)
        if vals[-1] <= 0.0:
            raise FileFormatError(f"{path}:{lineno}: radius {vals[-1]} must be > 0 (m)", path=path)
        rows.append(vals)
        lines.append(lineno)
    if not rows:
        raise FileFormatError(f"{path}: no particles (every line is blank or a comment)", path=path)
    a = np.array(rows)
    radii = np.ascontiguousarray(a[:, -1])
    if ncol == 3:
        if dim == 3:
            raise FileFormatError(
                f"{path}: dim = 3 needs four columns x y z r, found three", path=path
            )
        return np.ascontiguousarray(a[:, :2]), radii, 2
    z_zero = bool(np.all(a[:, 2] == 0.0))
    y_zero = bool(np.all(a[:, 1] == 0.0))
    if dim is None:
        dim = 2 if (z_zero or y_zero) else 3
    if dim == 3:
        return np.ascontiguousarray(a[:, :3]), radii, 3
    if z_zero:
        return np.ascontiguousarray(a[:, :2]), radii, 2
    if y_zero:
        return np.ascontiguousarray(a[:, [0, 2]]), radii, 2
    raise FileFormatError(f"{path}: dim = 2 needs an all-zero y or z column; neither is", path=path)


# --------------------------------------------------------------------------------------
# the analysis of one pack
# --------------------------------------------------------------------------------------
def _sym_labels(d: int) -> list[tuple[str, int, int]]:
    return [(_AXES[a] + _AXES[b], a, b) for a in range(d) for b in range(a, d)]


def _full_labels(d: int) -> list[tuple[str, int, int]]:
    return [(_AXES[a] + _AXES[b], a, b) for a in range(d) for b in range(d)]


def _readonly(a):
    if isinstance(a, np.ndarray):
        a.setflags(write=False)
    elif isinstance(a, tuple):
        return tuple(_readonly(b) for b in a)
    return a


def _field(name: str, doc: str) -> property:
    return property(lambda self: self._v[name], doc=doc)


class Microstructure:
    """Microstructure of one pack (SI units). Built by :func:`microstructure`.

    Particle-particle contacts unless a name says otherwise; D = 2 or 3; arrays are
    read-only. Undefined quantities are NaN (see the module doc for when, and which warn).
    ``to_dict()`` flattens everything scalar for a table row.
    """

    def __init__(self, values: dict):
        self._v = {k: _readonly(v) for k, v in values.items()}

    dim = _field("dim", "Spatial dimension D (2 or 3).")
    n_particles = _field("n_particles", "N_p, number of particles.")
    n_contacts = _field("n_contacts", "N_c, number of particle-particle contacts.")
    n_wall_contacts = _field("n_wall_contacts", "N_w, number of particle-wall contacts.")
    n_rattlers = _field(
        "n_rattlers",
        "N_0 + N_1: particles with fewer than two particle-particle contacts (Thornton 2000).",
    )
    has_forces = _field(
        "has_forces",
        "True when the contacts carry forces (a generated pack, or contacts given with some "
        "f_n > 0). False for contacts found from positions and radii: every force quantity "
        "is then NaN, without a warning.",
    )
    h_top = _field("h_top", "H_top = max(z_i + r_i), the pack's height (m) along the vertical.")
    phi_centres = _field(
        "phi_centres",
        "Solid volume over base x (max(z_i) - floor): the packing fraction with the height "
        "measured at the highest centre instead of the highest top (-). The paper's tables "
        "are consistent with this reading (docs/physics.md).",
    )
    box = _field(
        "box",
        "(lo, hi): (D,) arrays of the box used (m); hi[-1] = H_top. The side walls, or the "
        "particles' bounding box when no box was given.",
    )
    phi = _field(
        "phi",
        "Packing fraction: solid volume / (base x (H_top - floor)) (-); 2D: area fraction.",
    )
    phi_core = _field(
        "phi_core",
        "Interior packing fraction (-): volume of the particles inside the window "
        "[lo + m, hi - m] horizontally x [floor + m, H_top - m] vertically (m = core_margin), "
        "counting each particle's part inside the window exactly (closed-form segments in 2D, "
        "exact slice areas integrated to ~1e-11 in 3D; see window_volumes), over the window's "
        "volume. NaN (with a warning) if the window is empty.",
    )
    phi_core_centres = _field(
        "phi_core_centres",
        "The peers' interior fraction (-): whole volumes of the particles whose centres lie in "
        "the core window, over the window's volume (the peers' analyze_dump.py). Biased by "
        "the particles cut by the window's faces; use phi_core for the exact value.",
    )
    void_ratio = _field("void_ratio", "Void ratio e = (1 - phi)/phi (-), from the bulk phi.")
    z = _field("z", "Coordination number Z = 2 N_c/N_p (eq. 1); 0 without contacts.")
    z_walls = _field("z_walls", "Z with wall contacts: (2 N_c + N_w)/N_p.")
    z_mech = _field(
        "z_mech",
        "Mechanical coordination number without rattlers, Z_m = (2 N_c - N_1)/(N_p - N_0 - N_1) "
        "(Thornton 2000), N_k = particles with k particle-particle contacts; 0 when no particle "
        "has two or more contacts.",
    )
    z_empirical = _field(
        "z_empirical",
        "Empirical Z(e) of eqs. 16-19 from the void ratio: dict 'field', 'athanasiou', "
        "'yanagisawa', 'chang' (see empirical_z).",
    )
    fabric = _field(
        "fabric",
        "(D, D) fabric tensor R_ij = (1/N_c) sum n_i n_j (eq. 2); trace 1. NaN without contacts.",
    )
    fabric_deviator = _field("fabric_deviator", "(D, D) deviator R' = R - I/D (eq. 6).")
    a_r = _field(
        "a_r", "(D, D) fabric anisotropy a^r = 15/2 R' (3D, eq. 5) or 4 R' (2D); traceless."
    )
    a_r_mag = _field("a_r_mag", "Scalar amplitude of a^r (see anisotropy_magnitude).")
    fabric_eigenvalues = _field(
        "fabric_eigenvalues",
        "(D,) eigenvalues Phi_1 >= ... of R, clipped to [0, 1] against rounding.",
    )
    fabric_eigenvectors = _field(
        "fabric_eigenvectors", "(D, D) unit eigenvectors of R, column k for eigenvalue k."
    )
    phi_d = _field(
        "phi_d",
        "Barreto's Phi_d (eq. 15) of the fabric eigenvalues; in 2D Phi_1 - Phi_2 (see phi_d).",
    )
    anisotropy = _field(
        "anisotropy",
        "Table 1 measures of the fabric eigenvalues: dict 'curry', 'thornton', 'ibraim', "
        "'maeda' (Phi_min = Phi_3 in 3D; see anisotropy_measures).",
    )
    f0 = _field(
        "f0",
        "Mean normal force over equal-weight orientation groups, eq. 8 (N); "
        "bin-free estimator (force_tensors). NaN without forces.",
    )
    force_normal_tensor = _field(
        "force_normal_tensor", "(D, D) normal-force tensor F^n (eq. 9, N), bin-free; tr = f0."
    )
    a_n = _field("a_n", "(D, D) normal-force anisotropy a^n = c_D (F^n/f0 - I/D), bin-free.")
    a_n_mag = _field("a_n_mag", "Scalar amplitude of a^n (see anisotropy_magnitude).")
    force_normal_eigenvalues = _field(
        "force_normal_eigenvalues", "(D,) eigenvalues of F^n, descending (N)."
    )
    force_normal_eigenvectors = _field(
        "force_normal_eigenvectors", "(D, D) eigenvectors of F^n, column k for eigenvalue k."
    )
    force_tangential_tensor = _field(
        "force_tangential_tensor",
        "(D, D) tangential-force tensor F^t_ij = <f^t_i n_j> (eq. 13, N), bin-free; traceless, "
        "not necessarily symmetric.",
    )
    a_t = _field(
        "a_t", "(D, D) tangential anisotropy a^t = 5 sym(F^t)/f0 (3D), 4 sym(F^t)/f0 (2D)."
    )
    a_t_mag = _field("a_t_mag", "Scalar amplitude of a^t (see anisotropy_magnitude).")
    n_bins = _field("n_bins", "Orientation-group resolution of the binned estimator, or None.")
    f0_binned = _field("f0_binned", "f0 by the binned estimator (N); None unless binned=True.")
    force_normal_tensor_binned = _field(
        "force_normal_tensor_binned", "(D, D) F^n, binned estimator; None unless binned=True."
    )
    a_n_binned = _field("a_n_binned", "(D, D) a^n, binned estimator; None unless binned=True.")
    force_tangential_tensor_binned = _field(
        "force_tangential_tensor_binned", "(D, D) F^t, binned; None unless binned=True."
    )
    a_t_binned = _field("a_t_binned", "(D, D) a^t, binned (traceless); None unless binned=True.")

    def to_dict(self) -> dict:
        """A flat dict of scalars (float, int, bool) for one row of a table.

        Keys: dim, n_particles, n_contacts, n_wall_contacts, n_rattlers, has_forces, h_top,
        phi, phi_core, phi_core_centres, void_ratio, z, z_walls, z_mech, z_field,
        z_athanasiou, z_yanagisawa, z_chang; symmetric tensors by their upper components
        (fabric_xx, fabric_xy, ..., a_r_*, force_normal_*, a_n_*, a_t_*); F^t by all
        components (force_tangential_xy, force_tangential_yx, ...); eigenvalues
        fabric_eig1.., force_normal_eig1..; the major fabric direction fabric_vec1_x..;
        a_r_mag, a_n_mag, a_t_mag, f0, phi_d, anisotropy_curry, anisotropy_thornton,
        anisotropy_ibraim, anisotropy_maeda; with binned=True also f0_binned,
        a_n_binned_*, a_t_binned_*, a_n_binned_mag, a_t_binned_mag, n_bins.
        """
        v = self._v
        d = v["dim"]
        out: dict = {}
        for key in ("dim", "n_particles", "n_contacts", "n_wall_contacts", "n_rattlers"):
            out[key] = int(v[key])
        out["has_forces"] = bool(v["has_forces"])
        for key in (
            "h_top",
            "phi",
            "phi_centres",
            "phi_core",
            "phi_core_centres",
            "void_ratio",
            "z",
            "z_walls",
            "z_mech",
        ):
            out[key] = float(v[key])
        for key, val in v["z_empirical"].items():
            out[f"z_{key}"] = float(val)

        def sym(prefix, t):
            for lab, a, b in _sym_labels(d):
                out[f"{prefix}_{lab}"] = float(t[a, b])

        sym("fabric", v["fabric"])
        for k in range(d):
            out[f"fabric_eig{k + 1}"] = float(v["fabric_eigenvalues"][k])
        for k in range(d):
            out[f"fabric_vec1_{_AXES[k]}"] = float(v["fabric_eigenvectors"][k, 0])
        sym("a_r", v["a_r"])
        out["a_r_mag"] = float(v["a_r_mag"])
        out["phi_d"] = float(v["phi_d"])
        for key, val in v["anisotropy"].items():
            out[f"anisotropy_{key}"] = float(val)
        out["f0"] = float(v["f0"])
        sym("force_normal", v["force_normal_tensor"])
        for k in range(d):
            out[f"force_normal_eig{k + 1}"] = float(v["force_normal_eigenvalues"][k])
        sym("a_n", v["a_n"])
        out["a_n_mag"] = float(v["a_n_mag"])
        for lab, a, b in _full_labels(d):
            out[f"force_tangential_{lab}"] = float(v["force_tangential_tensor"][a, b])
        sym("a_t", v["a_t"])
        out["a_t_mag"] = float(v["a_t_mag"])
        if v["n_bins"] is not None:
            out["n_bins"] = int(v["n_bins"])
            out["f0_binned"] = float(v["f0_binned"])
            sym("a_n_binned", v["a_n_binned"])
            out["a_n_binned_mag"] = anisotropy_magnitude(v["a_n_binned"])
            sym("a_t_binned", v["a_t_binned"])
            out["a_t_binned_mag"] = anisotropy_magnitude(v["a_t_binned"])
        return out

    def __repr__(self) -> str:
        v = self._v
        forces = f", f0={v['f0']:.4g} N" if v["has_forces"] else ", no forces"
        return (
            f"Microstructure(dim={v['dim']}, N_p={v['n_particles']}, N_c={v['n_contacts']}, "
            f"phi={v['phi']:.4f}, phi_core={v['phi_core']:.4f}, Z={v['z']:.3f}, "
            f"Z_m={v['z_mech']:.3f}, |a_r|={v['a_r_mag']:.4f}{forces})"
        )


def _as_contacts(contacts, n: int, d: int) -> Contacts:
    if isinstance(contacts, Contacts):
        cols = contacts.to_dict()
    elif isinstance(contacts, Mapping):
        cols = dict(contacts)
    else:
        raise InvalidParameterError(
            f"invalid contacts = {type(contacts).__name__}: expected granpack.Contacts or a "
            "dict of arrays (i, j, normal, and optionally force_normal, force_tangential)"
        )
    for key in ("i", "j", "normal"):
        if key not in cols:
            raise InvalidParameterError(f"invalid contacts: missing column {key!r}")
    try:
        i = np.asarray(cols["i"])
        j = np.asarray(cols["j"])
        normal = np.asarray(cols["normal"], dtype=float)
    except (TypeError, ValueError) as exc:
        raise InvalidParameterError(f"invalid contacts: {exc}") from None
    m = i.shape[0] if i.ndim == 1 else -1
    if m < 0 or j.shape != (m,) or normal.shape != (m, d):
        raise InvalidParameterError(
            f"invalid contacts: shapes i {i.shape}, j {j.shape}, normal {normal.shape}; "
            f"expected (M,), (M,), (M, {d})"
        )
    for name, arr in (("i", i), ("j", j)):
        if m and not np.issubdtype(arr.dtype, np.integer):
            raise InvalidParameterError(
                f"invalid contacts.{name}: dtype {arr.dtype}, expected integers"
            )
    i = i.astype(np.int64)
    j = j.astype(np.int64)
    if m and (i.min() < 0 or i.max() >= n):
        raise InvalidParameterError(
            f"invalid contacts.i: particle indices must lie in [0, {n - 1}]"
        )
    if m and (j.min() < _MIN_WALL_ID or j.max() >= n):
        raise InvalidParameterError(
            f"invalid contacts.j: must lie in [0, {n - 1}] or be a wall id -1..-5"
        )
    if m and np.any(i == j):
        k = int(np.argmax(i == j))
        raise InvalidParameterError(
            f"invalid contacts: contact {k} joins particle {int(i[k])} to itself (i == j)"
        )
    if m:
        # a pair listed twice (as (i, j) or (j, i)) would count twice in Z and the fabric
        lo_ = np.where(j >= 0, np.minimum(i, j), i)
        hi_ = np.where(j >= 0, np.maximum(i, j), j)
        pairs = np.unique(np.stack([lo_, hi_], axis=1), axis=0, return_counts=True)
        if np.any(pairs[1] > 1):
            a, b = pairs[0][int(np.argmax(pairs[1] > 1))]
            raise InvalidParameterError(
                f"invalid contacts: the pair ({int(a)}, {int(b)}) is listed more than once"
            )
    zeros_d = np.zeros((m, d))
    full = {
        "i": i,
        "j": j,
        "normal": normal,
        "overlap": np.asarray(cols.get("overlap", np.zeros(m)), dtype=float),
        "force_normal": np.asarray(cols.get("force_normal", np.zeros(m)), dtype=float),
        "force_tangential": np.asarray(cols.get("force_tangential", zeros_d), dtype=float),
        "branch": np.asarray(cols.get("branch", zeros_d), dtype=float),
    }
    if full["force_normal"].shape != (m,) or full["force_tangential"].shape != (m, d):
        raise InvalidParameterError(
            f"invalid contacts: force_normal {full['force_normal'].shape}, force_tangential "
            f"{full['force_tangential'].shape}; expected ({m},), ({m}, {d})"
        )
    for key in ("normal", "force_normal", "force_tangential"):
        if not np.all(np.isfinite(full[key])):
            raise InvalidParameterError(f"invalid contacts.{key}: non-finite values")
    if m and np.min(full["force_normal"]) < 0.0:
        k = int(np.argmin(full["force_normal"]))
        raise InvalidParameterError(
            f"invalid contacts.force_normal[{k}] = {full['force_normal'][k]}: must be >= 0 (N)"
        )
    if m and np.any(np.linalg.norm(normal, axis=1) == 0.0):
        raise InvalidParameterError("invalid contacts.normal: a row has zero length")
    return Contacts.from_dict(full)


def _as_box(box, d: int):
    try:
        lo, hi = box
        lo = np.asarray(lo, dtype=float).ravel()
        hi = np.asarray(hi, dtype=float).ravel()
    except (TypeError, ValueError):
        raise InvalidParameterError(
            f"invalid box = {box!r}: expected (lo, hi), each a sequence of {d} lengths (m)"
        ) from None
    if lo.shape != (d,) or hi.shape[0] not in (d - 1, d):
        raise InvalidParameterError(
            f"invalid box: lo has {lo.shape[0]} values and hi {hi.shape[0]}; expected {d} and "
            f"{d} (hi's vertical value is ignored: the top is H_top) or {d - 1}"
        )
    hi = hi[: d - 1]
    if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi)) and np.all(hi > lo[:-1])):
        raise InvalidParameterError(
            f"invalid box: lo = {lo.tolist()}, hi = {hi.tolist()}; need finite hi > lo (m)"
        )
    return lo, hi


def _as_particles(positions, radii):
    try:
        x = np.asarray(positions, dtype=float)
        r = np.asarray(radii, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InvalidParameterError(f"invalid positions/radii: {exc}") from None
    if x.ndim != 2 or x.shape[1] not in (2, 3):
        raise InvalidParameterError(
            f"invalid positions: shape {x.shape}, expected (N, 2) or (N, 3)"
        )
    if x.shape[0] == 0:
        raise InvalidParameterError("invalid positions: no particles (N = 0)")
    if r.shape != (x.shape[0],):
        raise InvalidParameterError(f"invalid radii: shape {r.shape}, expected ({x.shape[0]},)")
    if not np.all(np.isfinite(x)):
        raise InvalidParameterError("invalid positions: non-finite values")
    if not (np.all(np.isfinite(r)) and np.all(r > 0)):
        k = int(np.argmin(np.where(np.isfinite(r), r, -np.inf)))
        raise InvalidParameterError(f"invalid radii[{k}] = {r[k]}: must be finite and > 0 (m)")
    return np.ascontiguousarray(x), np.ascontiguousarray(r)


def _check_overlaps(pairs: Contacts, r: np.ndarray) -> None:
    """Refuses interpenetrating particles: an overlap beyond the smaller radius puts a
    centre inside the other particle, and phi and Z then mean nothing (phi above 1)."""
    if len(pairs) == 0:
        return
    ratio = pairs.overlap / np.minimum(r[pairs.i], r[pairs.j])
    k = int(np.argmax(ratio))
    if ratio[k] > 1.0:
        i, j = int(pairs.i[k]), int(pairs.j[k])
        raise InvalidParameterError(
            f"invalid positions: particles {i} and {j} overlap by {pairs.overlap[k]:.4g} m, "
            f"more than the smaller radius {min(r[i], r[j]):.4g} m (overlap ratio "
            f"{ratio[k]:.3g}; at most 1): not a valid pack"
        )


def _find_contacts(x, r, walls) -> Contacts:
    try:
        found = _core.find_contacts(x, r, walls=walls)
    except GranpackError as exc:
        hint = ""
        if "max_overlap_ratio" in str(exc):
            # find_contacts reuses the engine's blow-up guard; for analysis it only means
            # that two particles interpenetrate by a radius or more
            hint = " (two particles overlap by the smaller radius or more: not a valid pack)"
        raise GranpackError(
            f"cannot find the contacts of the given positions/radii: {exc}{hint}"
        ) from None
    return Contacts.from_dict(found)


def microstructure(
    pack=None,
    *,
    positions=None,
    radii=None,
    contacts=None,
    box=None,
    binned: bool = False,
    n_bins: int | None = None,
    core_margin: float = 0.1,
) -> Microstructure:
    """Microstructure of a pack: phi, void ratio, coordination, fabric, force tensors.

    Parameters
    ----------
    pack : granpack.Pack or granpack.ParticleFile, optional
        A generated pack (its positions, radii, contacts with forces, and box), or what
        :func:`granpack.read_particles` read from a file (its box, if the file has one;
        periodic boundaries are not modelled: see ParticleFile.periodic). Give either
        `pack` or `positions` and `radii`, not both.
    positions : (N, D) array, optional
        Centres (m), D = 2 or 3, vertical axis last (y in 2D, z in 3D).
    radii : (N,) array, optional
        Radii (m), > 0.
    contacts : granpack.Contacts or dict of arrays, optional
        Contacts in force (columns as in :class:`granpack.Contacts`; force columns may be
        left out). Default None: found with the Rust cell grid (``granpack._core.
        find_contacts``) for every pair with positive overlap, and every particle-wall
        overlap if `box` is given; those carry no forces, so every force quantity is NaN
        and ``has_forces`` is False (no warning).
    box : (lo, hi), optional
        Side walls and floor: lo (D,) and hi (D,) (hi's vertical value, e.g. inf, is
        ignored: the top is H_top) or hi (D-1,) (m). Default: the pack's box; for arrays,
        the particles' bounding box with no walls (no wall contacts are then found).
    binned : bool
        Also compute the paper's binned force estimator (``*_binned``). Default False.
    n_bins : int, optional
        Resolution of the binned estimator (see force_tensors_binned): 2D sectors (default
        36), 3D bands in cos(gamma) with 2 n_bins sectors each (default 10).
    core_margin : float
        Distance m (m) of the core window from the side walls, the floor and the top.
        Default 0.1, as the peers' script.

    Returns
    -------
    Microstructure

    Warns
    -----
    MicrostructureWarning
        "no particle-particle contacts" (Z = 0; fabric, its eigen-analysis and every force
        quantity NaN: a single particle, or only wall contacts); "core window is empty"
        (phi_core NaN: the pack is lower than 2 core_margin or the base narrower);
        "fabric too anisotropic for the bin-free force estimator" (bin-free force
        quantities NaN; the binned ones are still given).

    Raises
    ------
    GranpackError
        Bad input, naming the parameter.
    """
    if pack is not None:
        if any(a is not None for a in (positions, radii, contacts, box)):
            raise GranpackError("give either pack or positions/radii/contacts/box, not both")
        try:
            positions, radii, contacts, box = pack.positions, pack.radii, pack.contacts, pack.box
        except AttributeError:
            raise InvalidParameterError(
                f"invalid pack = {type(pack).__name__}: expected a granpack.Pack or the "
                "result of granpack.read_particles"
            ) from None
    elif positions is None or radii is None:
        raise GranpackError("give a pack, or positions and radii")
    x, r = _as_particles(positions, radii)
    n, d = x.shape
    binned = bool(binned)
    nb: int | None = _n_bins(n_bins, d)
    if not binned:
        nb = None
    margin = as_real("core_margin", core_margin, 0.0, unit="m")

    with np.errstate(over="ignore", under="ignore"):
        vol = math.pi * r * r if d == 2 else 4.0 / 3.0 * math.pi * r * r * r
        solid = float(np.sum(vol))
        h_top = float(np.max(x[:, -1] + r))
    if not (np.all(np.isfinite(vol)) and np.all(vol > 0.0) and math.isfinite(solid)):
        k = int(np.argmax(~(np.isfinite(vol) & (vol > 0.0))))
        raise InvalidParameterError(
            f"invalid radii[{k}] = {r[k]}: the particle volume is {vol[k]:.3g} and the total "
            f"{solid:.3g}; volumes must be finite and > 0 (radii within about 1e-100 to "
            "1e100 m)"
        )
    if not math.isfinite(h_top):
        raise InvalidParameterError("invalid positions: the pack's top max(z + r) overflows")
    if box is None:
        lo = np.min(x - r[:, None], axis=0)
        hi_h = np.max(x[:, :-1] + r[:, None], axis=0)
        walls = None
    else:
        lo, hi_h = _as_box(box, d)
        if h_top <= lo[-1]:
            raise InvalidParameterError(
                f"invalid box: floor at {lo[-1]} m is at or above the top of the pack {h_top} m"
            )
        walls = (lo.tolist(), [*hi_h.tolist(), h_top])
    hi = np.array([*hi_h, h_top])
    with np.errstate(over="ignore", under="ignore"):
        box_volume = float(np.prod(hi - lo))
    if not (math.isfinite(box_volume) and box_volume > 0.0):
        raise InvalidParameterError(
            f"invalid positions: the box from {lo.tolist()} to {hi.tolist()} m has volume "
            f"{box_volume:.3g}; coordinates must span a finite box of volume > 0"
        )

    if contacts is None:
        c = _find_contacts(x, r, walls)
        contacts_given = False
        geometric = c
    else:
        c = _as_contacts(contacts, n, d)
        contacts_given = True
        geometric = _find_contacts(x, r, None)
    _check_overlaps(geometric.particle_pairs(), r)

    # -- packing fraction ---------------------------------------------------------------
    phi = float(solid / box_volume)
    if not phi > 0.0:
        raise InvalidParameterError(
            f"invalid positions/radii: solid volume {solid:.3g} in a box of {box_volume:.3g} "
            "gives phi = 0 (underflow); rescale the coordinates and radii"
        )
    h_centres = float(np.max(x[:, -1])) - lo[-1]
    phi_centres = (
        float(np.sum(vol) / (box_volume / (hi[-1] - lo[-1]) * h_centres))
        if h_centres > 0
        else math.nan
    )
    wlo, whi = lo + margin, hi - margin
    if np.all(whi > wlo):
        w_volume = float(np.prod(whi - wlo))
        phi_core = float(np.sum(window_volumes(x, r, wlo, whi)) / w_volume)
        centre_in = np.all((x >= wlo) & (x <= whi), axis=1)
        phi_core_centres = float(np.sum(vol[centre_in]) / w_volume)
    else:
        warnings.warn(
            f"core window is empty (margin {margin} m; box {lo.tolist()} to {hi.tolist()}): "
            "phi_core is NaN",
            MicrostructureWarning,
            stacklevel=2,
        )
        phi_core = phi_core_centres = math.nan
    e = (1.0 - phi) / phi

    # -- coordination ---------------------------------------------------------------------
    pp = c.particle_pairs()
    n_c = len(pp)
    n_w = len(c) - n_c
    degree = np.bincount(pp.i, minlength=n) + np.bincount(pp.j, minlength=n)
    n0 = int(np.sum(degree == 0))
    n1 = int(np.sum(degree == 1))
    active = n - n0 - n1
    z_mech = (2.0 * n_c - n1) / active if active > 0 else 0.0

    nan_t = np.full((d, d), np.nan)
    nan_v = np.full(d, np.nan)
    values = {
        "dim": d,
        "n_particles": n,
        "n_contacts": n_c,
        "n_wall_contacts": n_w,
        "n_rattlers": n0 + n1,
        "h_top": h_top,
        "box": (lo, hi),
        "phi": phi,
        "phi_centres": phi_centres,
        "phi_core": phi_core,
        "phi_core_centres": phi_core_centres,
        "void_ratio": e,
        "z": 2.0 * n_c / n,
        "z_walls": (2.0 * n_c + n_w) / n,
        "z_mech": z_mech,
        "z_empirical": empirical_z(e),
        "n_bins": nb,
    }

    # -- fabric ---------------------------------------------------------------------------
    if n_c == 0:
        warnings.warn(
            "no particle-particle contacts: Z = 0; the fabric tensor, its eigen-analysis and "
            "the force tensors are undefined (NaN)",
            MicrostructureWarning,
            stacklevel=2,
        )
        fab = nan_t
        eig, vec = nan_v, nan_t
    else:
        fab = fabric_tensor(pp.normal)
        eig, vec = eigen_sorted(fab)
        eig = np.clip(eig, 0.0, 1.0)
    a_r = ANISOTROPY_FACTOR[d] * (fab - np.eye(d) / d)
    values.update(
        fabric=fab,
        fabric_deviator=fab - np.eye(d) / d,
        a_r=a_r,
        a_r_mag=anisotropy_magnitude(a_r),
        fabric_eigenvalues=eig,
        fabric_eigenvectors=vec,
        phi_d=phi_d(eig),
        anisotropy=anisotropy_measures(eig, values["z"]),
    )

    # -- forces ---------------------------------------------------------------------------
    has_forces = bool(contacts_given and n_c > 0 and np.any(pp.force_normal > 0.0))
    free = binned_t = None
    if has_forces:
        nrm, fn, ft = _force_columns(pp.normal, pp.force_normal, pp.force_tangential)
        free = _bin_free(nrm, fn, ft)
        if free is None:
            warnings.warn(
                "fabric too anisotropic for the bin-free force estimator (1 + a^r_kl n_k n_l "
                "<= 0 at some contact): f0, F^n, F^t, a^n, a^t are NaN; use binned=True",
                MicrostructureWarning,
                stacklevel=2,
            )
        if binned:
            binned_t = force_tensors_binned(nrm, fn, ft, nb)
    if free is None:
        free = ForceTensors(math.nan, nan_t, nan_t, nan_t, nan_t)
    fn_eig, fn_vec = eigen_sorted(free.normal)
    values.update(
        has_forces=has_forces,
        f0=free.f0,
        force_normal_tensor=free.normal,
        force_tangential_tensor=free.tangential,
        a_n=free.a_n,
        a_n_mag=anisotropy_magnitude(free.a_n),
        a_t=free.a_t,
        a_t_mag=anisotropy_magnitude(free.a_t),
        force_normal_eigenvalues=fn_eig,
        force_normal_eigenvectors=fn_vec,
    )
    if binned and binned_t is None:
        binned_t = ForceTensors(math.nan, nan_t, nan_t, nan_t, nan_t)
    values.update(
        f0_binned=None if binned_t is None else binned_t.f0,
        force_normal_tensor_binned=None if binned_t is None else binned_t.normal,
        force_tangential_tensor_binned=None if binned_t is None else binned_t.tangential,
        a_n_binned=None if binned_t is None else binned_t.a_n,
        a_t_binned=None if binned_t is None else binned_t.a_t,
    )
    return Microstructure(values)


# granpack/__init__.py re-exports the function under this module's name, which hides the
# module: attach the helpers so that granpack.microstructure.read_xyzr(...) etc. work.
for _name in __all__:
    if _name != "microstructure":
        setattr(microstructure, _name, globals()[_name])
del _name
