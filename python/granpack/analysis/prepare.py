"""The quantities beyond the paper that :func:`granpack.microstructure` adds to a
:class:`System` (coordination distribution, rattlers, stress and K0, strong and weak
networks, bond order), and the slice stress the profiles share."""

from __future__ import annotations

import math
import warnings

import numpy as np

from ..contacts import Contacts
from .coordination import coordination_distribution, degrees, rattlers_iterative
from .order import bond_order
from .stress import contact_forces, k0, love_weber
from .system import System
from .tensors import ANISOTROPY_FACTOR, anisotropy_magnitude, fabric_tensor

__all__ = ["MAX_SLICES", "FORCE_BIN", "force_balance", "stress_slices"]


def __getattr__(name: str):
    # `Prepared` is the former name of `System`, until the next release; it warns on first
    # use only, as the name is then bound here
    if name == "Prepared":
        warnings.warn(
            "granpack.analysis.prepare.Prepared is now granpack.analysis.system.System; "
            "Prepared is removed in the next release",
            DeprecationWarning,
            stacklevel=2,
        )
        globals()[name] = System
        return System
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


#: Most slices of a depth profile.
MAX_SLICES = 10_000
#: Width of the bins of force_distribution, in units of the mean normal force.
FORCE_BIN = 0.1


def force_balance(prep: System, forces: np.ndarray) -> tuple[float, float]:
    """(YADE's unbalanced ratio, PFC's maximum ratio) of the contact forces `forces`
    (M, D; on the second body) and the body forces: mean and largest |net force| over
    particles, each over the mean |contact force| (-). NaN without body forces or
    contacts."""
    c = prep.contacts
    if prep.body is None or len(c) == 0:
        return math.nan, math.nan
    net = prep.body.copy()
    np.add.at(net, c.i, -forces)
    pair = c.j >= 0
    np.add.at(net, c.j[pair], forces[pair])
    mean_c = float(np.mean(np.linalg.norm(forces, axis=1)))
    if not mean_c > 0.0:
        return math.nan, math.nan
    mag = np.linalg.norm(net, axis=1)
    return float(np.mean(mag)) / mean_c, float(np.max(mag)) / mean_c


def _force_edges(ratio: np.ndarray) -> np.ndarray:
    top = max(1.0, math.ceil(float(np.max(ratio)) / FORCE_BIN) * FORCE_BIN) if ratio.size else 1.0
    return np.arange(0.0, top + 0.5 * FORCE_BIN, FORCE_BIN)


def stress_slices(prep: System, edges: np.ndarray, forces, branches) -> np.ndarray:
    """(S, D, D) Love-Weber stress of each horizontal slice (Pa): every contact is given to
    the slice of its contact point, over the slice's volume (cross-section x thickness), so
    that the thickness-weighted mean of the slices is the pack's stress."""
    d = prep.d
    s_count = edges.shape[0] - 1
    pts = prep.contact_points()[:, -1]
    k = np.clip(np.searchsorted(edges, pts, side="right") - 1, 0, s_count - 1)
    out = np.zeros((s_count, d, d))
    prod = forces[:, :, None] * branches[:, None, :]
    for a in range(d):
        for b in range(d):
            out[:, a, b] = np.bincount(k, weights=prod[:, a, b], minlength=s_count)
    dv = prep.container.base_area * np.diff(edges)
    out /= dv[:, None, None]
    return 0.5 * (out + np.transpose(out, (0, 2, 1)))


