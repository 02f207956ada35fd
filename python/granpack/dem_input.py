"""Input snippets that continue a pack in LAMMPS or LIGGGHTS: :func:`lammps_input` and
:func:`liggghts_input`.

Each reads the data file of granpack's export and sets up granpack's physics there: the
Hertz-Mindlin law with the scene's Young's modulus, Poisson's ratio, friction and
damping, the same walls (box, periodic cell or cylinder), gravity, drag, time step,
rotations on or off and, in 2D, the scene's mass convention. It ends with
``run ${steps}`` (0 unless ``-var steps N`` is given), and prints the number of
particle-particle contacts (``compute contact/atom``, summed: 2 N_c) as ``c_contacts``
in the thermo output.

The damping maps exactly onto each code's form (docs/interop.md derives it):

- granpack: c_n = 2 xi sqrt(m* k_n) with k_n = 2 E* sqrt(R* d), and c_t likewise with
  k_t = 8 G* sqrt(R* d);
- LIGGGHTS ``gran model hertz``: gamma_n = -2 sqrt(5/6) beta sqrt(S_n m*) with S_n =
  k_n, beta = ln e / sqrt(ln^2 e + pi^2): the restitution e with
  -sqrt(5/6) beta = xi; the tangential damping follows the same beta, as granpack's;
- LAMMPS ``pair granular ... damping tsuji``: eta_n = alpha(e) sqrt(m* 4/3 E* a) with
  a = sqrt(R* d) and Tsuji's polynomial alpha(e): the e with alpha(e) = 2 sqrt(3/2) xi;
  the tangential damping is that of the normal times the factor sqrt(k_t / k_n) =
  sqrt(2 (1 - nu) / (2 - nu)) that granpack's c_t has over its c_n.
"""

from __future__ import annotations

import math

from ._validate import InvalidParameterError
from .pack import Pack

__all__ = [
    "SNIPPET_NAME",
    "liggghts_restitution",
    "lammps_restitution",
    "tsuji_alpha",
    "lammps_input",
    "liggghts_input",
    "container_of",
]

#: The file name of the input snippet beside the data file.
SNIPPET_NAME = "in.granpack"


def container_of(pack: Pack) -> tuple[str, float | None]:
    """The pack's container ("box", "periodic" or "cylinder") and cylinder radius (m,
    None for the others), from its scene (scenes without the key are boxes)."""
    kind = getattr(pack.scene, "container", "box")
    radius = getattr(pack.scene, "cylinder_radius", None)
    if kind == "cylinder" and radius is None:
        radius = pack.scene.base[0] / 2.0
    return kind, (float(radius) if kind == "cylinder" and radius is not None else None)


def liggghts_restitution(damping: float) -> float:
    """Restitution e that makes LIGGGHTS' Hertz damping granpack's (damping ratio xi)."""
    beta = damping / math.sqrt(5.0 / 6.0)  # -beta of LIGGGHTS' formula
    if beta >= 1.0:
        return 0.0
    return math.exp(-math.pi * beta / math.sqrt(1.0 - beta * beta))


_TSUJI = (1.2728, -4.2783, 11.087, -22.348, 27.467, -18.022, 4.8218)


def tsuji_alpha(e: float) -> float:
    """Tsuji's damping coefficient alpha(e) (LAMMPS ``damping tsuji``)."""
    return sum(c * e**k for k, c in enumerate(_TSUJI))


def lammps_restitution(damping: float) -> float:
    """Restitution e that makes LAMMPS' Tsuji damping granpack's (damping ratio xi):
    alpha(e) = 2 sqrt(3/2) xi, solved by bisection (alpha falls from 1.27 at e = 0 to
    0 at e = 1)."""
    want = 2.0 * math.sqrt(1.5) * damping
    if want >= tsuji_alpha(0.0):
        raise InvalidParameterError(
            f"invalid damping = {damping}: LAMMPS' Tsuji damping reaches at most "
            f"{tsuji_alpha(0.0) / (2.0 * math.sqrt(1.5)):.4f}",
            parameter="damping",
            value=damping,
        )
    lo, hi = 0.0, 1.0
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        if tsuji_alpha(mid) > want:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def _g(v: float) -> str:
    return repr(float(v))


