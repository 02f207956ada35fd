"""The analysis of one pack: :func:`microstructure`."""

from __future__ import annotations

import math
import warnings
from typing import Any, Unpack

import numpy as np

from .._validate import InvalidParameterError, as_int, as_real
from ..grading import realised_grading
from .prepare import MAX_SLICES, _beyond_the_paper
from .relations import empirical_z
from .result import Microstructure, MicrostructureWarning
from .system import System, SystemArgs
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
from .volumes import container_window_volumes, window_volumes

__all__ = ["microstructure"]


def microstructure(
    pack=None,
    *,
    binned: bool = False,
    n_bins: int | None = None,
    core_margin: float = 0.1,
    slices: int = 10,
    **where: Unpack[SystemArgs],
) -> Microstructure:
    """Microstructure of a pack: phi, void ratio, coordination, fabric, force tensors.

    Parameters
    ----------
    pack : granpack.Pack, granpack.ParticleFile or System, optional
        A System made by :meth:`System.from_any`, a generated pack (its positions,
        radii, contacts with forces, and box), or what
        :func:`granpack.read_particles` read from a file (its box, if the file has one,
        and its periodic horizontal axes: see ParticleFile.periodic). Give either
        `pack` or `positions` and `radii`, not both.
    binned : bool
        Also compute the paper's binned force estimator (``*_binned``). Default False.
    n_bins : int, optional
        Resolution of the binned estimator (see force_tensors_binned): 2D sectors (default
        36), 3D bands in cos(gamma) with 2 n_bins sectors each (default 10).
    core_margin : float
        Distance m (m) of the core window from the side walls, the floor and the top.
        Default 0.1, as the peers' script.
    slices : int
        Horizontal slices of ``stress_profile`` (default 10; 1 to 10 000).


    Other Parameters
    ----------------
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
        A periodic cell or a cylinder needs it: the periods are hi - lo, and the cylinder's
        axis passes through (lo_x + R, lo_y + R).
    periodic : sequence of D - 1 bool, optional
        Horizontal axes that repeat, with periods hi - lo: contacts across the seam are
        found by minimum image, branch vectors are minimum images, phi_core has no lateral
        inset along them. Default: a Pack's ``scene.container == "periodic"`` (all
        horizontal axes); otherwise none.
    cylinder_radius : float, optional
        R (m) of a vertical cylinder (3D): phi is over pi R^2 (H_top - floor), the core
        window is a coaxial cylinder of radius R - core_margin, wall id -2 is the cylinder.
        Default: a Pack's cylinder (``scene.cylinder_radius``, or half its base).
    container : str, optional
        One of `CONTAINERS`: the container to analyse in, whatever the pack or file says.
        Default None: a Pack's scene; for a file read (ParticleFile), what the file said
        (ParticleFile.container), else a box, assumed. ``Microstructure.container`` and
        ``.container_source`` say which was used and why. A cylinder without `box` stands on
        the lowest particle with its axis through the middle of the particles' lateral
        extent.
    lid : float, optional
        Height (m) of a lid that closes the sample (a consolidated sample,
        `granpack.consolidate`): phi and the volume are taken from the floor up to it
        instead of H_top = max(z + r), and where the contacts are found from the geometry
        every particle above its plane touches it (wall id -6). Above the floor and every
        particle's centre. Default None: a Pack's consolidation record; for a file read,
        what the file said (``ParticleFile.lid``, granpack's container tag); else an
        open top.

    Returns
    -------
    Microstructure

    Warns
    -----
    MicrostructureWarning
        "no particle-particle contacts" (Z = 0; Z_m, fabric, its eigen-analysis and every force
        quantity NaN: a single particle, or only wall contacts); "core window is empty"
        (phi_core NaN: the pack is lower than 2 core_margin or the base narrower);
        "fabric too anisotropic for the bin-free force estimator" (bin-free force
        quantities NaN; the binned ones are still given).

    Raises
    ------
    GranpackError
        Bad input, naming the parameter.
    """
    prep = System.from_any(pack, **where)
    x, r, n, d = prep.x, prep.r, prep.n, prep.d
    lo, hi, c, contacts_given = prep.lo, prep.hi, prep.contacts, prep.contacts_given
    solid, vol, h_top, box_volume = prep.solid, prep.vol, prep.h_top, prep.volume
    cont = prep.container
    binned = bool(binned)
    nb: int | None = _n_bins(n_bins, d)
    if not binned:
        nb = None
    margin = as_real("core_margin", core_margin, 0.0, unit="m")
    n_slices = as_int("slices", slices, 1, MAX_SLICES)

    # -- packing fraction ---------------------------------------------------------------
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        phi = float(np.float64(solid) / np.float64(box_volume))
    if not phi > 0.0:
        raise InvalidParameterError(
            f"invalid positions/radii: solid volume {solid:.3g} in a box of {box_volume:.3g} "
            "gives phi = 0 (underflow); rescale the coordinates and radii",
            parameter="positions",
        )
    if not math.isfinite(phi):
        raise InvalidParameterError(
            f"invalid box: the particles' volume {solid:.3g} in a container of "
            f"{box_volume:.3g} gives phi = {phi} (overflow): the box must hold the particles "
            "(m)",
            parameter="box",
        )
    h_centres = float(np.max(x[:, -1])) - lo[-1]
    phi_centres = (
        float(np.sum(vol) / (box_volume / (hi[-1] - lo[-1]) * h_centres))
        if cont.radius is None and h_centres > 0
        else float(np.sum(vol) / (cont.base_area * h_centres))
        if h_centres > 0
        else math.nan
    )
    if cont.kind == "box":
        wlo, whi = lo + margin, hi - margin
        window = None
        if np.all(whi > wlo):
            w_volume = float(np.prod(whi - wlo))
            window = (window_volumes(x, r, wlo, whi), w_volume, np.all((x >= wlo) & (x <= whi), 1))
    else:
        window = container_window_volumes(x, r, cont, margin)
    if window is not None:
        w_vols, w_volume, centre_in = window
        phi_core = float(np.sum(w_vols) / w_volume)
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
    # an undefined mean (no particle with two contacts) is NaN, as in the profiles
    z_mech = (2.0 * n_c - n1) / active if active > 0 else math.nan

    nan_t = np.full((d, d), np.nan)
    nan_v = np.full(d, np.nan)
    values: dict[str, Any] = {
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
            "no particle-particle contacts: Z = 0; Z_m, the fabric tensor, its eigen-analysis "
            "and the force tensors are undefined (NaN)",
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
    values.update(_beyond_the_paper(prep, pp, values, n_slices, has_forces))
    scene = getattr(prep.source, "scene", None)
    values["grading"] = realised_grading(
        r, d, inertia_2d=getattr(scene, "inertia_2d", None) or "disc"
    )
    return Microstructure(**values)
