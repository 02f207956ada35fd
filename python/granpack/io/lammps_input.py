"""Input snippets that continue a pack in LAMMPS or LIGGGHTS: :func:`lammps_input` and
:func:`liggghts_input`.

Each reads the data file of granpack's export and sets up granpack's physics there: the
Hertz-Mindlin law with the scene's Young's modulus, Poisson's ratio, friction and
damping, the same walls (box, periodic cell or cylinder), gravity, drag, time step,
rotations on or off and, in 2D, the scene's mass convention. It ends with
``run ${steps}`` (0 unless ``-var steps N`` is given), and prints the number of
particle-particle contacts (``compute contact/atom``, summed: 2 N_c) as ``c_contacts``
in the thermo output.

A material with the linear law or rolling resistance ``"epsd"`` goes out with it (docs/
export.md, "The contact model in each code"): LAMMPS ``hooke k_n e`` with ``damping
tsuji`` and ``tangential linear_history``, ``rolling sds k_roll gamma_roll mu_roll`` on the
pairs and every wall; LIGGGHTS ``model hooke/stiffness`` (``kn``, ``kt``, ``gamman``,
``gammat``) and ``rolling_friction epsd3``. A constant k_roll for a material without
`rolling_stiffness` is 2.25 mu_r^2 k_n at the pack's mean contact
(`granpack.io.contact_model`); a default material's input is what it always was.

The Hertz-Mindlin damping maps exactly onto each code's form (docs/interop.md derives it):

- granpack: c_n = 2 xi sqrt(m* k_n) with k_n = 2 E* sqrt(R* d), and c_t likewise with
  k_t = 8 G* sqrt(R* d);
- LIGGGHTS ``gran model hertz``: gamma_n = -2 sqrt(5/6) beta sqrt(S_n m*) with S_n =
  k_n, beta = ln e / sqrt(ln^2 e + pi^2): the restitution e with
  -sqrt(5/6) beta = xi; the tangential damping follows the same beta, as granpack's;
- LAMMPS ``pair granular ... damping tsuji``: eta_n = alpha(e) sqrt(m* 4/3 E* a) with
  a = sqrt(R* d) and Tsuji's polynomial alpha(e): the e with alpha(e) = 2 sqrt(3/2) xi;
  the tangential damping is that of the normal times the factor sqrt(k_t / k_n) =
  sqrt(2 (1 - nu) / (2 - nu)) that granpack's c_t has over its c_n.

A consolidated pack (`granpack.consolidate`) continues as the consolidation left it: the
walls at their consolidated positions and the lid a wall of the same material (LAMMPS
``fix wall/gran ... zplane NULL z_lid``, LIGGGHTS ``fix wall/gran ... primitive zplane
z_lid``), held fixed; gravity and drag as in the stage (no drag; gravity as its record
says) and the stage's time step. The thermo output adds ``v_lid_force``, the particles'
normal force on the lid (N), granpack's `lid_force` at the export. A
comment block gives the commands that hold the lid at the target stress with a servo
instead (LAMMPS: a plane region moved by a variable that a loop corrects from the lid
force; LIGGGHTS: ``fix mesh/surface/stress/servo`` on a lid mesh the input writes).

LAMMPS 29Sep2021's ``fix wall/gran ... hertz/material`` takes E/(2 (1 - nu)) for a wall,
(1 + nu) times the pair's E* = E/(2 (1 - nu^2)), and its ``mindlin NULL`` tangential
stiffness is (2 - nu)(1 + nu) E a / 4 instead of 8 G* a = 2 E a / ((2 - nu)(1 + nu))
(a = sqrt(r d); 0.60 of it at nu = 0.25): the consolidated input gives its walls the
stiffnesses themselves (``hertz`` k_n = 4/3 E*, ``mindlin`` k_t = 8 G*), granpack's wall
law, so that the lid force is granpack's. A deposit's input keeps ``hertz/material``.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from .._validate import InvalidParameterError
from ..analysis.container import Container, _consolidation_record
from .contact_model import (
    mean_contact,
    normal_stiffness_at_mean,
    rolling_stiffness_at_mean,
    rolling_stiffness_words,
)

if TYPE_CHECKING:
    from ..pack import Pack
    from ..simulation import Material

__all__ = [
    "SNIPPET_NAME",
    "liggghts_restitution",
    "lammps_restitution",
    "lammps_linear_restitution",
    "tsuji_alpha",
    "lammps_input",
    "liggghts_input",
    "lid_force",
    "lid_area",
    "lid_height",
]

#: The file name of the input snippet beside the data file.
SNIPPET_NAME = "in.granpack"


def lid_height(pack: Pack) -> float | None:
    """The height (m) of a consolidated pack's lid above the floor at 0, as the analysis
    takes it (the top of the pack's box); None for a deposit, whose top is open. The
    exports' container tag carries it (``lid=``), so that a file read back is analysed
    up to the lid."""
    rec = _consolidation_record(pack)
    return None if rec is None else float(rec["height"])


def lid_area(pack: Pack) -> float:
    """The lid's area (m^2; m in 2D) of a consolidated pack: the box's cross-section, or
    pi R^2 for the cylinder at its consolidated radius R."""
    rec = _consolidation_record(pack)
    if rec is None:
        raise InvalidParameterError(
            "invalid pack: it is not consolidated (no lid); see granpack.consolidate",
            parameter="pack",
        )
    kind = Container.of_pack(pack).kind
    if kind == "cylinder":
        return math.pi * float(rec["walls"]["cylinder"]) ** 2
    return float(math.prod(pack.scene.base))


def lid_force(pack: Pack) -> float:
    """The particles' normal force on the lid of a consolidated pack (N): the record's lid
    stress times `lid_area` (in 2D, N/m times m). ``v_lid_force`` in the thermo output of
    ``in.granpack`` is the same force as the other code computes it."""
    area = lid_area(pack)  # refuses a deposit
    rec = _consolidation_record(pack)
    assert rec is not None
    return float(rec["wall_stress"]["lid"]) * area


def _dt(pack: Pack) -> float:
    """The time step that continues the pack: the consolidation stage's for a consolidated
    pack (the contacts under load are stiffer than the deposit's), the scene's otherwise."""
    rec = _consolidation_record(pack)
    return float(rec["dt"]) if rec is not None and "dt" in rec else float(pack.scene.dt)


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
    return _tsuji_inverse(2.0 * math.sqrt(1.5), damping)


def lammps_linear_restitution(damping: float) -> float:
    """Restitution e that makes LAMMPS' Tsuji damping of a ``hooke`` contact granpack's
    linear law's (damping ratio xi): LAMMPS 29Sep2021 damps it with alpha(e) sqrt(m* k_n),
    granpack with 2 xi sqrt(m* k_n), so alpha(e) = 2 xi."""
    return _tsuji_inverse(2.0, damping)


def _tsuji_inverse(factor: float, damping: float) -> float:
    """The e with tsuji_alpha(e) = factor * damping, by bisection."""
    want = factor * damping
    if want >= tsuji_alpha(0.0):
        raise InvalidParameterError(
            f"invalid damping = {damping}: LAMMPS' Tsuji damping reaches at most "
            f"{tsuji_alpha(0.0) / factor:.4f}",
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
    container = Container.of_pack(pack)
    kind, radius = container.kind, container.radius
    lines = [
        f"# {code} input from granpack: continues the pack of {data_name}",
        f"# dim={s.dim} N={len(pack)} seed={s.seed} stream={s.stream} container={kind}"
        + (f" cylinder_radius={_g(radius)}" if radius is not None else ""),
        f"# {code.split()[0].lower()} -in {SNIPPET_NAME} [-var steps N]   (N steps of dt = "
        f"{_dt(pack):g} s; default 0)",
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
    kind = Container.of_pack(pack).kind
    side = "p" if kind == "periodic" else "f"
    return f"{side} {side} m" if pack.dim == 3 else f"{side} m p"


def _consolidated_notes(pack: Pack, code: str) -> list[str]:
    """The comment block of a consolidated pack's input: the walls, the lid force, and
    what the run keeps of the consolidation stage."""
    rec = _consolidation_record(pack)
    assert rec is not None
    w = rec["walls"]
    v = "z" if pack.dim == 3 else "y"
    unit, area_unit = "N", ("m^2" if pack.dim == 3 else "m")
    targets = ", ".join(f"{n} {float(t):g}" for n, t in rec["targets"].items())
    walls = [f"floor {v} = {_g(w['floor'])}", f"lid {v} = {_g(w['lid'])}"]
    if "cylinder" in w:
        walls.append(f"cylinder radius {_g(w['cylinder'])}")
    for ax in ("x", "y"):
        if f"{ax}_lo" in w:
            walls.append(f"{ax} = {_g(w[f'{ax}_lo'])} .. {_g(w[f'{ax}_hi'])}")
    gravity = "on" if rec.get("gravity") else "off"
    stress = "Pa" if pack.dim == 3 else "N/m"
    return [
        f"# Consolidated sample: {rec.get('mode', 'oedometric')}, targets {targets} {stress}.",
        "# The walls where the consolidation left them, of the same material (m):",
        f"#   {', '.join(walls)}",
        f"# granpack's lid force: {float(rec['wall_stress']['lid']):.10g} {stress} over "
        f"{lid_area(pack):.10g} {area_unit} = {lid_force(pack):.10g} {unit}; v_lid_force in the",
        f"# thermo output is that force as {code} computes it (its normal force on the lid).",
        f"# As in the consolidation stage: gravity {gravity}, no drag, the stage's dt. The walls",
        "# stay where they are. The data file holds no tangential history: the contacts'",
        "# tangential springs start from zero and the sample relaxes a little at first",
        "# (docs/interop.md, Consolidated samples).",
    ]


def _lid_stiffness(pack: Pack) -> float:
    """The lid contacts' normal stiffness summed, sum 2 E* sqrt(r d) (N/m): the servo's
    gain is its inverse (the sample beneath is softer, so each correction falls short of
    the error and the lid does not overshoot)."""
    rec = _consolidation_record(pack)
    assert rec is not None
    m = pack.scene.material
    e_star = m.e_star
    top = pack.positions[:, -1] + pack.radii - float(rec["walls"]["lid"])
    d = top[top > 0.0]
    r = pack.radii[top > 0.0]
    if m.contact_law == "linear":
        assert m.normal_stiffness is not None
        return float(m.normal_stiffness) * max(len(d), 1)
    k = float(sum(2.0 * e_star * math.sqrt(ri * di) for ri, di in zip(r, d, strict=True)))
    # a lid without contacts: one contact of the mean particle at 1e-3 of its radius
    if k <= 0.0:
        r_mean = float(pack.radii.mean())
        k = 2.0 * e_star * r_mean * math.sqrt(1e-3)
    return k


def lammps_input(pack: Pack, data_name: str) -> str:
    """A LAMMPS input (29Sep2021 or later, GRANULAR package) that reads `data_name`
    with the pack's material, container, gravity and drag (see the module notes)."""
    s = pack.scene
    m = s.material
    container = Container.of_pack(pack)
    kind, radius = container.kind, container.radius
    rec = _consolidation_record(pack)
    model_notes: list[str] = []
    if m.contact_law == "linear":
        law, model_notes = _lammps_linear_law(m)
        wall_law = law
    else:
        e = lammps_restitution(m.damping)
        t_damp = math.sqrt(2.0 * (1.0 - m.poisson) / (2.0 - m.poisson))
        law = (
            f"hertz/material {_g(m.young)} {_g(e)} {_g(m.poisson)} tangential mindlin NULL "
            f"{_g(t_damp)} {_g(m.friction)} damping tsuji limit_damping"
        )
        wall_law = law
        if rec is not None:
            # granpack's wall law, stiffnesses given (see the module notes)
            e_star = m.e_star
            g_star = m.young / (4.0 * (2.0 - m.poisson) * (1.0 + m.poisson))
            wall_law = (
                f"hertz {_g(4.0 / 3.0 * e_star)} {_g(e)} tangential mindlin "
                f"{_g(8.0 * g_star)} {_g(t_damp)} {_g(m.friction)} damping tsuji limit_damping"
            )
    rolling, rolling_notes = _lammps_rolling(pack)
    law += rolling
    wall_law += rolling
    model_notes += rolling_notes
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
    ]
    if m.contact_law == "linear":
        out.append(f"# granpack's linear law; damping ratio {m.damping:g}")
    else:
        out += [
            "# Hertz-Mindlin with granpack's damping (restitution and tangential factor: see",
            f"# docs/interop.md); damping ratio {m.damping:g}",
        ]
    out += model_notes
    out += [
        "pair_style      granular",
        f"pair_coeff      * * {law}",
    ]
    floor = "zplane" if s.dim == 3 else "yplane"
    if rec is not None:
        out += _consolidated_notes(pack, "LAMMPS")
    if rec is not None and m.contact_law != "linear":
        out += [
            "# fix wall/gran's hertz/material gives a wall (1 + nu) times the pair law's normal",
            "# stiffness and another Mindlin one: the walls take granpack's, k_n = 4/3 E* and",
            "# k_t = 8 G* (times sqrt(r d))",
        ]
    w = rec["walls"] if rec is not None else {}
    lo_floor = _g(w["floor"]) if rec is not None else "0.0"
    walls = [f"fix             floor all wall/gran granular {wall_law} {floor} {lo_floor} NULL"]
    if kind == "box":
        x = (_g(w["x_lo"]), _g(w["x_hi"])) if rec is not None else ("0.0", _g(s.base[0]))
        walls.append(
            f"fix             wall_x all wall/gran granular {wall_law} xplane {x[0]} {x[1]}"
        )
        if s.dim == 3:
            y = (_g(w["y_lo"]), _g(w["y_hi"])) if rec is not None else ("0.0", _g(s.base[1]))
            walls.append(
                f"fix             wall_y all wall/gran granular {wall_law} yplane {y[0]} {y[1]}"
            )
    elif kind == "cylinder":
        assert radius is not None
        walls += [
            f"region          can cylinder z {_g(radius)} {_g(radius)} {_g(radius)} 0.0 INF "
            "side in units box open 1 open 2",
            f"fix             wall_cyl all wall/gran/region granular {wall_law} region can",
        ]
    out += walls
    if rec is not None:
        col = 4 if s.dim == 3 else 3  # contacts array: flag, fx, fy, fz, ...
        out += [
            f"fix             lid all wall/gran granular {wall_law} {floor} NULL "
            f"{_g(w['lid'])} contacts",
            f"compute         lid_f all reduce sum f_lid[{col}]",
            "variable        lid_force equal -c_lid_f",
        ]
    if rec is None or rec.get("gravity"):
        out.append(f"fix             gravity all gravity {_g(s.gravity)} vector {vert}")
    if s.drag > 0.0 and rec is None:
        out.append(f"fix             drag all viscous {_g(s.drag)}")
    if s.rotations:
        disc = " disc" if s.dim == 2 and s.inertia_2d == "disc" else ""
        out.append(f"fix             integrate all nve/sphere{disc}")
    else:
        out.append("fix             integrate all nve   # rotations off: spins are not integrated")
    if s.dim == 2:
        out.append("fix             plane all enforce2d")
    out += _run_lines(pack, rec is not None)
    if rec is not None:
        out += _lammps_servo(pack, wall_law)
    out.append("")
    return "\n".join(out)


def _lammps_linear_law(m: Material) -> tuple[str, list[str]]:
    """LAMMPS' form of granpack's linear law, and the comment lines that explain it:
    ``hooke k_n e`` with ``damping tsuji`` (29Sep2021 damps a hooke contact with
    alpha(e) sqrt(m* k_n): alpha(e) = 2 xi gives c_n = 2 xi sqrt(m* k_n) on every contact)
    and ``tangential linear_history k_t x mu`` (its damping x times the normal's:
    x = sqrt(k_t / k_n) gives c_t = 2 xi sqrt(m* k_t)). Walls take the same law."""
    k_n = m.normal_stiffness
    k_t = m.tangential_stiffness_or_default
    assert k_n is not None and k_t is not None
    e = lammps_linear_restitution(m.damping)
    x_t = math.sqrt(k_t / k_n)
    law = (
        f"hooke {_g(k_n)} {_g(e)} tangential linear_history {_g(k_t)} {_g(x_t)} "
        f"{_g(m.friction)} damping tsuji limit_damping"
    )
    notes = [
        f"# k_n = {_g(k_n)} N/m, k_t = {_g(k_t)} N/m; c = 2 xi sqrt(m* k) on every contact:",
        "# damping tsuji with the e of alpha(e) = 2 xi (LAMMPS 29Sep2021's Tsuji prefactor;",
        "# the LAMMPS source of 2025-2026 multiplies it by sqrt(2): there the damping is",
        "# sqrt(2) times granpack's, docs/interop.md) and the tangential factor sqrt(k_t / k_n)",
    ]
    return law, notes


def _lammps_rolling(pack: Pack) -> tuple[str, list[str]]:
    """The ``rolling sds k_roll gamma_roll mu_roll`` words of the pair and wall laws, and
    their comment lines (both empty without rolling resistance). LAMMPS' k_roll is a
    constant: a material without `rolling_stiffness` gets 2.25 mu_r^2 k_n at the pack's
    mean contact (contact_model.rolling_stiffness_at_mean)."""
    m = pack.scene.material
    if m.rolling == "none":
        return "", []
    assert m.rolling_friction is not None
    k_r = rolling_stiffness_at_mean(pack)
    gamma_r = 0.0 if m.rolling_damping is None else float(m.rolling_damping)
    words = f" rolling sds {_g(k_r)} {_g(gamma_r)} {_g(m.rolling_friction)}"
    notes = [
        f"# rolling resistance epsd (rolling sds): k_roll = {_g(k_r)} N/m, "
        f"gamma_roll = {_g(gamma_r)} N s/m, mu_roll = {_g(m.rolling_friction)};",
        f"# k_roll: {rolling_stiffness_words(pack)}",
    ]
    return words, notes


def _run_lines(pack: Pack, lid: bool) -> list[str]:
    """The time step, the contact count, the thermo output (with the lid force of a
    consolidated sample) and the run of ``steps`` steps that both codes' inputs end with."""
    return [
        f"timestep        {_g(_dt(pack))}",
        "compute         contact all contact/atom",
        "compute         contacts all reduce sum c_contact   # 2 N_c",
        "thermo_style    custom step atoms ke c_contacts" + (" v_lid_force" if lid else ""),
        "thermo          1000",
        "variable        steps index 0",
        "run             ${steps}",
    ]


def _lammps_servo(pack: Pack, wall_law: str) -> list[str]:
    """The commented commands that continue with the lid on a servo in LAMMPS."""
    rec = _consolidation_record(pack)
    assert rec is not None
    lid = _g(rec["walls"]["lid"])
    plane, move = (
        (f"0.0 0.0 {lid} 0.0 0.0 -1.0", "NULL NULL v_lid_dz")
        if pack.dim == 3
        else (f"0.0 {lid} 0.0 0.0 -1.0 0.0", "NULL v_lid_dz NULL")
    )
    gain = 1.0 / _lid_stiffness(pack)
    lines = [
        "unfix           lid",
        f"variable        lid_target equal {_g(lid_force(pack))}",
        f"variable        lid_gain equal {gain:.6g}   # m per N",
        "variable        lid_at equal 0.0",
        "variable        lid_to equal 0.0",
        "variable        lid_dz equal 0.0",
        f"region          lid_plane plane {plane} move {move} units box",
        f"fix             lid all wall/gran/region granular {wall_law} region lid_plane contacts",
        "run             0 post no",
        "variable        servo_loop loop 100   # 100 corrections, 100 steps each",
        "label           servo",
        "variable        lid_to equal $(v_lid_at+v_lid_gain*(v_lid_force-v_lid_target))",
        "variable        lid_dz equal ${lid_at}+(${lid_to}-${lid_at})*(step-$(step))/100",
        "run             100",
        "variable        lid_at equal ${lid_to}",
        "next            servo_loop",
        "jump            SELF servo",
    ]
    return [
        "# To continue with the lid held at granpack's lid force by a servo instead (fix",
        "# wall/gran cannot move by feedback): a plane region that a variable moves, under",
        "# fix wall/gran/region (which sees the region's speed). Every 100 steps the loop",
        "# sets the lid's next position from the force error (gain: the inverse of the lid",
        "# contacts' stiffness) and moves it there at constant speed. Uncomment:",
        *(f"# {ln}" for ln in lines),
    ]


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
    container = Container.of_pack(pack)
    kind, radius = container.kind, container.radius
    rec = _consolidation_record(pack)
    r_min = float(pack.radii.min()) if len(pack) else float(s.r_min or s.r_mean)
    normal, properties = _liggghts_model(pack)
    rolling = " rolling_friction epsd3" if m.rolling != "none" else ""
    wall = f"wall/gran model {normal} tangential history{rolling} primitive type 1"
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
        *properties,
        f"pair_style      gran model {normal} tangential history{rolling} limitForce on",
        "pair_coeff      * *",
    ]
    if rec is not None:
        out += _consolidated_notes(pack, "LIGGGHTS")
    w = rec["walls"] if rec is not None else {}
    out.append(f"fix             floor all {wall} zplane {_g(w['floor']) if rec else '0.0'}")
    if kind == "box":
        x = (_g(w["x_lo"]), _g(w["x_hi"])) if rec is not None else ("0.0", _g(s.base[0]))
        y = (_g(w["y_lo"]), _g(w["y_hi"])) if rec is not None else ("0.0", _g(s.base[1]))
        out += [
            f"fix             wall_x0 all {wall} xplane {x[0]}",
            f"fix             wall_x1 all {wall} xplane {x[1]}",
            f"fix             wall_y0 all {wall} yplane {y[0]}",
            f"fix             wall_y1 all {wall} yplane {y[1]}",
        ]
    elif kind == "cylinder":
        assert radius is not None
        out.append(
            f"fix             wall_cyl all {wall} zcylinder {_g(radius)} {_g(radius)} {_g(radius)}"
        )
    if rec is not None:
        out += [
            f"fix             lid all {wall} zplane {_g(w['lid'])} store_force yes",
            "compute         lid_f all reduce sum f_force_lid[3]",
            "variable        lid_force equal -c_lid_f",
        ]
    if rec is None or rec.get("gravity"):
        out.append(f"fix             gravity all gravity {_g(s.gravity)} vector 0.0 0.0 -1.0")
    if s.drag > 0.0 and rec is None:
        out.append(f"fix             drag all viscous {_g(s.drag)}")
    if s.rotations:
        out.append("fix             integrate all nve/sphere")
    else:
        out.append("fix             integrate all nve   # rotations off: spins are not integrated")
    out += _run_lines(pack, rec is not None)
    if rec is not None:
        out += _liggghts_servo(pack, wall)
    out.append("")
    return "\n".join(out)


