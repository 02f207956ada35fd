"""The result of the analysis of one pack: :class:`Microstructure`."""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

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
    (Thornton 2000), N_k = particles with k particle-particle contacts; 0 when no particle has
    two or more contacts.
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
        a_n_binned_*, a_t_binned_*, a_n_binned_mag, a_t_binned_mag, n_bins.
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
        return out

    def __repr__(self) -> str:
        v = vars(self)
        forces = f", f0={v['f0']:.4g} N" if v["has_forces"] else ", no forces"
        return (
            f"Microstructure(dim={v['dim']}, N_p={v['n_particles']}, N_c={v['n_contacts']}, "
            f"phi={v['phi']:.4f}, phi_core={v['phi_core']:.4f}, Z={v['z']:.3f}, "
            f"Z_m={v['z_mech']:.3f}, |a_r|={v['a_r_mag']:.4f}{forces})"
        )