def _beyond_the_paper(
    prep: System, pp: Contacts, values: dict, n_slices: int, has_forces: bool
) -> dict:
    """Coordination distribution and rattlers, stress and K0, the strong and weak networks
    and the force distribution, bond order. `pp` is ``prep.contacts.particle_pairs()``,
    which the caller already holds (a second copy would cost some 500 bytes a particle)."""
    n, d = prep.n, prep.d
    c = prep.contacts
    n_c = len(pp)
    deg = degrees(pp.i, pp.j, n)
    p_z = coordination_distribution(deg)
    k = np.arange(p_z.shape[0])
    z_std = float(math.sqrt(max(0.0, float(np.sum(p_z * k * k)) - (2.0 * n_c / n) ** 2)))
    ratt, n_live = rattlers_iterative(c.i, c.j, n, d)
    n_ratt = int(np.sum(ratt))
    # every particle a rattler: Z_m is the mean over no particle, NaN (as z_mech)
    z_iter = 2.0 * n_live / (n - n_ratt) if n > n_ratt else math.nan
    ratt_f, n_live_f = rattlers_iterative(c.i, c.j, n, d, d)
    n_ratt_f = int(np.sum(ratt_f))
    z_iter_f = 2.0 * n_live_f / (n - n_ratt_f) if n > n_ratt_f else math.nan
    nan_t = np.full((d, d), np.nan)
    out: dict = {
        "container": prep.container.kind,
        "container_source": prep.container_source,
        "container_volume": float(prep.volume),
        "coordination_distribution": p_z,
        "z_std": z_std,
        "n_rattlers_iterative": n_ratt,
        "z_mech_iterative": float(z_iter),
        "n_rattlers_frictional": n_ratt_f,
        "z_mech_frictional": float(z_iter_f),
    }
    # -- stress ---------------------------------------------------------------------------
    edges = np.linspace(prep.lo[-1], prep.hi[-1], n_slices + 1)
    if has_forces:
        forces = contact_forces(c.normal, c.force_normal, c.force_tangential)
        branches = prep.branches()
        sigma = love_weber(forces, branches, prep.volume)
        prof = stress_slices(prep, edges, forces, branches)[:, d - 1, d - 1]
        unbalanced, max_ratio = force_balance(prep, forces)
    else:
        sigma = nan_t
        prof = np.full(n_slices, np.nan)
        unbalanced = max_ratio = math.nan
    out.update(
        stress=sigma,
        k0=k0(sigma),
        stress_profile=(edges, prof),
        unbalanced=unbalanced,
        unbalanced_max=max_ratio,
    )
    # -- strong and weak networks ---------------------------------------------------------
    if has_forces and n_c > 0:
        fn = pp.force_normal
        mean = float(np.mean(fn))
        strong = fn > mean
        n_s = int(np.sum(strong))
        fab_s = fabric_tensor(pp.normal[strong]) if n_s else nan_t
        fab_w = fabric_tensor(pp.normal[~strong]) if n_c - n_s else nan_t
        ratio = fn / mean
        f_edges = _force_edges(ratio)
        hist, _ = np.histogram(ratio, bins=f_edges)
        pdf = hist / (n_c * FORCE_BIN)
        fn_mean, s_frac = mean, n_s / n_c
    else:
        fab_s = fab_w = nan_t
        f_edges, pdf = np.array([0.0, FORCE_BIN]), np.array([np.nan])
        fn_mean = s_frac = math.nan
        n_s = 0
    a_s = ANISOTROPY_FACTOR[d] * (fab_s - np.eye(d) / d)
    a_w = ANISOTROPY_FACTOR[d] * (fab_w - np.eye(d) / d)
    out.update(
        force_normal_mean=fn_mean,
        n_strong=n_s,
        strong_fraction=float(s_frac),
        fabric_strong=fab_s,
        fabric_weak=fab_w,
        a_r_strong=a_s,
        a_r_weak=a_w,
        a_r_strong_mag=anisotropy_magnitude(a_s),
        a_r_weak_mag=anisotropy_magnitude(a_w),
        force_distribution=(f_edges, pdf),
    )
    # -- bond order -----------------------------------------------------------------------
    bo = bond_order(pp.i, pp.j, pp.normal, n, d, 6)
    q = bo.q[np.isfinite(bo.q)]
    out.update(
        q6=bo.q,
        q6_mean=float(np.mean(q)) if q.size else math.nan,
        q6_global=bo.global_q,
        crystal_fraction=bo.crystal_fraction,
    )
    return out