def _header(pack: Pack, data_name: str, code: str) -> list[str]:
    s = pack.scene
    kind, radius = container_of(pack)
    lines = [
        f"# {code} input from granpack: continues the pack of {data_name}",
        f"# dim={s.dim} N={len(pack)} seed={s.seed} stream={s.stream} container={kind}"
        + (f" cylinder_radius={_g(radius)}" if radius is not None else ""),
        f"# {code.split()[0].lower()} -in {SNIPPET_NAME} [-var steps N]   (N steps of dt = "
        f"{s.dt:g} s; default 0)",
    ]
    if s.dim == 2:
        lines.append(
            f"# 2D mass convention: {s.inertia_2d} ("
            + (
                "m = pi r^2 rho per metre, I = m r^2 / 2: set density/disc, fix nve/sphere disc"
                if s.inertia_2d == "disc"
                else "m = 4/3 pi r^3 rho, I = 2/5 m r^2: the sphere's"
            )
            + ")"
        )
    return lines


def _boundary(pack: Pack) -> str:
    # the open top shrink-wraps with the data file's height as its least value ("m"), so
    # that a particle thrown up is not lost; 2D's vertical is y and LAMMPS wants z periodic
    kind, _ = container_of(pack)
    side = "p" if kind == "periodic" else "f"
    return f"{side} {side} m" if pack.dim == 3 else f"{side} m p"


def lammps_input(pack: Pack, data_name: str) -> str:
    """A LAMMPS input (29Sep2021 or later, GRANULAR package) that reads `data_name`
    with the pack's material, container, gravity and drag (see the module notes)."""
    s = pack.scene
    m = s.material
    kind, radius = container_of(pack)
    e = lammps_restitution(m.damping)
    t_damp = math.sqrt(2.0 * (1.0 - m.poisson) / (2.0 - m.poisson))
    law = (
        f"hertz/material {_g(m.young)} {_g(e)} {_g(m.poisson)} tangential mindlin NULL "
        f"{_g(t_damp)} {_g(m.friction)} damping tsuji limit_damping"
    )
    r_min = float(pack.radii.min()) if len(pack) else float(s.r_min or s.r_mean)
    vert = "0 0 -1" if s.dim == 3 else "0 -1 0"
    out = _header(pack, data_name, "LAMMPS")
    out += [
        "units           si",
        "atom_style      sphere",
        f"dimension       {s.dim}",
        f"boundary        {_boundary(pack)}",
        "atom_modify     map array",
        "comm_modify     vel yes",
        "newton          off",
        f"read_data       {data_name}",
    ]
    if s.dim == 2 and s.inertia_2d == "disc":
        out.append(f"set             group all density/disc {_g(m.density)}")
    out += [
        f"neighbor        {_g(s.skin_ratio * r_min)} bin",
        "neigh_modify    delay 0",
        "# Hertz-Mindlin with granpack's damping (restitution and tangential factor: see",
        f"# docs/interop.md); damping ratio {m.damping:g}",
        "pair_style      granular",
        f"pair_coeff      * * {law}",
    ]
    floor = "zplane" if s.dim == 3 else "yplane"
    walls = [f"fix             floor all wall/gran granular {law} {floor} 0.0 NULL"]
    if kind == "box":
        walls.append(
            f"fix             wall_x all wall/gran granular {law} xplane 0.0 {_g(s.base[0])}"
        )
        if s.dim == 3:
            walls.append(
                f"fix             wall_y all wall/gran granular {law} yplane 0.0 {_g(s.base[1])}"
            )
    elif kind == "cylinder":
        assert radius is not None
        walls += [
            f"region          can cylinder z {_g(radius)} {_g(radius)} {_g(radius)} 0.0 INF "
            "side in units box open 1 open 2",
            f"fix             wall_cyl all wall/gran/region granular {law} region can",
        ]
    out += walls
    out.append(f"fix             gravity all gravity {_g(s.gravity)} vector {vert}")
    if s.drag > 0.0:
        out.append(f"fix             drag all viscous {_g(s.drag)}")
    if s.rotations:
        disc = " disc" if s.dim == 2 and s.inertia_2d == "disc" else ""
        out.append(f"fix             integrate all nve/sphere{disc}")
    else:
        out.append("fix             integrate all nve   # rotations off: spins are not integrated")
    if s.dim == 2:
        out.append("fix             plane all enforce2d")
    out += [
        f"timestep        {_g(s.dt)}",
        "compute         contact all contact/atom",
        "compute         contacts all reduce sum c_contact   # 2 N_c",
        "thermo_style    custom step atoms ke c_contacts",
        "thermo          1000",
        "variable        steps index 0",
        "run             ${steps}",
        "",
    ]
    return "\n".join(out)


