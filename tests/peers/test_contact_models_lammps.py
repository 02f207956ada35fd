"""granpack's contact models against LAMMPS' ``granular`` pair style and ``fix wall/gran``.

Three scenes run in both codes from the same start, in 3D and in 2D (LAMMPS
``dimension 2``: spheres held in the plane, granpack's ``inertia_2d="sphere"``), and
their trajectories (positions, velocities and spins, every few steps) are compared:

- a sphere rolling on the floor under gravity with rolling resistance ``epsd``
  (LAMMPS ``rolling sds``): it rolls, stops in the plastic regime and rocks in the
  elastic one;
- two spheres meeting obliquely (one pushed and spinning), Hertz-Mindlin with ``epsd``,
  no gravity: LAMMPS ``hertz/material ... tangential mindlin NULL ... damping tsuji``,
  the mapping of granpack's export (`granpack.io.lammps_input`);
- the same with the linear law: LAMMPS ``hooke`` with ``damping velocity`` gamma_n =
  2 xi sqrt(m* k_n) and ``tangential linear_history`` with the tangential damping
  factor sqrt(k_t / k_n) (granpack's c_t = 2 xi sqrt(m* k_t)).

granpack's rolling law (in granpack's convention, v_r = R* (w_j - w_i) x n, the
history projected with its magnitude kept, the cap mu_r F_n with F_n the clamped total
normal force, torques -/+ R* n x f_r) is LAMMPS' to the last bits: a direct
transcription with LAMMPS' other conventions reproduces both LAMMPS 29Sep2021 (the
Debian package) and 22Jul2025 to 1e-15. What remains between granpack and LAMMPS comes
from granpack's own Hertz-Mindlin conventions, older than the rolling model:

- the slip velocity at the contact: granpack takes the lever arm r - d/2 (the contact
  point), LAMMPS r; and at a wall LAMMPS' torque arm is r, granpack's r - d/2. Both
  differ by O(d/r) of the tangential terms, so the scenes are stiff (d/r of a few 1e-6
  on the floor, 1e-5 between the spheres) and agree to about d/r;
- LAMMPS' first force evaluation (``setup``) does not advance the contact histories,
  granpack's does: a contact open at the start would get one extra step of history. The
  scenes start a hair apart, so that every contact opens during a step in both codes.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from peer_runs import run

import granpack as gp
from granpack.io.lammps_input import lammps_restitution

G = 9.81  # m/s^2
NU, RHO = 0.25, 2500.0
#: the damping ratio of the tangential dashpot over the normal one (Hertz: sqrt(k_t/k_n))
T_DAMP = math.sqrt(2.0 * (1.0 - NU) / (2.0 - NU))


def _g(v: float) -> str:
    return repr(float(v))


def _mass(r: float) -> float:
    return 4.0 / 3.0 * math.pi * r**3 * RHO


def lammps_scene(bodies, *, dt, steps, every, pair=None, floor=None, gravity=0.0, dim=3) -> str:
    """A LAMMPS input: `bodies` (position, radius, velocity, spin; 3 components each)
    in a closed box, the pair law `pair` (``pair_coeff`` words) and/or the floor (z = 0,
    or y = 0 in 2D) with the wall law `floor`, gravity down, velocity Verlet
    (``nve/sphere``: a 2D particle is a sphere held in the plane, granpack's
    ``inertia_2d="sphere"``), and a dump of x, v, omega every `every` steps in full
    precision."""
    lo = 0.0 if floor else -0.1
    box = f"-0.1 0.1 {lo} 0.1 -0.01 0.01" if dim == 2 else f"-0.1 0.1 -0.1 0.1 {lo} 0.1"
    out = [
        "units           si",
        "atom_style      sphere",
        f"dimension       {dim}",
        "boundary        f f p" if dim == 2 else "boundary        f f f",
        "atom_modify     map array",
        "comm_modify     vel yes",
        "newton          off",
        f"region          box block {box} units box",
        "create_box      1 box",
    ]
    for k, (x, r, v, w) in enumerate(bodies, 1):
        out += [
            f"create_atoms    1 single {_g(x[0])} {_g(x[1])} {_g(x[2])} units box",
            f"set             atom {k} diameter {_g(2.0 * r)} density {_g(RHO)}",
            f"set             atom {k} vx {_g(v[0])} vy {_g(v[1])} vz {_g(v[2])}",
            f"set             atom {k} omega {_g(w[0])} {_g(w[1])} {_g(w[2])}",
        ]
    out += ["neighbor        0.002 bin", "neigh_modify    delay 0 every 1 check yes"]
    if pair:
        out += ["pair_style      granular", f"pair_coeff      * * {pair}"]
    else:
        out.append("pair_style      none")
    if floor:
        plane = "yplane" if dim == 2 else "zplane"
        out.append(f"fix             floor all wall/gran granular {floor} {plane} 0.0 NULL")
    if gravity:
        down = "0 -1 0" if dim == 2 else "0 0 -1"
        out.append(f"fix             gravity all gravity {_g(gravity)} vector {down}")
    out.append("fix             integrate all nve/sphere")
    if dim == 2:
        out.append("fix             plane all enforce2d")
    out += [
        f"timestep        {_g(dt)}",
        f"dump            traj all custom {every} traj.dump id x y z vx vy vz omegax omegay omegaz",
        "dump_modify     traj format float %.17g sort id",
        "thermo          1000000",
        f"run             {steps}",
        "",
    ]
    return "\n".join(out)


def lammps_trajectory(lmp: str, run_dir, text: str, n: int) -> np.ndarray:
    """Runs `text`; the dump as an array (frames, n particles, 9: x, v, omega)."""
    run(lmp, run_dir, text)
    lines = (run_dir / "traj.dump").read_text().splitlines()
    frames, i = [], 0
    while i < len(lines):
        assert lines[i].startswith("ITEM: TIMESTEP")
        assert int(lines[i + 3]) == n
        rows = [[float(w) for w in ln.split()[1:]] for ln in lines[i + 9 : i + 9 + n]]
        frames.append(rows)
        i += 9 + n
    return np.array(frames)


def granpack_trajectory(
    bodies, material, *, dt, steps, every, floor=False, gravity=0.0, dim=3
) -> np.ndarray:
    """The same scene in `gp.Simulation`: (frames, n, 9) every `every` steps from 0, in
    LAMMPS' layout (a 2D run's out-of-plane components zero)."""
    n = len(bodies)
    if dim == 2:
        box = ((-0.1, 0.0), (0.1, math.inf)) if floor else None
        spins = [b[3][2] for b in bodies]
    else:
        box = ((-0.1, -0.1, 0.0), (0.1, 0.1, math.inf)) if floor else None
        spins = [b[3] for b in bodies]
    down = [0.0] * dim
    down[-1] = -gravity
    sim = gp.Simulation(
        dim=dim, material=material, dt=dt, gravity=down, box=box, inertia_2d="sphere"
    )
    sim.add_particles(
        [b[0][:dim] for b in bodies],
        [b[1] for b in bodies],
        velocities=[b[2][:dim] for b in bodies],
        spins=spins,
    )

    def frame():
        out = np.zeros((n, 9))
        out[:, :dim] = sim.positions
        out[:, 3 : 3 + dim] = sim.velocities
        if dim == 2:
            out[:, 8] = sim.spins
        else:
            out[:, 6:9] = sim.spins
        return out

    frames = [frame()]
    for _ in range(steps // every):
        sim.step(every)
        frames.append(frame())
    return np.array(frames)


def differences(got: np.ndarray, ref: np.ndarray) -> dict[str, float]:
    """The largest difference of the changes since the start of the positions,
    velocities and spins over every frame and particle, each relative to the largest
    change of that quantity in `ref`: the changes are what the contacts make (a spin
    that the contact alters by a little would otherwise hide the difference)."""
    out = {}
    for name, cols in (("x", slice(0, 3)), ("v", slice(3, 6)), ("w", slice(6, 9))):
        a, b = got[..., cols] - got[0, ..., cols], ref[..., cols] - ref[0, ..., cols]
        out[name] = float(np.abs(a - b).max() / np.abs(b).max())
    return out


# -- a sphere rolling on the floor ------------------------------------------------------

R_A = 0.002  # m
E_A = 1e11  # Pa: stiff, so that the overlap is 2e-6 of the radius
MU_R_A = 0.05


def _floor_scene(dim: int = 3):
    e_star = E_A / (2.0 * (1.0 - NU**2))
    g_star = E_A / (4.0 * (1.0 + NU) * (2.0 - NU))
    m = _mass(R_A)
    d0 = (m * G / (4.0 / 3.0 * e_star * math.sqrt(R_A))) ** (2.0 / 3.0)
    # LAMMPS' k_roll is a constant: the default's 2.25 mu_r^2 k_n at the resting overlap
    k_r = 2.25 * MU_R_A**2 * 2.0 * e_star * math.sqrt(R_A * d0)
    mat = gp.Material(
        density=RHO,
        young=E_A,
        poisson=NU,
        damping=0.3,
        friction=0.5,
        rolling="epsd",
        rolling_friction=MU_R_A,
        rolling_stiffness=k_r,
    )
    v0 = 0.02
    # a hair above the floor: the contact opens during the first steps in both codes;
    # rolling along +x without slip (in 2D about z, the floor at y = 0)
    if dim == 2:
        bodies = [((0.0, R_A + 1e-9, 0.0), R_A, (v0, 0.0, 0.0), (0.0, 0.0, -v0 / R_A))]
    else:
        bodies = [((0.0, 0.0, R_A + 1e-9), R_A, (v0, 0.0, 0.0), (0.0, v0 / R_A, 0.0))]
    # the wall law as granpack's: k_n = 4/3 E*, k_t = 8 G* (times sqrt(r d)); fix
    # wall/gran's hertz/material would take another wall modulus
    wall = (
        f"hertz {_g(4.0 / 3.0 * e_star)} {_g(lammps_restitution(mat.damping))} damping tsuji "
        f"tangential mindlin {_g(8.0 * g_star)} {_g(T_DAMP)} {_g(mat.friction)} "
        f"rolling sds {_g(k_r)} 0.0 {_g(MU_R_A)} limit_damping"
    )
    return mat, bodies, wall


@pytest.mark.parametrize("dim", [3, 2])
def test_a_sphere_rolling_on_the_floor_follows_lammps(lmp, tmp_path, dim):
    mat, bodies, wall = _floor_scene(dim)
    kw = dict(dt=1e-6, steps=70_000, every=1000, gravity=G, dim=dim)
    ref = lammps_trajectory(lmp, tmp_path, lammps_scene(bodies, floor=wall, **kw), len(bodies))
    got = granpack_trajectory(bodies, mat, floor=True, **kw)
    assert got.shape == ref.shape
    # the scene does what it is for: rolls, stops (v_x changes sign) and rocks
    vx = ref[:, 0, 3]
    assert vx[1] > 0.0 and vx.min() < 0.0
    diff = differences(got, ref)
    # O(d/r) = 2e-6: the lever arms of the slip velocity and the wall torque (module notes)
    assert max(diff.values()) < 2e-6, diff
    # without rolling resistance it would roll on: the comparison sees the model
    bare_wall = wall.split(" rolling ")[0] + " limit_damping"
    bare = lammps_trajectory(
        lmp, tmp_path, lammps_scene(bodies, floor=bare_wall, **kw), len(bodies)
    )
    assert differences(bare, ref)["v"] > 0.5


# -- two spheres meeting ----------------------------------------------------------------

R1, R2 = 0.01, 0.007  # m
MU_R_B = 0.1
#: the rolling spring (N/m) and dashpot (N s/m) of each law's scene: with Hertz a spring of
#: the default's order (2.25 mu_r^2 k_n) that reaches the cap at once, no dashpot; with
#: the linear law a soft one that stays mostly elastic, with a dashpot whose force is of
#: the spring's order
ROLLING_B = {"hertz": (1e5, 0.0), "linear": (1e3, 0.2)}


def _pair_bodies(dim: int = 3):
    gap = 1e-7
    y = 0.002  # the offset of the centres across the push: an oblique contact
    x2 = (math.sqrt((R1 + R2 + gap) ** 2 - y * y), y, 0.0)
    # a spin off every axis in 3D; in 2D about z only
    spin = (0.0, 0.0, 40.0) if dim == 2 else (3.0, -5.0, 40.0)
    return [
        ((0.0, 0.0, 0.0), R1, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)),
        (x2, R2, (-0.01, 0.0, 0.0), spin),
    ]


def _rolling(law: str, mu_r: float) -> str:
    k_r, gamma_r = ROLLING_B[law]
    return f"rolling sds {_g(k_r)} {_g(gamma_r)} {_g(mu_r)}" if mu_r > 0.0 else ""


def _pair_case(law: str, mu_r: float) -> tuple[gp.Material, str]:
    """The material and LAMMPS' pair_coeff words of the two-sphere scene."""
    rolling = {}
    if mu_r > 0.0:
        rolling = dict(
            rolling="epsd",
            rolling_friction=mu_r,
            rolling_stiffness=ROLLING_B[law][0],
            rolling_damping=ROLLING_B[law][1],
        )
    common = dict(density=RHO, poisson=NU, damping=0.1, friction=0.3)
    if law == "hertz":
        mat = gp.Material(young=1e11, **common, **rolling)
        words = (
            f"hertz/material {_g(mat.young)} {_g(lammps_restitution(mat.damping))} {_g(NU)} "
            f"tangential mindlin NULL {_g(T_DAMP)} {_g(mat.friction)} damping tsuji "
            f"{_rolling(law, mu_r)} limit_damping"
        )
        return mat, words
    mat = gp.Material(contact_law="linear", normal_stiffness=6.7e6, **common, **rolling)
    k_n, k_t = mat.normal_stiffness, mat.tangential_stiffness_or_default
    assert k_n is not None and k_t is not None
    m1, m2 = _mass(R1), _mass(R2)
    gamma_n = 2.0 * mat.damping * math.sqrt(m1 * m2 / (m1 + m2) * k_n)
    words = (
        f"hooke {_g(k_n)} {_g(gamma_n)} damping velocity tangential linear_history {_g(k_t)} "
        f"{_g(math.sqrt(k_t / k_n))} {_g(mat.friction)} {_rolling(law, mu_r)} limit_damping"
    )
    return mat, words


