"""granpack's contact law and layer-loop setup in LAMMPS 22Jul2025 (GRANULAR package).

The layer loop on LAMMPS (`granpack.mpi.engine`) starts from an empty domain that
`setup_commands` sets up, fills it with ``create_atoms`` and gives each atom the radius
and mass of `atom_properties`. `check_mappable` refuses first what cannot be mapped.

The law (``pair_style granular``), with k, c the stiffness and dashpot of granpack's
contact (docs/physics.md) and a = sqrt(R* d):

- Hertz-Mindlin: ``hertz k_n e`` with k_n = 4/3 E*, so F = k_n a d; ``tangential mindlin
  k_t x mu`` with k_t = 8 G*, G* = E / (4 (2 - nu)(1 + nu)), so k_t a is granpack's
  8 G* sqrt(R* d); ``damping coeff_restitution`` with e the restitution whose LAMMPS
  prefactor makes c_n = 2 xi sqrt(m* 2 E* a) (`restitution`), and the tangential
  factor x = sqrt(2 (1 - nu) / (2 - nu)) = sqrt(k_t / k_n) of granpack's c_t over its c_n.
- Linear: ``hooke k_n e`` and ``tangential linear_history k_t x mu``, x = sqrt(k_t / k_n),
  with the same damping: c = 2 xi sqrt(m* k) on both springs.
- Rolling ``"epsd"``: ``rolling sds k_roll gamma_roll mu_roll``, whose spring, dashpot,
  cap mu_r F_n and torque R* n x f_r are granpack's; k_roll is one constant
  (`rolling_stiffness`).
- ``limit_damping``: the normal force is clamped at 0, as granpack's.

Why ``damping coeff_restitution``: LAMMPS 22Jul2025 damps with damp sqrt(m* F_n / d),
where ``damping tsuji`` takes damp = sqrt(2) alpha(e) (Tsuji's polynomial, which is
0.0003 and not 0 at e = 1, and limits xi to 0.735 under Hertz) and ``coeff_restitution``
takes damp = 2 sqrt(3/2) sqrt(5/6) beta (Hertz) or 2 beta (hooke), beta = -ln e /
sqrt(pi^2 + ln^2 e). Granpack's 2 xi sqrt(m* k_n) is 2 sqrt(3/2) xi sqrt(m* F_n / d)
under Hertz (k_n = 3/2 F_n / d) and 2 xi sqrt(m* F_n / d) under the linear law, so
beta = xi / sqrt(5/6) (Hertz) or xi (linear): closed forms, exact for xi below
sqrt(5/6) = 0.913 (Hertz) or 1 (linear).

Walls are of the particles' material, with granpack's wall law: R* = r and m* = m
against a plane, and the pair's E* and G*, so the walls take the same explicit
stiffnesses (``fix wall/gran ... granular`` with the pair law; no ``hertz/material``,
whose wall mixing differs between versions). Against granpack's cylinder (axis at
(R, R)), LAMMPS' region wall takes R* = 2 r R / (2 R - r), granpack r sqrt(R / (R - r))
(Johnson's equivalent radius); both are r (1 + r / 2R) to first order. The cylinder's
k_n and k_t are scaled by sqrt(R*_granpack / R*_LAMMPS) at the mean radius, which
makes its Hertz force, dashpot and Mindlin spring granpack's for that radius; other
radii differ by about (r/R)^2 / 16 in force (6e-4 at r = R/10). The rolling law
against the cylinder keeps LAMMPS' R*.

What LAMMPS does differently, and no parameter changes (of order d / r, the overlap
over the radius: mean 5e-4 in a 3D deposit of the paper's material, 4e-3 in a 2D one
of discs): the relative tangential velocity of a
pair takes the spins times the radii (granpack: r - d/2, the contact point), and a
wall contact's torque arm is r (granpack: r - d/2). Head-on contacts are exact; the
tests (tests/mpi/test_lammps_law.py) measure the rest.

Conventions: 2D packs are discs in the x-y plane with y vertical and z periodic and
thin (``enforce2d``); ``inertia_2d="disc"`` is ``fix nve/sphere disc`` with m = rho pi
r^2, ``"sphere"`` plain ``nve/sphere`` with m = 4/3 rho pi r^3. ``rotations=False`` is
``fix nve`` (spins stay 0; the torques act on nothing, as in granpack). Drag is ``fix
viscous c_D`` (f = -c_D v, granpack's).
"""

