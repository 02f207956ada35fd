"""Tensors of contact normals and forces: fabric, anisotropy, eigen-analysis, the paper's
Table 1 measures, and the contact-force tensors (bin-free and binned estimators).

Readings of the paper
---------------------
- Eq. 2 writes R = 1/(2 N_c) sum n n over both particles' normals; with one normal per
  contact that is R = 1/N_c sum n n (trace 1), which is what is computed.
- Eqs. 10-11 drop the 1/f0 and the identity; the standard forms are used:
  a^n = 15/2 (F^n/f0 - I/3) in 3D, 4 (F^n/f0 - I/2) in 2D (Ouadfel & Rothenburg 2001;
  Rothenburg & Bathurst 1989); a^t = 5 F^t/f0 (3D), 4 F^t/f0 (2D).
- Table 1 is garbled; the measures are Curry (Phi_1 - Phi_min)/2, Thornton Phi_1 - Phi_min,
  Ibraim Phi_1/Phi_min and Maeda Z (Phi_1 - Phi_min).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from .._validate import GranpackError, InvalidParameterError, as_int

__all__ = [
    "ANISOTROPY_FACTOR",
    "TANGENTIAL_FACTOR",
    "DEFAULT_N_BINS",
    "ForceTensors",
    "fabric_tensor",
    "force_tensors",
    "force_tensors_binned",
    "anisotropy_tensor",
    "anisotropy_magnitude",
    "eigen_sorted",
    "phi_d",
    "anisotropy_measures",
]

ANISOTROPY_FACTOR = {2: 4.0, 3: 7.5}
#: Factor in a^t = c F^t/f0 (5 in 3D, 4 in 2D).
TANGENTIAL_FACTOR = {2: 4.0, 3: 5.0}
#: Default orientation-group resolution of the binned estimator: 36 sectors of 10 degrees in
#: 2D; 10 bands in cos(gamma) x 20 azimuthal sectors (200 equal-area groups) in 3D, about 200
#: contact orientations a group for the paper's packs. The binning bias falls as the square
#: of the group width (about 1 % of a^n in 2D and 4 % in 3D at these defaults).
DEFAULT_N_BINS = {2: 36, 3: 10}


def _unit_rows(name: str, normals) -> np.ndarray:
    n = np.asarray(normals, dtype=float)
    if n.ndim != 2 or n.shape[1] not in (2, 3):
        raise InvalidParameterError(
            f"invalid {name}: shape {n.shape}, expected (M, 2) or (M, 3)", parameter=name
        )
    if n.shape[0] == 0:
        raise InvalidParameterError(
            f"invalid {name}: no contacts (M = 0); the tensor is undefined", parameter=name
        )
    if not np.all(np.isfinite(n)):
        raise InvalidParameterError(f"invalid {name}: non-finite values", parameter=name)
    norm = np.linalg.norm(n, axis=1)
    if np.any(norm == 0.0):
        raise InvalidParameterError(
            f"invalid {name}: row {int(np.argmin(norm))} has zero length", parameter=name
        )
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
        raise InvalidParameterError(
            f"invalid tensor: shape {t.shape}, expected (2, 2) or (3, 3)", parameter="tensor"
        )
    d = t.shape[0]
    tr = np.trace(t)
    if not np.isfinite(tr) or tr == 0.0:
        raise InvalidParameterError(
            f"invalid tensor: trace {tr}, must be finite and non-zero", parameter="tensor"
        )
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
        raise InvalidParameterError(
            f"invalid force_normal: shape {fn.shape}, expected ({m},)", parameter="force_normal"
        )
    if ft.shape != (m, d):
        raise InvalidParameterError(
            f"invalid force_tangential: shape {ft.shape}, expected ({m}, {d})",
            parameter="force_tangential",
        )
    if not (np.all(np.isfinite(fn)) and np.all(np.isfinite(ft))):
        raise InvalidParameterError("invalid forces: non-finite values", parameter="forces")
    if np.any(fn < 0.0):
        k = int(np.argmin(fn))
        raise InvalidParameterError(
            f"invalid force_normal[{k}] = {fn[k]}: must be >= 0 (N)", parameter=f"force_normal[{k}]"
        )
    if not np.any(fn > 0.0):
        raise InvalidParameterError(
            "invalid force_normal: all zero, so f0 = 0 and a^n, a^t are undefined",
            parameter="force_normal",
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
        raise InvalidParameterError(
            "invalid force_normal: f0 = 0, a^n and a^t are undefined", parameter="force_normal"
        )
    return _finish(f0, fn_tensor, ft_tensor, d)
