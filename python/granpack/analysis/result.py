"""The result of the analysis of one pack: :class:`Microstructure`."""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from ..grading import Grading
from .coordination import P_Z_KEYS
from .tensors import anisotropy_magnitude

__all__ = ["Microstructure", "MicrostructureWarning"]

_AXES = "xyz"


class MicrostructureWarning(UserWarning):
    """A quantity is undefined for this pack and is reported as NaN (see the module doc)."""


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


@dataclass(frozen=True, eq=False)
class Microstructure:
    """Microstructure of one pack (SI units). Built by :func:`microstructure`.

    Particle-particle contacts unless a name says otherwise; D = 2 or 3; arrays are
    read-only. Undefined quantities are NaN (see the module doc for when, and which warn).
    ``to_dict()`` flattens everything scalar for a table row.
    """

    dim: int
    """Spatial dimension D (2 or 3)."""
    n_particles: int
    """N_p, number of particles."""
    n_contacts: int
    """N_c, number of particle-particle contacts."""
    n_wall_contacts: int
    """N_w, number of particle-wall contacts."""
    n_rattlers: int
    """N_0 + N_1: particles with fewer than two particle-particle contacts (Thornton 2000)."""
    has_forces: bool
    """True when the contacts carry forces (a generated pack, or contacts given with some f_n > 0).
    False for contacts found from positions and radii: every force quantity is then NaN, without
    a warning.
    """
    h_top: float
    """H_top = max(z_i + r_i), the pack's height (m) along the vertical."""
    phi_centres: float
    """Solid volume over base x (max(z_i) - floor): the packing fraction with the height measured
    at the highest centre instead of the highest top (-). The paper's tables are consistent with
    this reading (docs/physics.md).
    """
    box: tuple[np.ndarray, np.ndarray]
    """(lo, hi): (D,) arrays of the box used (m); hi[-1] = H_top. The side walls, or the particles'
    bounding box when no box was given.
    """
    phi: float
    """Packing fraction: solid volume / (base x (H_top - floor)) (-); 2D: area fraction."""
    phi_core: float
    """Interior packing fraction (-): volume of the particles inside the window [lo + m, hi - m]
    horizontally x [floor + m, H_top - m] vertically (m = core_margin), counting each particle's
    part inside the window exactly (closed-form segments in 2D, exact slice areas integrated to
    ~1e-11 in 3D; see window_volumes), over the window's volume. NaN (with a warning) if the
    window is empty.
    """
    phi_core_centres: float
    """The peers' interior fraction (-): whole volumes of the particles whose centres lie in the
    core window, over the window's volume (the peers' analyze_dump.py). Biased by the particles
    cut by the window's faces; use phi_core for the exact value.
    """
    void_ratio: float
    """Void ratio e = (1 - phi)/phi (-), from the bulk phi."""
    z: float
    """Coordination number Z = 2 N_c/N_p (eq. 1); 0 without contacts."""
    z_walls: float
    """Z with wall contacts: (2 N_c + N_w)/N_p."""
    z_mech: float
    """Mechanical coordination number without rattlers, Z_m = (2 N_c - N_1)/(N_p - N_0 - N_1)
    (Thornton 2000), N_k = particles with k particle-particle contacts; NaN when no particle
    has two or more contacts (a mean over no particle, as ``profiles`` gives it per slice).
    """
    z_empirical: dict[str, float]
    """Empirical Z(e) of eqs. 16-19 from the void ratio: dict 'field', 'athanasiou', 'yanagisawa',
    'chang' (see empirical_z).
    """
    fabric: np.ndarray
    """(D, D) fabric tensor R_ij = (1/N_c) sum n_i n_j (eq. 2); trace 1. NaN without contacts."""
    fabric_deviator: np.ndarray
    """(D, D) deviator R' = R - I/D (eq. 6)."""
    a_r: np.ndarray
    """(D, D) fabric anisotropy a^r = 15/2 R' (3D, eq. 5) or 4 R' (2D); traceless."""
    a_r_mag: float
    """Scalar amplitude of a^r (see anisotropy_magnitude)."""
    fabric_eigenvalues: np.ndarray
    """(D,) eigenvalues Phi_1 >= ... of R, clipped to [0, 1] against rounding."""
    fabric_eigenvectors: np.ndarray
    """(D, D) unit eigenvectors of R, column k for eigenvalue k."""
    phi_d: float
    """Barreto's Phi_d (eq. 15) of the fabric eigenvalues; in 2D Phi_1 - Phi_2 (see phi_d)."""
    anisotropy: dict[str, float]
    """Table 1 measures of the fabric eigenvalues: dict 'curry', 'thornton', 'ibraim', 'maeda'
    (Phi_min = Phi_3 in 3D; see anisotropy_measures).
    """
    f0: float
    """Mean normal force over equal-weight orientation groups, eq. 8 (N); bin-free estimator
    (force_tensors). NaN without forces.
    """
    force_normal_tensor: np.ndarray
    """(D, D) normal-force tensor F^n (eq. 9, N), bin-free; tr = f0."""
    a_n: np.ndarray
    """(D, D) normal-force anisotropy a^n = c_D (F^n/f0 - I/D), bin-free."""
    a_n_mag: float
    """Scalar amplitude of a^n (see anisotropy_magnitude)."""
    force_normal_eigenvalues: np.ndarray
    """(D,) eigenvalues of F^n, descending (N)."""
    force_normal_eigenvectors: np.ndarray
    """(D, D) eigenvectors of F^n, column k for eigenvalue k."""
    force_tangential_tensor: np.ndarray
    """(D, D) tangential-force tensor F^t_ij = <f^t_i n_j> (eq. 13, N), bin-free; traceless, not
    necessarily symmetric.
    """
    a_t: np.ndarray
    """(D, D) tangential anisotropy a^t = 5 sym(F^t)/f0 (3D), 4 sym(F^t)/f0 (2D)."""
    a_t_mag: float
    """Scalar amplitude of a^t (see anisotropy_magnitude)."""
    n_bins: int | None
    """Orientation-group resolution of the binned estimator, or None."""
    f0_binned: float | None
    """f0 by the binned estimator (N); None unless binned=True."""
    force_normal_tensor_binned: np.ndarray | None
    """(D, D) F^n, binned estimator; None unless binned=True."""
    a_n_binned: np.ndarray | None
    """(D, D) a^n, binned estimator; None unless binned=True."""
    force_tangential_tensor_binned: np.ndarray | None
    """(D, D) F^t, binned; None unless binned=True."""
    a_t_binned: np.ndarray | None
    """(D, D) a^t, binned (traceless); None unless binned=True."""
    container: str
    """The container: "box", "periodic" (lateral axes repeating) or "cylinder"."""
    container_source: str
    """Where `container` comes from: "scene" (a generated pack's), "file" (what the file
    read said: a granpack pack, the container tag of granpack's exports, a dump's or XYZ
    file's periodic flags), "argument" (``container=``, ``periodic=``, ``cylinder_radius=``,
    or ``granpack analyze --container``) or "assumed" (nothing said: a box, walled at the
    file's box, or with no walls where the file has none)."""
    container_volume: float
    """V, the container's volume up to H_top (m^3; m^2 in 2D): base x (H_top - floor) for the
    box and the periodic cell, pi R^2 (H_top - floor) for the cylinder. phi = solid / V."""
    coordination_distribution: np.ndarray
    """(k_max + 1,) P[k], the fraction of particles with k particle-particle contacts (-);
    sum_k P[k] = 1 and sum_k k P[k] = Z."""
    z_std: float
    """Width of P[k]: the standard deviation sqrt(sum_k k^2 P[k] - Z^2) of the contacts per
    particle (-)."""
    n_rattlers_iterative: int
    """Rattlers removed iteratively: particles with fewer than D + 1 contacts with the
    particles left and the walls, removed until none is left. The removal of LAMMPS
    ``compute rattlers/atom``, except that granpack counts wall contacts (floor, side
    walls, cylinder; walls are never removed) and LAMMPS cannot (its compute sees only
    the pair contacts of the pair style, not fix wall/gran): a particle held by a wall is
    a rattler there and not here, and the counts differ by up to a factor of 2 in packs
    where many particles touch a wall. LAMMPS' count: ``rattlers_iterative`` on the
    particle pairs only (``contacts.particle_pairs()``)."""
    z_mech_iterative: float
    """Mechanical coordination number of the network left after the iterative removal:
    2 N_c' / (N_p - N_r), N_c' the contacts among the N_p - N_r particles left (-); NaN
    when none is left. ``z_mech`` is the one-pass reading (Thornton 2000)."""
    n_rattlers_frictional: int
    """As n_rattlers_iterative with D contacts needed instead of D + 1 (a frictional particle
    under gravity can rest on D: a disc on two, a sphere on three)."""
    z_mech_frictional: float
    """As z_mech_iterative for the removal with D contacts needed (-)."""
    stress: np.ndarray
    """(D, D) Love-Weber stress, symmetric part, compression positive (Pa; N/m in 2D):
    sigma = (1/V) sum_c f_c (x) l_c over particle-particle contacts (f_c the force on j,
    l_c = x_j - x_i, minimum image in a periodic cell) and wall contacts (f_c the force on the
    wall, l_c from the centre to the contact point), V = container_volume. NaN without
    forces."""
    k0: float
    """K0 = mean horizontal over vertical stress (-): (sigma_xx + sigma_yy)/(2 sigma_zz) in 3D,
    sigma_xx/sigma_yy in 2D. NaN without forces."""
    unbalanced: float
    """YADE's unbalanced-force ratio (-): the mean over particles of |net force| (the
    contact forces and the weight) over the mean |contact force|, wall contacts included.
    A pack at rest has it near 0; a deposit made with the paper's 1 s of jamming per layer
    is not quite at rest. NaN without forces, or where the weights are unknown (another
    code's file)."""
    unbalanced_max: float
    """PFC's maximum unbalanced-force ratio (-): the largest |net force| over the mean
    |contact force|. NaN as ``unbalanced``."""
    stress_profile: tuple[np.ndarray, np.ndarray]
    """(edges (S + 1,), sigma_zz (S,)): the vertical stress of S horizontal slices from the
    floor to H_top (Pa), each contact given to the slice of its contact point (the midpoint of
    the branch for a pair), over the slice's volume; their mean is stress[-1, -1]."""
    force_normal_mean: float
    """<f_n>, the plain mean normal force of the particle-particle contacts (N); the strong
    network is f_n > <f_n>. NaN without forces."""
    n_strong: int
    """Number of strong contacts, f_n > <f_n> (Radjai et al. 1998)."""
    strong_fraction: float
    """n_strong / N_c (-); NaN without forces."""
    fabric_strong: np.ndarray
    """(D, D) fabric tensor of the strong contacts; N_s R_s + N_w R_w = N_c R."""
    fabric_weak: np.ndarray
    """(D, D) fabric tensor of the weak contacts (f_n <= <f_n>)."""
    a_r_strong: np.ndarray
    """(D, D) anisotropy of the strong fabric, c_D (R_s - I/D) (-)."""
    a_r_weak: np.ndarray
    """(D, D) anisotropy of the weak fabric, c_D (R_w - I/D) (-)."""
    a_r_strong_mag: float
    """Scalar amplitude of a_r_strong (see anisotropy_magnitude)."""
    a_r_weak_mag: float
    """Scalar amplitude of a_r_weak (see anisotropy_magnitude)."""
    force_distribution: tuple[np.ndarray, np.ndarray]
    """(edges, pdf): P(f_n/<f_n>), the probability density of the normalised normal force over
    bins of width 0.1 from 0 (-); sum pdf x 0.1 = 1."""
    q6: np.ndarray
    """(N,) local bond order over contact neighbours: Steinhardt's q6 in 3D, psi6 in 2D (-);
    NaN for a particle without contacts (see granpack.steinhardt)."""
    q6_mean: float
    """Mean of q6 over the particles that have contacts (-)."""
    q6_global: float
    """Global Q6 (3D) or Psi6 (2D) over all bonds (-)."""
    crystal_fraction: float
    """Crystallised fraction (-): particles with q6 >= 0.45 (3D; psi6 >= 0.7 in 2D) and at
    least 4 (3D; 3 in 2D) solid-like contacts, whose two particles' bond-order vectors
    correlate by 0.7 or more (see granpack.analysis.BondOrder)."""
    grading: Grading
    """The realised grading of the particles (D10 ... D90, Cu, Cc by mass and by number;
    docs/grading.md), mass weighed by the pack's inertia_2d in 2D ("disc" for bare
    positions and radii)."""

    def __post_init__(self) -> None:
        for f in fields(self):
            object.__setattr__(self, f.name, _readonly(getattr(self, f.name)))

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
        a_n_binned_*, a_t_binned_*, a_n_binned_mag, a_t_binned_mag, n_bins. Beyond the
        paper: container_volume, coordination_p0 .. coordination_p14 and
        coordination_p15plus (P[k]), z_std, n_rattlers_iterative, z_mech_iterative,
        n_rattlers_frictional, z_mech_frictional, stress_* (upper components), k0,
        unbalanced, unbalanced_max,
        force_normal_mean, n_strong, strong_fraction, fabric_strong_*, fabric_weak_*,
        a_r_strong_mag, a_r_weak_mag, q6_mean, q6_global, crystal_fraction; the grading
        d10_mass, d30_mass, d50_mass, d60_mass, d90_mass, cu_mass, cc_mass and the same
        by number (d10_number ... cc_number).
        """
        v = vars(self)
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
        out["container_volume"] = float(v["container_volume"])
        p_z = v["coordination_distribution"]
        for k in range(P_Z_KEYS):
            out[f"coordination_p{k}"] = float(p_z[k]) if k < p_z.shape[0] else 0.0
        out[f"coordination_p{P_Z_KEYS}plus"] = float(np.sum(p_z[P_Z_KEYS:]))
        out["z_std"] = float(v["z_std"])
        out["n_rattlers_iterative"] = int(v["n_rattlers_iterative"])
        out["z_mech_iterative"] = float(v["z_mech_iterative"])
        out["n_rattlers_frictional"] = int(v["n_rattlers_frictional"])
        out["z_mech_frictional"] = float(v["z_mech_frictional"])
        sym("stress", v["stress"])
        out["k0"] = float(v["k0"])
        out["unbalanced"] = float(v["unbalanced"])
        out["unbalanced_max"] = float(v["unbalanced_max"])
        out["force_normal_mean"] = float(v["force_normal_mean"])
        out["n_strong"] = int(v["n_strong"])
        out["strong_fraction"] = float(v["strong_fraction"])
        sym("fabric_strong", v["fabric_strong"])
        sym("fabric_weak", v["fabric_weak"])
        out["a_r_strong_mag"] = float(v["a_r_strong_mag"])
        out["a_r_weak_mag"] = float(v["a_r_weak_mag"])
        out["q6_mean"] = float(v["q6_mean"])
        out["q6_global"] = float(v["q6_global"])
        out["crystal_fraction"] = float(v["crystal_fraction"])
        out.update({k: float(x) for k, x in v["grading"].to_dict().items()})
        return out

    def __repr__(self) -> str:
        v = vars(self)
        forces = f", f0={v['f0']:.4g} N" if v["has_forces"] else ", no forces"
        return (
            f"Microstructure(dim={v['dim']}, N_p={v['n_particles']}, N_c={v['n_contacts']}, "
            f"phi={v['phi']:.4f}, phi_core={v['phi_core']:.4f}, Z={v['z']:.3f}, "
            f"Z_m={v['z_mech']:.3f}, |a_r|={v['a_r_mag']:.4f}{forces})"
        )
