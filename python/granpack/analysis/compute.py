"""The analysis of one pack: :func:`microstructure`."""

from __future__ import annotations

import math
import warnings

import numpy as np

from .._validate import GranpackError, InvalidParameterError, as_real
from .inputs import _as_box, _as_contacts, _as_particles, _check_overlaps, _find_contacts
from .relations import empirical_z
from .result import Microstructure, MicrostructureWarning
from .tensors import (
    ANISOTROPY_FACTOR,
    ForceTensors,
    _bin_free,
    _force_columns,
    _n_bins,
    anisotropy_magnitude,
    anisotropy_measures,
    eigen_sorted,
    fabric_tensor,
    force_tensors_binned,
    phi_d,
)
from .volumes import window_volumes

__all__ = ["microstructure"]


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
    return Microstructure(**values)