def liggghts_input(pack: Pack, data_name: str) -> str:
    """A LIGGGHTS 3.8 input that reads `data_name` (the same data file as LAMMPS': it
    reads atom_style granular as LAMMPS' sphere) with the pack's material, container,
    gravity and drag. 3D only: LIGGGHTS has no 2D granular model."""
    s = pack.scene
    if s.dim != 3:
        raise InvalidParameterError(
            "invalid format = 'liggghts' for a 2D pack: LIGGGHTS has no 2D granular model; "
            "export 2D packs for LAMMPS (format 'lammps')",
            parameter="format",
            value="liggghts",
        )
    m = s.material
    kind, radius = container_of(pack)
    e = liggghts_restitution(m.damping)
    r_min = float(pack.radii.min()) if len(pack) else float(s.r_min or s.r_mean)
    wall = "wall/gran model hertz tangential history primitive type 1"
    out = _header(pack, data_name, "LIGGGHTS")
    out += [
        "units           si",
        "atom_style      granular",
        "atom_modify     map array",
        f"boundary        {_boundary(pack)}",
        "newton          off",
        "communicate     single vel yes",
        f"read_data       {data_name}",
        f"neighbor        {_g(s.skin_ratio * r_min)} bin",
        "neigh_modify    delay 0",
        f"fix             m1 all property/global youngsModulus peratomtype {_g(m.young)}",
        f"fix             m2 all property/global poissonsRatio peratomtype {_g(m.poisson)}",
        f"# the restitution that gives granpack's damping ratio {m.damping:g} (docs/interop.md)",
        f"fix             m3 all property/global coefficientRestitution peratomtypepair 1 {_g(e)}",
        "fix             m4 all property/global coefficientFriction peratomtypepair 1 "
        + _g(m.friction),
        "pair_style      gran model hertz tangential history limitForce on",
        "pair_coeff      * *",
        f"fix             floor all {wall} zplane 0.0",
    ]
    if kind == "box":
        out += [
            f"fix             wall_x0 all {wall} xplane 0.0",
            f"fix             wall_x1 all {wall} xplane {_g(s.base[0])}",
            f"fix             wall_y0 all {wall} yplane 0.0",
            f"fix             wall_y1 all {wall} yplane {_g(s.base[1])}",
        ]
    elif kind == "cylinder":
        assert radius is not None
        out.append(
            f"fix             wall_cyl all {wall} zcylinder {_g(radius)} {_g(radius)} {_g(radius)}"
        )
    out.append(f"fix             gravity all gravity {_g(s.gravity)} vector 0.0 0.0 -1.0")
    if s.drag > 0.0:
        out.append(f"fix             drag all viscous {_g(s.drag)}")
    if s.rotations:
        out.append("fix             integrate all nve/sphere")
    else:
        out.append("fix             integrate all nve   # rotations off: spins are not integrated")
    out += [
        f"timestep        {_g(s.dt)}",
        "compute         contact all contact/atom",
        "compute         contacts all reduce sum c_contact   # 2 N_c",
        "thermo_style    custom step atoms ke c_contacts",
        "thermo          1000",
        "variable        steps index 0",
        "run             ${steps}",
        "",
    ]
    return "\n".join(out)