@pytest.mark.parametrize("dim", [3, 2])
@pytest.mark.parametrize(
    ("law", "tolerance"),
    [
        # d/r = 4e-5 at the deepest: the slip velocity's lever arm (module notes), mostly
        # hidden by the sliding contact
        ("hertz", 3e-7),
        ("linear", 2e-8),
    ],
)
def test_two_spheres_with_rolling_resistance_follow_lammps(lmp, tmp_path, law, tolerance, dim):
    bodies = _pair_bodies(dim)
    kw = dict(dt=1e-7, steps=3000, every=20, dim=dim)
    mat, words = _pair_case(law, MU_R_B)
    ref = lammps_trajectory(lmp, tmp_path, lammps_scene(bodies, pair=words, **kw), 2)
    got = granpack_trajectory(bodies, mat, **kw)
    assert got.shape == ref.shape
    # they met and parted: the first sphere moves at the end
    assert np.linalg.norm(ref[-1, 0, 3:6]) > 1e-3
    diff = differences(got, ref)
    assert max(diff.values()) < tolerance, diff
    # the rolling resistance changes the spins by far more than the tolerance
    _, bare_words = _pair_case(law, 0.0)
    bare = lammps_trajectory(lmp, tmp_path, lammps_scene(bodies, pair=bare_words, **kw), 2)
    assert differences(bare, ref)["w"] > 1e3 * tolerance