from __future__ import annotations

import math
import re
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from ..errors import InvalidParameterError

if TYPE_CHECKING:
    from ..scene import PackScene
    from ..simulation import Material

__all__ = [
    "LAMMPS_VERSION",
    "HERTZ_MAX_DAMPING",
    "LammpsMappingError",
    "check_mappable",
    "restitution",
    "rolling_stiffness",
    "pair_law",
    "wall_law",
    "setup_commands",
    "balance_command",
    "AtomProperties",
    "atom_properties",
]

#: The LAMMPS version (``lammps.version()``) whose source this mapping follows.
LAMMPS_VERSION = 20250722

#: Largest damping ratio xi that ``damping coeff_restitution`` reaches under Hertz
#: (exclusive): sqrt(5/6), at e -> 0. The linear law reaches any xi < 1.
HERTZ_MAX_DAMPING = math.sqrt(5.0 / 6.0)


class LammpsMappingError(InvalidParameterError):
    """A scene the LAMMPS layer loop cannot run as granpack would. ``parameter`` names the
    scene key (``"material.damping"``, ...); the message says why and
    what to do."""


def check_mappable(scene: PackScene) -> None:
    """Raises `LammpsMappingError` for what the LAMMPS layer loop cannot map:

    - ``material.damping`` at or above `HERTZ_MAX_DAMPING` (Hertz) or at 1 (linear): no
      restitution of LAMMPS' damping gives it (see the module notes).

    Everything else maps: both laws, rolling ``"epsd"``, rotations on or off, both 2D
    mass conventions, every container and radius law; the keys of the loop itself
    (``settle_time``, ``settle_tol``, ``settle_dt``, ``freeze_depth``, ``trim``, the
    stages after the deposit) are the driver's (`granpack.mpi.engine`), which runs
    ``timestep`` again for ``settle_dt`` and freezes with groups."""
    m = scene.material
    limit = 1.0 if m.contact_law == "linear" else HERTZ_MAX_DAMPING
    if m.damping >= limit:
        raise LammpsMappingError(
            f"invalid material.damping = {m.damping!r} for the LAMMPS engine: LAMMPS' "
            f"restitution damping reaches damping ratios below {limit:.6g} "
            f"({m.contact_law} law); lower it or use granpack's engine",
            parameter="material.damping",
            value=m.damping,
            expected=f"< {limit:.6g}",
        )


def restitution(material: Material) -> float:
    """The restitution e (-) of ``damping coeff_restitution`` that gives granpack's
    damping ratio xi: e = exp(-pi b / sqrt(1 - b^2)) with b = xi / sqrt(5/6) (Hertz) or
    b = xi (linear). Raises `LammpsMappingError` where b >= 1."""
    xi = float(material.damping)
    b = xi if material.contact_law == "linear" else xi / HERTZ_MAX_DAMPING
    if b >= 1.0:
        limit = 1.0 if material.contact_law == "linear" else HERTZ_MAX_DAMPING
        raise LammpsMappingError(
            f"invalid material.damping = {xi!r}: LAMMPS' restitution damping reaches damping "
            f"ratios below {limit:.6g} ({material.contact_law} law)",
            parameter="material.damping",
            value=xi,
            expected=f"< {limit:.6g}",
        )
    return math.exp(-math.pi * b / math.sqrt(1.0 - b * b))


def _g_star(material: Material) -> float:
    nu = material.poisson
    return material.young / (4.0 * (2.0 - nu) * (1.0 + nu))


def _mass(scene: PackScene, r: float) -> float:
    rho = float(scene.material.density)
    if scene.dim == 2 and scene.inertia_2d == "disc":
        return rho * math.pi * r * r
    return rho * 4.0 / 3.0 * math.pi * r**3


