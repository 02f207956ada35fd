"""Microstructure of a pack: packing fraction, coordination, fabric and contact-force tensors.

The definitions are those of the paper's section 3, read as the documentation's
microstructure page gives them (docs/microstructure.md); D is the dimension (2: discs,
vertical y; 3: spheres, vertical z). Every quantity is computed with numpy over whole
arrays (no Python loop over particles or contacts).

Entry points
------------
``granpack.microstructure(pack)`` or ``microstructure(positions=..., radii=..., box=...)``
returns a :class:`Microstructure`. The building blocks are public too: :func:`fabric_tensor`,
:func:`force_tensors` (bin-free), :func:`force_tensors_binned` (the paper's equal-area
orientation groups), :func:`anisotropy_tensor`, :func:`eigen_sorted`, :func:`phi_d`,
:func:`anisotropy_measures`, :func:`empirical_z`, :func:`void_ratio`,
:func:`phi_from_void_ratio`, :func:`window_volumes` and :func:`read_xyzr` (``x y z r`` text
files from other DEM codes).

Beyond the paper: :func:`rdf` (pair correlation), :func:`steinhardt` (bond order and the
crystallised fraction), :func:`profiles` (depth profiles) and :func:`radial_profiles` (in a
cylinder); the result also holds P[k], rattlers, the Love-Weber stress and K0, and the strong
and weak force networks.

One module per concern: ``relations`` (void ratio, empirical Z(e)), ``tensors`` (fabric and
force tensors), ``volumes`` (exact volumes inside windows, slabs and cylinders),
``container`` (box, periodic cell, cylinder), ``coordination`` (P[k], rattlers), ``stress``
(Love-Weber, K0), ``structure`` (g(r), bond order), ``profiles``, ``reader`` (text packs),
``inputs`` (coercion of what the analysis is given, contacts in each container), ``system``
(:class:`System`, the one input of every function: ``System.from_any(pack_or_arrays)``),
``voronoi`` (local phi from the radical tessellation, optional), ``prepare`` (what
:func:`microstructure` adds beyond the paper), ``result`` (:class:`Microstructure`) and
``compute`` (:func:`microstructure`).

Warnings
--------
:class:`MicrostructureWarning` is emitted (and the affected quantities are NaN) when a
quantity is undefined: no particle-particle contacts (fabric and force tensors), an empty
core window (phi_core), or a fabric so anisotropic that the second-order contact density
1 + a^r_kl n_k n_l is not positive at some contact (bin-free force tensors). Nothing else
warns; in particular a pack given by positions and radii only has NaN force quantities
without a warning (``has_forces`` is False).
"""

from .compute import microstructure
from .container import CONTAINERS, Container, ContainerTag, wall_names
from .profiles import profiles, radial_profiles
from .reader import read_xyzr
from .relations import empirical_z, phi_from_void_ratio, void_ratio
from .result import Microstructure, MicrostructureWarning
from .structure import CRYSTAL_THRESHOLD, BondOrder, rdf, steinhardt
from .system import System
from .tensors import (
    DEFAULT_N_BINS,
    ForceTensors,
    anisotropy_magnitude,
    anisotropy_measures,
    anisotropy_tensor,
    eigen_sorted,
    fabric_tensor,
    force_tensors,
    force_tensors_binned,
    phi_d,
)
from .volumes import cylinder_volumes, slab_volumes, window_volumes
from .voronoi import local_phi

__all__ = [
    "System",
    "Microstructure",
    "BondOrder",
    "Container",
    "ContainerTag",
    "CONTAINERS",
    "wall_names",
    "CRYSTAL_THRESHOLD",
    "rdf",
    "steinhardt",
    "profiles",
    "radial_profiles",
    "local_phi",
    "slab_volumes",
    "cylinder_volumes",
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
