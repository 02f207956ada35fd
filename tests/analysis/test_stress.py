"""Stress tests of the DEM engine: random valid scenes never produce NaN,
never lose a particle through a wall and never gain energy beyond what the contacts can
store; elastic collisions conserve energy to a derived bound; a settled pack stays
still over 10^6 steps; a dt sweep up to and past the Rayleigh estimate shows where the
scheme becomes unstable and that the guards stop it.

Scenes are small (12-16 particles) so that hypothesis can afford tens of them; runs are
derandomized (the same examples on every run) and keep no example database.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import granpack as gp

STRESS = settings(
    max_examples=80,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.too_slow],
)

R_MIN = 0.01
#: Impacts are kept gentle: the fastest possible impact compresses a contact by at most
#: this fraction of the radius (Hertz), so the guards firing would mean a numerical
#: failure, not a physically violent scene.
DROP_OVERLAP = 0.05


def moduli(mat: gp.Material) -> tuple[float, float]:
    """E* and G* of the contact law (walls are of the same material)."""
    e_star = mat.young / (2 * (1 - mat.poisson**2))
    g_star = mat.young / (2 * (1 + mat.poisson)) / (2 * (2 - mat.poisson))
    return e_star, g_star


def impact_speed_limit(mat: gp.Material) -> float:
    """Impact speed at which a Hertz contact reaches DROP_OVERLAP r. Energy balance
    m v^2/2 = 8/15 E* sqrt(R) d^{5/2} with m = 4/3 pi r^3 rho, R = r gives
    (d/r)^{5/2} = 5 pi/4 rho v^2 / E*, the same for every radius."""
    e_star, _ = moduli(mat)
    return math.sqrt(DROP_OVERLAP**2.5 * e_star / (1.25 * math.pi * mat.density))


def random_scene(dim, ratio, mu, xi, young, frac, seed, rotations=True, n=12):
    """n particles with radii in [R_MIN, ratio R_MIN], placed without overlap in a box
    of a few diameters, with random velocities, falling under gravity: impacts reach at
    most DROP_OVERLAP of the radius. dt = frac x the Rayleigh estimate of R_MIN.
    Returns the simulation, the box width, gravity, the impact-speed limit and enough
    steps to fall through the slab about three times."""
    rng = np.random.default_rng(seed)
    mat = gp.Material(young=young, friction=mu, damping=xi)
    r = np.sort(rng.uniform(R_MIN, ratio * R_MIN, n))[::-1].copy()
    r[-1] = R_MIN
    width = (6 if dim == 2 else 4) * ratio * R_MIN
    vol = np.sum(np.pi * r**2) if dim == 2 else np.sum(4 / 3 * np.pi * r**3)
    h = max(vol / (0.15 * width ** (dim - 1)), 4 * ratio * R_MIN)
    x = np.empty((n, dim))
    for k in range(n):
        for _ in range(100_000):
            p = rng.uniform(r[k], width - r[k], dim)
            p[-1] = rng.uniform(r[k], h)
            if np.all(np.linalg.norm(x[:k] - p, axis=1) > r[:k] + r[k]):
                break
        x[k] = p
    v_lim = min(1.0, impact_speed_limit(mat))
    v0 = 0.3 * v_lim
    g = min(9.81, (v_lim**2 - v0**2) / (2 * h))  # a drop through h stays below v_lim
    vel = rng.uniform(-1, 1, (n, dim)) * v0 / math.sqrt(dim)
    gravity = [0.0] * dim
    gravity[-1] = -g
    box = ((0.0,) * dim, (width,) * (dim - 1) + (math.inf,))
    dt = frac * mat.critical_time_step(R_MIN)
    sim = gp.Simulation(
        dim=dim,
        material=mat,
        dt=dt,
        gravity=gravity,
        box=box,
        rotations=rotations,
        inertia_2d="sphere",
    )
    sim.add_particles(x, r, velocities=vel)
    n_steps = min(20_000, int(3 * math.sqrt(2 * h / g) / dt))
    return sim, width, g, v_lim, n_steps


def storable_elastic_energy(sim: gp.Simulation, g: float, v_lim: float) -> float:
    """An upper bound on the elastic energy the scene's contacts can hold, the tolerance
    of the energy check.

    Exactly, E_kin + E_pot + U = E_kin(0) + E_pot(0) + U(0) - D with D >= 0 (dashpots,
    Coulomb sliding, drag dissipate) and U >= 0 the elastic energy in the contacts; U(0)
    = 0 here (no initial overlap), so E_kin + E_pot <= its initial value. What the
    discrete scheme and the contact model add (the velocity-Verlet energy error, which
    is a fraction (w dt)^2/4 < 1 of the energy in a contact; contacts opening and closing
    between steps; the Mindlin spring stiffening with the overlap) all passes through
    energy stored in the contacts. A contact of effective radius R* = R_MIN/2 (the
    softest) carrying force F stores 2/5 F d(F) in its normal spring and at most
    (mu F)^2 / (2 k_t) in its tangential one, d(F) = (F / (4/3 E* sqrt(R*)))^{2/3},
    k_t = 8 G* sqrt(R* d). F is at most the weight W of all particles (statics) or the
    force of the fastest impact, which compresses the contact by at most
    d = R* (5 pi/4 rho v_lim^2 / E*)^{2/5}. The scene has at most N(N-1)/2 pair and
    N(2D-1) wall contacts."""
    mat, dim, n = sim.material, sim.dim, len(sim)
    e_star, g_star = moduli(mat)
    r_eff = R_MIN / 2
    stiffness = 4 / 3 * e_star * math.sqrt(r_eff)
    weight = float(np.sum(sim.masses)) * g
    d = max(
        (weight / stiffness) ** (2 / 3),
        r_eff * (1.25 * math.pi * mat.density * v_lim**2 / e_star) ** 0.4,
    )
    force = stiffness * d**1.5
    k_t = 8 * g_star * math.sqrt(r_eff * d)
    per_contact = 0.4 * force * d + (mat.friction * force) ** 2 / (2 * k_t)
    return (n * (n - 1) / 2 + n * (2 * dim - 1)) * per_contact


def check_sound(sim: gp.Simulation, width: float, e0: float, tol: float) -> None:
    """Finite state, every particle inside the box, energy within the bound."""
    x, v, w = sim.positions, sim.velocities, sim.spins
    assert np.all(np.isfinite(x)) and np.all(np.isfinite(v)) and np.all(np.isfinite(w))
    r = sim.radii[:, None]
    # centres inside the walls and no wall overlap beyond the guard's limit
    assert np.all(x - 0.5 * r >= 0.0), "a particle went through the floor or a side wall"
    assert np.all(x[:, :-1] + 0.5 * r <= width), "a particle went through a side wall"
    e = sim.kinetic_energy() + sim.potential_energy()
    assert e <= e0 + tol + 1e-12 * abs(e0), (e - e0, tol)


@STRESS
@given(
    dim=st.sampled_from([2, 3]),
    ratio=st.floats(1.0, 4.0),
    mu=st.floats(0.0, 1.0),
    xi=st.floats(0.0, 0.9),
    log_young=st.floats(6.0, 10.0),
    frac=st.floats(0.05, 0.3),
    rotations=st.booleans(),
    seed=st.integers(0, 2**32 - 1),
)
def test_random_valid_scenes_stay_sound(dim, ratio, mu, xi, log_young, frac, rotations, seed):
    """Random valid scenes (radii spread up to 1:4, friction 0-1, damping 0-0.9,
    E 1e6-1e10, dt a fraction 0.05-0.3 of the Rayleigh estimate): no NaN, no particle
    through a wall, E_kin + E_pot never above its start by more than the elastic energy
    the contacts can store. dt above 0.3 of the estimate is unstable for high damping
    (test_dt_sweep_up_to_and_past_the_estimate)."""
    sim, width, g, v_lim, n_steps = random_scene(
        dim, ratio, mu, xi, 10**log_young, frac, seed, rotations
    )
    e0 = sim.kinetic_energy() + sim.potential_energy()
    tol = storable_elastic_energy(sim, g, v_lim)
    check_sound(sim, width, e0, tol)
    while sim.steps < n_steps:
        sim.step(min(50, n_steps - sim.steps))  # no guard may fire on a sound scene
        check_sound(sim, width, e0, tol)


@settings(STRESS, max_examples=40)
@given(
    dim=st.sampled_from([2, 3]),
    log_young=st.floats(6.0, 10.0),
    ratio=st.floats(1.0, 4.0),
    frac=st.floats(0.02, 0.5),
    offset=st.floats(0.0, 0.5),
    wall=st.booleans(),
)
def test_elastic_collision_conserves_energy(dim, log_young, ratio, frac, offset, wall):
    """damping = 0, friction = 0: over a collision (a pair, or a particle and the floor
    under gravity) E_kin + E_pot + U stays within eps of its start, and E_kin + E_pot
    returns to it once the contact opens (the elastic energy comes back).

    eps is derived, not tuned: velocity Verlet conserves a modified energy that differs
    from the true one by (w dt)^2/4 of the elastic energy (exact for a linear spring;
    w^2 = k_n(d_max)/m*, k_n = 2 E* sqrt(R* d)), and a contact that opens or closes
    between two steps adds at most the elastic energy of one step's travel,
    8/15 E* sqrt(R*) (v dt)^{5/2}, twice per collision."""
    mat = gp.Material(young=10**log_young, damping=0.0, friction=0.0)
    e_star, _ = moduli(mat)
    v = min(1.0, impact_speed_limit(mat))
    dt = frac * mat.critical_time_step(R_MIN)
    r2 = ratio * R_MIN
    if wall:
        box = ((0.0,) * dim, (1.0,) * (dim - 1) + (math.inf,))
        grav = [0.0] * dim
        grav[-1] = -9.81
        sim = gp.Simulation(dim=dim, material=mat, dt=dt, gravity=grav, box=box)
        x = np.full((1, dim), 0.5)
        x[0, -1] = R_MIN + 2.5 * v * dt
        vel = np.zeros((1, dim))
        vel[0, -1], vel[0, 0] = -v, offset * v
        sim.add_particles(x, [R_MIN], velocities=vel)
        m_eff, r_eff = sim.masses[0], R_MIN
        v_n = math.sqrt(v * v + 2 * 9.81 * 2.5 * v * dt)

        def gap(s):
            return s.positions[0, -1] - R_MIN
    else:
        sim = gp.Simulation(dim=dim, material=mat, dt=dt, gravity=[0.0] * dim)
        x = np.zeros((2, dim))
        dist = R_MIN + r2 + 2.5 * v * dt
        x[1, 1] = offset * R_MIN
        x[1, 0] = math.sqrt(dist**2 - x[1, 1] ** 2)
        vel = np.zeros((2, dim))
        vel[0, 0] = v
        sim.add_particles(x, [R_MIN, r2], velocities=vel)
        m = sim.masses
        m_eff, r_eff = m[0] * m[1] / (m[0] + m[1]), R_MIN * r2 / (R_MIN + r2)
        v_n = v

        def gap(s):
            p = s.positions
            return np.linalg.norm(p[1] - p[0]) - R_MIN - r2

    k_hertz = 4 / 3 * e_star * math.sqrt(r_eff)
    u_max = 0.5 * m_eff * v_n**2
    d_max = (5 * m_eff * v_n**2 / (4 * k_hertz)) ** 0.4
    w2 = 2 * e_star * math.sqrt(r_eff * d_max) / m_eff
    eps = w2 * dt * dt / 4 * u_max + 2 * 8 / 15 * e_star * math.sqrt(r_eff) * (v_n * dt) ** 2.5

    def total():
        return sim.kinetic_energy() + sim.potential_energy() + sim.elastic_energy()

    e0 = total()
    touched = False
    for _ in range(100_000):
        sim.step(1)
        assert abs(total() - e0) <= eps, (total() - e0, eps)
        touched |= gap(sim) < 0
        if touched and gap(sim) > 0:
            break
    assert touched and gap(sim) > 0, "the collision did not end"
    assert sim.elastic_energy() == 0.0
    assert abs(sim.kinetic_energy() + sim.potential_energy() - e0) <= eps


def sweep_outcome(sim: gp.Simulation, width: float, n_steps: int) -> str:
    """'stable', or the guard that stopped the run; never NaN or a lost particle."""
    try:
        sim.step(n_steps)
    except gp.GranpackError as exc:
        msg = str(exc)
        assert msg.startswith("simulation became unstable at step ") and "particle" in msg, msg
        for what in ("energy", "overlap", "speed", "non-finite", "wall"):
            if what in msg:
                return what
        raise AssertionError(msg) from None
    x = sim.positions
    assert np.all(np.isfinite(x)) and np.all(np.isfinite(sim.velocities))
    assert np.all(x >= 0) and np.all(x[:, :-1] <= width)
    return "stable"


FRACTIONS = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0]


@pytest.mark.parametrize(
    ("dim", "xi", "expect_unstable"),
    [(2, 0.85, True), (3, 0.85, True), (2, 0.1, False), (3, 0.1, False)],
)
def test_dt_sweep_up_to_and_past_the_estimate(dim, xi, expect_unstable):
    """dt from 0.1 to 1.0 of the Rayleigh estimate on one scene (radii 1:3, friction
    0.5): with the paper's damping (0.1) it stays stable up to the estimate; with
    damping 0.85 the dashpot makes the explicit scheme unstable well below it (the
    damped oscillator's limit w dt < 2 (sqrt(1 + xi^2) - xi) = 0.9 instead of 2) and a
    guard stops the run, naming the step and particle. Past the estimate the engine
    refuses dt on the first step, quoting the estimate."""
    outcome = {}
    for frac in FRACTIONS:
        sim, width, _, _, n_steps = random_scene(dim, 3.0, 0.5, xi, 1e7, frac, seed=dim, n=16)
        outcome[frac] = sweep_outcome(sim, width, n_steps)
    print(f"dim {dim} damping {xi}:", outcome)
    assert all(outcome[f] == "stable" for f in FRACTIONS if f <= 0.3), outcome
    unstable = [f for f in FRACTIONS if outcome[f] != "stable"]
    if expect_unstable:
        assert unstable and min(unstable) > 0.3, outcome
    else:
        assert not unstable, outcome
    # past the estimate: refused before any step, with the estimate in the message
    for frac in (1.0 + 1e-9, 1.5, 3.0, 100.0):
        sim, *_ = random_scene(dim, 3.0, 0.5, xi, 1e7, 1.0, seed=dim, n=4)
        crit = sim.critical_time_step()
        bad = gp.Simulation(dim=dim, material=sim.material, dt=frac * crit)
        bad.add_particles(sim.positions, sim.radii)
        with pytest.raises(gp.GranpackError, match=r"critical \(Rayleigh\) time step") as err:
            bad.step(1)
        quoted = re.search(r"time step ([-+.e0-9]+) s", str(err.value)).group(1)
        assert float(quoted) == pytest.approx(crit, rel=1e-12) and bad.steps == 0


@pytest.mark.slow
@pytest.mark.parametrize("dim", [2, 3])
def test_settled_pack_stays_still_for_a_million_steps(dim):
    """A small frictional pile (8 particles, radii 1:1.5, the paper's damping and drag,
    rotations on), settled until its motion has died out, then 10^6 more steps: no
    particle creeps or drifts by more than 1e-6 of the smallest radius."""
    rng = np.random.default_rng(dim)
    n = 8
    r = rng.uniform(R_MIN, 1.5 * R_MIN, n)
    width = (5.0 if dim == 2 else 3.2) * 1.5 * R_MIN
    x = np.empty((n, dim))
    x[:, :-1] = rng.uniform(r[:, None], width - r[:, None], (n, dim - 1))
    x[:, -1] = np.cumsum(2 * r + 1e-3) - r
    mat = gp.Material(friction=0.5)
    gravity = [0.0] * dim
    gravity[-1] = -9.81
    sim = gp.Simulation(
        dim=dim,
        material=mat,
        dt=0.3 * mat.critical_time_step(r.min()),
        gravity=gravity,
        drag=0.005,
        box=((0.0,) * dim, (width,) * (dim - 1) + (math.inf,)),
    )
    sim.add_particles(x, r)
    # settle: until 10^5 steps move nothing by more than 1e-9 r (exponential decay)
    prev = sim.positions
    for _ in range(60):
        sim.step(100_000)
        moved = np.max(np.abs(sim.positions - prev))
        prev = sim.positions
        if moved < 1e-9 * R_MIN:
            break
    assert moved < 1e-9 * R_MIN, f"did not settle: {moved / R_MIN:.2e} r per 1e5 steps"
    settled = sim.positions
    sim.step(1_000_000)
    drift = np.max(np.abs(sim.positions - settled))
    assert drift < 1e-6 * R_MIN, f"drift {drift / R_MIN:.2e} r over 1e6 steps"
    assert np.all(np.isfinite(sim.velocities))


@pytest.mark.parametrize("dim", [2, 3])
def test_energy_guard_ignores_the_dashpot_share_of_a_sliding_stretch(dim):
    """A sphere hits the floor obliquely (v = (1, -1) m/s, no gravity, damping 0.9,
    friction 0.2, dt = 0.3 of the estimate) during step 1024, when the energy guard
    runs. A sliding contact stores the stretch -(f_t + c_t v_t)/k_t, dashpot included;
    counted as spring energy it once made E_kin + U reach 1.8 E_kin(0) and stopped this
    sound run. The spring energy is now capped at (mu f_n)^2 / (2 k_t)."""
    mat = gp.Material(damping=0.9, friction=0.2)
    dt = 0.3 * mat.critical_time_step(R_MIN)
    box = ((0.0,) * dim, (1.0,) * (dim - 1) + (math.inf,))
    sim = gp.Simulation(dim=dim, material=mat, dt=dt, gravity=[0.0] * dim, box=box)
    x = np.full((1, dim), 0.5)
    x[0, -1] = R_MIN + 1.0 * dt * 1021.5  # first contact two steps before step 1024
    v = np.zeros((1, dim))
    v[0, 0], v[0, -1] = 1.0, -1.0
    sim.add_particles(x, [R_MIN], velocities=v)
    k0 = sim.kinetic_energy()
    sim.step(1050)  # the energy guard runs at step 1024, mid-contact, and must not fire
    assert sim.kinetic_energy() < k0