def _liggghts_model(pack: Pack) -> tuple[str, list[str]]:
    """LIGGGHTS' normal model (``hertz`` or ``hooke/stiffness``) for the pack's material,
    and the lines that set its properties (and the rolling resistance's).

    - Hertz-Mindlin: Young's modulus, Poisson's ratio, the restitution that gives
      granpack's damping, the friction.
    - Linear: ``hooke/stiffness`` with ``kn``, ``kt`` and the damping per unit mass
      ``gamman`` = 2 xi sqrt(k_n / m*), ``gammat`` = 2 xi sqrt(k_t / m*) at the pack's
      mean m*: LIGGGHTS damps with gamma m*, granpack with 2 xi sqrt(m* k), so a contact
      of reduced mass m* is damped sqrt(m* / mean m*) times granpack's.
    - Rolling ``epsd``: ``rolling_friction epsd3`` (epsd2's stiffness is k_t R*^2, not
      granpack's), whose torque spring is rollingStiffness k_n mu_r^2 R*^2 with LIGGGHTS'
      k_n, the secant F_n / d: 4/3 E* sqrt(R* d) for Hertz, so rollingStiffness = 2.25 *
      3/2 gives granpack's default 2.25 mu_r^2 (2 E* sqrt(R* d)) on every contact, and
      2.25 is the linear law's. A given `rolling_stiffness` k_r becomes k_r / (mu_r^2
      k_n) (Hertz: k_n at the mean contact); epsd3's dashpot
      coefficientRollingViscousDamping eta_r (damping torque eta_r 2 sqrt(I_r k_r R*^2)
      times the relative spin) is granpack's gamma_r R*^2 at the mean contact
      (I_r = 1.4 m* r^2 of two spheres of its R*).
    """
    m = pack.scene.material
    lines: list[str] = []
    if m.contact_law == "linear":
        k_n = m.normal_stiffness
        k_t = m.tangential_stiffness_or_default
        assert k_n is not None and k_t is not None
        mc = mean_contact(pack)
        g_n = 2.0 * m.damping * math.sqrt(k_n / mc.m_star)
        g_t = 2.0 * m.damping * math.sqrt(k_t / mc.m_star)
        lo, hi = (math.sqrt(v / mc.m_star) for v in mc.m_star_range)
        normal = "hooke/stiffness"
        lines += [
            f"# granpack's linear law: k_n = {_g(k_n)} N/m, k_t = {_g(k_t)} N/m, damping ratio "
            f"{m.damping:g};",
            "# hooke/stiffness damps with gamma m*: gamma = 2 xi sqrt(k / m*) at the mean m* = "
            f"{mc.m_star:.6g} kg,",
            f"# so the pack's contacts are damped {lo:.3g} to {hi:.3g} times granpack's "
            "(sqrt(m* / mean m*))",
            f"fix             m1 all property/global kn peratomtypepair 1 {_g(k_n)}",
            f"fix             m2 all property/global kt peratomtypepair 1 {_g(k_t)}",
            f"fix             m3 all property/global gamman peratomtypepair 1 {_g(g_n)}",
            "fix             m4 all property/global coefficientFriction peratomtypepair 1 "
            + _g(m.friction),
            f"fix             m5 all property/global gammat peratomtypepair 1 {_g(g_t)}",
        ]
    else:
        e = liggghts_restitution(m.damping)
        normal = "hertz"
        lines += [
            f"fix             m1 all property/global youngsModulus peratomtype {_g(m.young)}",
            f"fix             m2 all property/global poissonsRatio peratomtype {_g(m.poisson)}",
            f"# the restitution that gives granpack's damping ratio {m.damping:g} "
            "(docs/interop.md)",
            "fix             m3 all property/global coefficientRestitution peratomtypepair 1 "
            + _g(e),
            "fix             m4 all property/global coefficientFriction peratomtypepair 1 "
            + _g(m.friction),
        ]
    if m.rolling != "none":
        lines += _liggghts_rolling(pack)
    return normal, lines