def rolling_stiffness(scene: PackScene) -> float:
    """LAMMPS' constant ``k_roll`` (N/m) for the scene's rolling ``"epsd"`` law: the
    material's ``rolling_stiffness`` where given; else granpack's 2.25 mu_r^2 k_n with

    - the linear law: its k_n (exact);
    - Hertz: k_n = 2 E* sqrt(R* d) of two spheres of radius ``r_mean`` (R* = r_mean / 2)
      pressed by the weight of the column of mean particles above the pack's mid-depth,
      F = m g max(1, H / (4 r_mean)) (H = ``height``, g = ``gravity``, m the mean
      particle's mass in the scene's convention), d = (3 F / (4 E* sqrt(R*)))^(2/3).
      Granpack takes each contact's current k_n, which grows as F^(1/3) with depth: the
      mid-depth is the middle of that range (a factor 8 in F is a factor 2 in k_roll).
      It came within 2 % of the mean contact's k_n of a 408-sphere deposit (example
      4.3's fast settings on a 0.3 m base, 0.3 m high) and within 9 % of an 80-disc one
      (4.1 on a 0.3 m base, 0.12 m high). Give ``rolling_stiffness`` for an exact
      mapping.

    0 without rolling resistance (``rolling="none"``)."""
    m = scene.material
    if m.rolling == "none":
        return 0.0
    if m.rolling_stiffness is not None:
        return float(m.rolling_stiffness)
    mu_r = float(m.rolling_friction or 0.0)
    if m.contact_law == "linear":
        assert m.normal_stiffness is not None
        return 2.25 * mu_r**2 * float(m.normal_stiffness)
    r = float(scene.r_mean)
    force = _mass(scene, r) * float(scene.gravity) * max(1.0, float(scene.height) / (4.0 * r))
    r_star = 0.5 * r
    d = (3.0 * force / (4.0 * m.e_star * math.sqrt(r_star))) ** (2.0 / 3.0)
    return 2.25 * mu_r**2 * 2.0 * m.e_star * math.sqrt(r_star * d)


def _num(v: float) -> str:
    return repr(float(v))


def _law(scene: PackScene, stiffness_factor: float = 1.0) -> str:
    m = scene.material
    e = restitution(m)
    if m.contact_law == "linear":
        k_n = m.normal_stiffness
        k_t = m.tangential_stiffness_or_default
        assert k_n is not None and k_t is not None
        law = (
            f"hooke {_num(k_n * stiffness_factor)} {_num(e)} tangential linear_history "
            f"{_num(k_t * stiffness_factor)} {_num(math.sqrt(k_t / k_n))} {_num(m.friction)}"
        )
    else:
        nu = m.poisson
        law = (
            f"hertz {_num(4.0 / 3.0 * m.e_star * stiffness_factor)} {_num(e)} "
            f"tangential mindlin {_num(8.0 * _g_star(m) * stiffness_factor)} "
            f"{_num(math.sqrt(2.0 * (1.0 - nu) / (2.0 - nu)))} {_num(m.friction)}"
        )
    law += " damping coeff_restitution"
    # mu_r = 0 caps the rolling force at 0, which LAMMPS' sds would reach by dividing
    # by a zero k_roll; without the model no moment is transmitted, as granpack's
    if m.rolling != "none" and m.rolling_friction:
        gamma = 0.0 if m.rolling_damping is None else float(m.rolling_damping)
        law += (
            f" rolling sds {_num(rolling_stiffness(scene))} {_num(gamma)} "
            f"{_num(m.rolling_friction)}"
        )
    return law + " limit_damping"


def pair_law(scene: PackScene) -> str:
    """The words after ``pair_coeff * *`` (``pair_style granular``) that make LAMMPS'
    pair contact granpack's (see the module notes)."""
    return _law(scene)