def _liggghts_rolling(pack: Pack) -> list[str]:
    """The property lines of ``rolling_friction epsd3`` (`_liggghts_model`)."""
    m = pack.scene.material
    mu_r = m.rolling_friction
    assert mu_r is not None
    mc = mean_contact(pack)
    # LIGGGHTS' k_n per unit of granpack's: Hertz's secant is 2/3 of the tangent
    secant = 1.0 if m.contact_law == "linear" else 2.0 / 3.0
    if m.rolling_stiffness is None or mu_r == 0.0:
        coeff = 2.25 / secant
        how = (
            "2.25 mu_r^2 k_n with granpack's k_n (the current one): exact on every contact"
            if m.rolling_stiffness is None
            else "mu_r = 0: no rolling torque, whatever the stiffness"
        )
    else:
        coeff = m.rolling_stiffness / (mu_r**2 * secant * normal_stiffness_at_mean(pack))
        how = "the material's k_r / (mu_r^2 k_n)" + (
            " (exact)" if m.contact_law == "linear" else " with k_n at the pack's mean contact"
        )
    if coeff < 1.0:
        raise InvalidParameterError(
            f"invalid rolling_stiffness = {m.rolling_stiffness!r}: LIGGGHTS' epsd3 needs "
            f"rollingStiffness = k_r / (mu_r^2 k_n) >= 1 in SI units, and this material gives "
            f"{coeff:.6g}; export for LAMMPS ('lammps-data'), or give k_r >= "
            f"{m.rolling_stiffness / coeff if m.rolling_stiffness else 0.0:.6g} N/m",
            parameter="rolling_stiffness",
            value=m.rolling_stiffness,
        )
    eta_r = 0.0
    if m.rolling_damping:
        # epsd3's dashpot eta_r 2 sqrt(I_r k_r R*^2) against granpack's gamma_r R*^2, at
        # the mean contact: two spheres of radius 2 R*, I_r = 1.4 m* (2 R*)^2
        k_r = rolling_stiffness_at_mean(pack)
        inertia = 1.4 * mc.m_star * (2.0 * mc.r_star) ** 2
        eta_r = m.rolling_damping * mc.r_star / (2.0 * math.sqrt(inertia * k_r))
    return [
        f"# rolling resistance epsd: rolling_friction epsd3, mu_r = {_g(mu_r)}; rollingStiffness",
        f"# = {coeff!r}: {how}",
        "fix             m6 all property/global coefficientRollingFriction peratomtypepair 1 "
        + _g(mu_r),
        "fix             m7 all property/global coefficientRollingViscousDamping "
        f"peratomtypepair 1 {_g(eta_r)}",
        f"fix             m8 all property/global rollingStiffness scalar {_g(coeff)}",
    ]


def _liggghts_servo(pack: Pack, wall: str) -> list[str]:
    """The commented commands that continue with the lid on LIGGGHTS' servo wall."""
    rec = _consolidation_record(pack)
    assert rec is not None
    s = pack.scene
    container = Container.of_pack(pack)
    kind, radius = container.kind, container.radius
    z = float(rec["walls"]["lid"])
    # a square lid facing down, inset from the side walls by 0.1 r_min so that no node
    # lies on the domain's boundary (a sphere touches the lid at least r from a wall)
    inset = 0.1 * float(pack.radii.min())
    if kind == "cylinder":
        assert radius is not None
        lx = ly = 2.0 * radius
    else:
        lx, ly = float(s.base[0]), float(s.base[1])
    a, b, c, d = inset, lx - inset, inset, ly - inset
    stl = ["solid lid"]
    for tri in (((a, c), (b, d), (b, c)), ((a, c), (a, d), (b, d))):
        stl += ["  facet normal 0 0 -1", "    outer loop"]
        stl += [f"      vertex {_g(px)} {_g(py)} {_g(z)}" for px, py in tri]
        stl += ["    endloop", "  endfacet"]
    stl.append("endsolid lid")
    writes = [f'print           "{stl[0]}" file lid.stl']
    writes += [f'print           "{ln}" append lid.stl' for ln in stl[1:]]
    speed = float(rec.get("max_wall_speed", 0.05))
    lines = [
        *writes,
        "variable        lid_force equal f_lid_mesh[3]",
        "uncompute       lid_f",
        "unfix           lid",
        f"fix             lid_mesh all mesh/surface/stress/servo file lid.stl type 1 com "
        f"{_g(lx / 2.0)} {_g(ly / 2.0)} {_g(z)} ctrlPV force axis 0.0 0.0 -1.0 target_val "
        f"{_g(lid_force(pack))} vel_max {_g(speed)} kp 3.0",
        f"fix             lid_wall all {wall.replace(' primitive type 1', '')} mesh n_meshes 1 "
        "meshes lid_mesh",
        "run             10000",
    ]
    return [
        "# To continue with the lid held at granpack's lid force by LIGGGHTS' servo wall",
        "# instead: a mesh lid (written here as lid.stl) under fix mesh/surface/stress/servo,",
        "# moving at up to the stage's wall speed with v = vel_max kp (F* - F) / F*. Uncomment:",
        *(f"# {ln}" for ln in lines),
    ]