def _cylinder_factor(scene: PackScene) -> float:
    """sqrt(R*_granpack / R*_LAMMPS) against the cylinder, at the mean radius."""
    big = float(scene.cylinder_radius)  # type: ignore[arg-type]
    r = float(scene.r_mean)
    ratio = math.sqrt(big / (big - r)) * (2.0 * big - r) / (2.0 * big)
    if scene.material.contact_law == "linear":
        return 1.0  # constant springs: no R* in the law
    return math.sqrt(ratio)


def wall_law(scene: PackScene, *, cylinder: bool = False) -> str:
    """The law words of ``fix wall/gran ... granular`` (a plane) or ``fix
    wall/gran/region ... granular`` (``cylinder=True``: granpack's cylinder, its
    stiffnesses scaled as the module notes say) for granpack's wall of the particles'
    material."""
    return _law(scene, _cylinder_factor(scene) if cylinder else 1.0)


_GROUP = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")


def setup_commands(scene: PackScene, *, z_top: float, mobile_group: str = "mobile") -> list[str]:
    """The LAMMPS commands, ``units si`` to ``timestep``, of an empty domain for the
    scene's layer loop; the driver then adds atoms (``create_atoms``), sets their radius
    and mass (`atom_properties`), adds them to `mobile_group` and runs.

    Parameters
    ----------
    scene : PackScene
        The scene (`check_mappable` first).
    z_top : float
        The domain's initial top (m), > 0: its vertical extent is 0 .. z_top, and it
        grows with the particles (shrink-wrapped with that least extent, ``m``).
    mobile_group : str
        The group that is integrated (``fix nve/sphere``). Default ``"mobile"``, created
        empty here (``group mobile empty``; the driver adds atoms with ``group mobile id
        ...``); ``"all"`` integrates every atom.

    The domain: 3D boxes x in [0, base[0]], y in [0, base[1]] (the cylinder's square,
    its axis at (R, R)), z vertical; 2D x in [0, base[0]], y vertical, z periodic and thin.
    Side boundaries are fixed (``f``) or periodic (``p``), the vertical one shrink-wraps.
    The processors are laid across the base only (``processors * * 1``, 2D ``* 1 1``),
    in LAMMPS' brick decomposition, whose cuts `balance_command` moves along the base's
    axes only (``newton off``: each rank computes the pairs it shares with another
    itself, and needs no reverse communication of the contacts' history). The floor is a
    wall at 0, the box's side walls at 0 and base, the cylinder a region wall; gravity
    ``scene.gravity`` downwards and drag ``fix viscous scene.drag`` act on every atom;
    ``enforce2d`` in 2D. The neighbor skin is ``skin_ratio * r_min`` as granpack's.
    """
    z = float(z_top)
    if not (math.isfinite(z) and z > 0.0):
        raise InvalidParameterError(
            f"invalid z_top = {z_top!r}: must be a finite height > 0 (m)",
            parameter="z_top",
            value=z_top,
            expected="> 0",
        )
    if not isinstance(mobile_group, str) or not _GROUP.match(mobile_group):
        raise InvalidParameterError(
            f"invalid mobile_group = {mobile_group!r}: must be a LAMMPS group name "
            "(letters, digits, underscores)",
            parameter="mobile_group",
            value=mobile_group,
        )
    s = scene
    dim = s.dim
    kind = s.container
    side = "p" if kind == "periodic" else "f"
    r_min = float(s.r_min if s.r_min is not None else s.r_mean)
    r_max = float(s.r_max if s.r_max is not None else s.r_mean)
    base = [float(b) for b in s.base]
    if dim == 3:
        boundary = f"{side} {side} m"
        processors = "* * 1"
        region = f"0.0 {_num(base[0])} 0.0 {_num(base[1])} 0.0 {_num(z)}"
        down = "0.0 0.0 -1.0"
        floor = "zplane"
    else:
        boundary = f"{side} m p"
        processors = "* 1 1"
        # the discs lie at z = 0 in a periodic slab of one diameter
        region = f"0.0 {_num(base[0])} 0.0 {_num(z)} {_num(-r_max)} {_num(r_max)}"
        down = "0.0 -1.0 0.0"
        floor = "yplane"
    law = pair_law(s)
    out = [
        "units si",
        "atom_style sphere",
        f"dimension {dim}",
        f"boundary {boundary}",
        "atom_modify map array",
        "newton off",
        f"processors {processors}",
        f"region domain block {region} units box",
        "create_box 1 domain",
        "comm_modify vel yes",
        f"neighbor {_num(s.skin_ratio * r_min)} bin",
        "neigh_modify delay 0",
        "pair_style granular",
        f"pair_coeff * * {law}",
        f"fix floor all wall/gran granular {law} {floor} 0.0 NULL",
    ]
    if kind == "box":
        out.append(f"fix wall_x all wall/gran granular {law} xplane 0.0 {_num(base[0])}")
        if dim == 3:
            out.append(f"fix wall_y all wall/gran granular {law} yplane 0.0 {_num(base[1])}")
    elif kind == "cylinder":
        big = _num(float(s.cylinder_radius))  # type: ignore[arg-type]
        out += [
            f"region can cylinder z {big} {big} {big} INF INF side in units box open 1 open 2",
            f"fix wall_cyl all wall/gran/region granular {wall_law(s, cylinder=True)} region can",
        ]
    if mobile_group != "all":
        out.append(f"group {mobile_group} empty")
    if s.gravity > 0.0:
        out.append(f"fix gravity all gravity {_num(s.gravity)} vector {down}")
    if s.drag > 0.0:
        out.append(f"fix drag all viscous {_num(s.drag)}")
    if s.rotations:
        disc = " disc" if dim == 2 and s.inertia_2d == "disc" else ""
        out.append(f"fix integrate {mobile_group} nve/sphere{disc}")
    else:
        # spins stay at their value, 0: granpack's rotations=False
        out.append(f"fix integrate {mobile_group} nve")
    if dim == 2:
        out.append("fix plane all enforce2d")
    out.append(f"timestep {_num(s.dt)}")
    return out


def balance_command(scene: PackScene) -> str:
    """The command that re-splits the base among the ranks as the pack grows: the brick's
    cuts moved along the base's axes (x and y; x in 2D) until each slab holds the same
    count of particles within 10 %, the vertical never cut."""
    axes = "xy" if scene.dim == 3 else "x"
    return f"balance 1.1 shift {axes} 10 1.1"


class AtomProperties(NamedTuple):
    """Per-atom values the driver writes through ``extract_atom`` after
    ``create_atoms`` (which sets neither)."""

    #: Mass (kg; kg per metre of thickness for 2D discs), shape (N,).
    rmass: np.ndarray
    #: Radius (m), shape (N,).
    radius: np.ndarray


def atom_properties(scene: PackScene, radii) -> AtomProperties:
    """The masses and radii (float64 arrays) of particles of `radii` (m, > 0, shape
    (N,)) in the scene's mass convention: rho 4/3 pi r^3, or rho pi r^2 for 2D discs
    (``inertia_2d="disc"``). LAMMPS' ``nve/sphere`` then takes I = 2/5 m r^2 (``disc``:
    1/2 m r^2), granpack's."""
    r = np.array(radii, dtype=np.float64, copy=True)
    if r.ndim != 1:
        raise InvalidParameterError(
            f"invalid radii: expected a 1-D array of radii (m), got shape {r.shape}",
            parameter="radii",
        )
    bad = ~(np.isfinite(r) & (r > 0.0))
    if np.any(bad):
        k = int(np.argmax(bad))
        raise InvalidParameterError(
            f"invalid radii[{k}] = {r[k]!r}: must be a finite radius > 0 (m)",
            parameter=f"radii[{k}]",
            value=float(r[k]),
        )
    rho = float(scene.material.density)
    if scene.dim == 2 and scene.inertia_2d == "disc":
        m = rho * math.pi * r * r
    else:
        m = rho * 4.0 / 3.0 * math.pi * r**3
    return AtomProperties(rmass=m, radius=r)
