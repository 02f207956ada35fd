"""The DEM engine against analytical mechanics: Hertz impacts, restitution, oblique
impacts with Coulomb friction, rolling and sliding on an incline, a settled column."""

from __future__ import annotations

import math

import numpy as np
import pytest

import granpack as gp

# Hertz: F = K d^{3/2}, K = 4/3 E* sqrt(R*). Energy balance gives
# d_max = (5 m* v^2 / (4 K))^{2/5} and the duration t_c = 2 I d_max / v with
# I = int_0^1 (1 - x^{5/2})^{-1/2} dx = (2/5) B(2/5, 1/2).
HERTZ_I = 0.4 * math.gamma(0.4) * math.gamma(0.5) / math.gamma(0.9)


def sphere_mass(r: float, rho: float = 1000.0) -> float:
    return 4.0 / 3.0 * math.pi * r**3 * rho


def hertz_prediction(mat: gp.Material, r_eff: float, m_eff: float, v: float):
    e_star = mat.young / (2 * (1 - mat.poisson**2))
    k = 4.0 / 3.0 * e_star * math.sqrt(r_eff)
    d_max = (5 * m_eff * v * v / (4 * k)) ** 0.4
    return d_max, 2 * HERTZ_I * d_max / v


def run_impact(sim: gp.Simulation, overlap, max_steps: int = 400_000, chunk: int = 1):
    """Steps until the contact opens; returns (duration, max overlap)."""
    t_in = None
    d_max = 0.0
    for _ in range(max_steps):
        sim.step(chunk)
        d = overlap(sim)
        if d > 0 and t_in is None:
            t_in = sim.time
        if d <= 0 and t_in is not None:
            return sim.time - t_in, d_max
        d_max = max(d_max, d)
    raise AssertionError("contact did not end")


@pytest.mark.parametrize("dim", [2, 3])
def test_hertz_head_on_two_spheres(dim):
    mat = gp.Material(damping=0.0, friction=0.0)
    sim = gp.Simulation(dim=dim, material=mat, dt=1e-6, gravity=[0.0] * dim, inertia_2d="sphere")
    r, v = 0.01, 1.0
    x = np.zeros((2, dim))
    x[1, 0] = 2 * r + 1e-9
    vel = np.zeros((2, dim))
    vel[0, 0], vel[1, 0] = 0.5 * v, -0.5 * v
    sim.add_particles(x, [r, r], velocities=vel)
    e0 = sim.kinetic_energy()
    m = sphere_mass(r)
    d_max, t_c = hertz_prediction(mat, r / 2, m / 2, v)

    def overlap(s):
        p = s.positions
        return 2 * r - np.linalg.norm(p[1] - p[0])

    dur, dm = run_impact(sim, overlap)
    assert dur == pytest.approx(t_c, rel=0.01)
    assert dm == pytest.approx(d_max, rel=0.01)
    assert sim.kinetic_energy() == pytest.approx(e0, rel=1e-3)


@pytest.mark.parametrize("dim", [2, 3])
def test_hertz_sphere_on_floor(dim):
    mat = gp.Material(damping=0.0, friction=0.0)
    box = ((0.0,) * dim, (1.0,) * (dim - 1) + (math.inf,))
    sim = gp.Simulation(
        dim=dim, material=mat, dt=1e-6, gravity=[0.0] * dim, box=box, inertia_2d="sphere"
    )
    r, v = 0.01, 0.7
    x = np.full((1, dim), 0.5)
    x[0, -1] = r + 1e-9
    vel = np.zeros((1, dim))
    vel[0, -1] = -v
    sim.add_particles(x, [r], velocities=vel)
    e0 = sim.kinetic_energy()
    # wall: R* = r, m* = m
    d_max, t_c = hertz_prediction(mat, r, sphere_mass(r), v)
    dur, dm = run_impact(sim, lambda s: r - s.positions[0, -1])
    assert dur == pytest.approx(t_c, rel=0.01)
    assert dm == pytest.approx(d_max, rel=0.01)
    assert sim.kinetic_energy() == pytest.approx(e0, rel=1e-3)
    assert sim.velocities[0, -1] == pytest.approx(v, rel=1e-3)


def floor_rebound(dim: int, mat: gp.Material, v: float, vt: float = 0.0, dt: float = 1e-6):
    box = ((0.0,) * dim, (1.0,) * (dim - 1) + (math.inf,))
    sim = gp.Simulation(
        dim=dim, material=mat, dt=dt, gravity=[0.0] * dim, box=box, inertia_2d="sphere"
    )
    r = 0.01
    x = np.full((1, dim), 0.5)
    x[0, -1] = r + 1e-9
    vel = np.zeros((1, dim))
    vel[0, -1] = -v
    vel[0, 0] = vt
    sim.add_particles(x, [r], velocities=vel)
    run_impact(sim, lambda s: r - s.positions[0, -1], chunk=4)
    return sim


def test_restitution_is_velocity_independent():
    """Hertz with c_n = 2 xi sqrt(m* k_n), k_n ~ d^{1/2}, restitutes a fixed fraction
    of the impact speed whatever the speed (Tsuji et al. 1992)."""
    mat = gp.Material(damping=0.1, friction=0.0)
    speeds = [0.1, 0.3, 1.0, 2.0, 5.0]
    e = [floor_rebound(3, mat, v).velocities[0, -1] / v for v in speeds]
    assert max(e) - min(e) < 0.01 * np.mean(e), e
    # damping dissipates: well below 1, well above 0
    assert 0.5 < np.mean(e) < 0.95


@pytest.mark.parametrize("dim", [2, 3])
def test_oblique_impact_in_the_sliding_regime(dim):
    """Rigid-body impulse result (e.g. Maw et al. 1976; Chung & Ooi 2011): when the
    contact slides throughout, the tangential impulse is mu times the normal impulse:
    v_t' = v_t - mu (1 + e) v_n and |w'| = mu (1 + e) v_n r m / I = 5/2 mu (1 + e) v_n / r
    (sphere inertia: the 2D run has sphere mass, inertia_2d="sphere")."""
    mu, r, vn, vt = 0.3, 0.01, 0.5, 1.5  # vt / vn = 3 > 7/2 mu (1 + e) = 2.1
    mat = gp.Material(damping=0.0, friction=mu)
    sim = floor_rebound(dim, mat, vn, vt)
    e = sim.velocities[0, -1] / vn
    assert e == pytest.approx(1.0, abs=2e-3)
    assert sim.velocities[0, 0] == pytest.approx(vt - mu * (1 + e) * vn, rel=0.01)
    w_expected = 2.5 * mu * (1 + e) * vn / r
    if dim == 3:
        w = sim.spins[0]
        # moving along +x over a floor below: spin about +y (towards rolling)
        assert w[1] == pytest.approx(w_expected, rel=0.01)
        assert abs(w[0]) < 1e-9 and abs(w[2]) < 1e-9
        assert sim.velocities[0, 1] == pytest.approx(0.0, abs=1e-12)
    else:
        # spin about +z: clockwise (negative) for motion along +x over the floor
        assert sim.spins[0] == pytest.approx(-w_expected, rel=0.01)


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("mu", [0.5, 0.05])
def test_incline_rolls_or_slides(dim, mu):
    """Gravity tilted by theta: a sphere rolls without slipping with a = 5/7 g sin(theta)
    when mu >= 2/7 tan(theta), and slides with a = g (sin(theta) - mu cos(theta)) when not."""
    theta, g, r = math.radians(20.0), 9.81, 0.01
    mat = gp.Material(damping=0.3, friction=mu)
    grav = [0.0] * dim
    grav[0] = g * math.sin(theta)
    grav[-1] = -g * math.cos(theta)
    box = ((-1.0,) + (0.0,) * (dim - 1), (10.0,) * (dim - 1) + (math.inf,))
    if dim == 3:
        box = ((-1.0, -1.0, 0.0), (10.0, 1.0, math.inf))
    sim = gp.Simulation(dim=dim, material=mat, dt=1e-5, gravity=grav, box=box, inertia_2d="sphere")
    m = sphere_mass(r)
    e_star = mat.young / (2 * (1 - mat.poisson**2))
    d0 = (m * g * math.cos(theta) / (4 / 3 * e_star * math.sqrt(r))) ** (2 / 3)
    x = np.zeros((1, dim))
    x[0, -1] = r - d0
    sim.add_particles(x, [r])
    ts, xs = [], []
    for _ in range(40):
        sim.step(500)
        ts.append(sim.time)
        xs.append(sim.positions[0, 0])
    ts, xs = np.array(ts), np.array(xs)
    a = 2 * np.polyfit(ts, xs, 2)[0]
    rolls = mu >= 2 / 7 * math.tan(theta)
    expected = (
        5 / 7 * g * math.sin(theta) if rolls else g * (math.sin(theta) - mu * math.cos(theta))
    )
    assert a == pytest.approx(expected, rel=0.01)
    v = sim.velocities[0, 0]
    w = sim.spins[0] if dim == 2 else sim.spins[0][1]
    slip = v - (-w * r if dim == 2 else w * r)
    if rolls:
        assert abs(slip) < 1e-3 * v
    else:
        assert slip > 0.1 * v


@pytest.mark.parametrize("dim", [2, 3])
def test_column_settles_and_stays(dim):
    """A column of particles dropped in a narrow box settles on the floor and then does
    not move over 10^5 steps: nothing drifts, nothing leaves the box."""
    r, n = 0.01, 12
    width = 2.3 * r
    box = ((0.0,) * dim, (width,) * (dim - 1) + (math.inf,))
    sim = gp.Simulation(dim=dim, dt=1e-4, drag=0.005, box=box, inertia_2d="sphere")
    rng = np.random.default_rng(1)
    x = np.empty((n, dim))
    x[:, :-1] = width / 2 + rng.uniform(-0.1 * r, 0.1 * r, size=(n, dim - 1))
    x[:, -1] = r + 2.2 * r * np.arange(n)
    sim.add_particles(x, np.full(n, r))
    sim.step(50_000)
    settled = sim.positions
    sim.step(100_000)
    final = sim.positions
    lo, hi = np.zeros(dim), np.array([width] * (dim - 1) + [np.inf])
    assert np.all(final - r >= lo - 0.01 * r) and np.all(final + r <= hi + 0.01 * r)
    drift = np.max(np.abs(final - settled))
    assert drift < 1e-6 * r, drift
    # stacked: every particle rests above the one below, column height ~ n diameters
    assert np.max(final[:, -1]) < 2 * r * n
    assert sim.kinetic_energy() < 1e-12


def test_rotations_off_keep_spins_zero_and_skip_torques():
    sim = gp.Simulation(dim=3, rotations=False, box=((0, 0, 0), (1, 1, math.inf)))
    sim.add_particles(
        [[0.5, 0.5, 0.0099]], [0.01], velocities=[[0.3, 0.0, 0.0]], spins=[[0.0, 5.0, 0.0]]
    )
    sim.step(500)
    assert np.all(sim.spins == 0.0)
    assert sim.velocities[0, 0] < 0.3


def test_contacts_columns_follow_the_boundary_layout():
    sim = gp.Simulation(dim=3, box=((0, 0, 0), (1, 1, math.inf)), gravity=[0, 0, -9.81])
    r = 0.01
    sim.add_particles([[0.5, 0.5, r * 0.999], [0.5, 0.5, 3 * r * 0.999]], [r, r])
    sim.step(2000)
    c = sim.contacts()
    assert c.i.dtype == np.int64 and c.normal.shape == (len(c), 3)
    pp = c.particle_pairs()
    assert len(pp) == 1 and pp.i[0] == 0 and pp.j[0] == 1
    np.testing.assert_allclose(pp.normal[0], [0, 0, 1], atol=1e-9)
    wall = c.select(c.is_wall)
    assert list(wall.j) == [-1] and wall.i[0] == 0
    np.testing.assert_allclose(wall.normal[0], [0, 0, -1])
    # statics: the floor carries both weights, the pair carries the top one
    w = sphere_mass(r) * 9.81
    assert pp.force_normal[0] == pytest.approx(w, rel=1e-3)
    assert wall.force_normal[0] == pytest.approx(2 * w, rel=1e-3)
    assert np.all(c.overlap > 0)
    np.testing.assert_allclose(np.linalg.norm(pp.branch[0]), 2 * r - pp.overlap[0], rtol=1e-12)


def test_energy_is_conserved_through_an_elastic_collision():
    """xi = 0, mu = 0: kinetic energy goes into the Hertz spring 8/15 E* sqrt(R*) d^{5/2}
    and comes back; the sum stays constant at every step of the contact."""
    mat = gp.Material(damping=0.0, friction=0.0)
    sim = gp.Simulation(dim=3, material=mat, dt=1e-6, gravity=[0.0, 0.0, 0.0])
    r = 0.01
    sim.add_particles(
        [[0, 0, 0], [2 * r + 1e-9, 0, 0]], [r, r], velocities=[[0.5, 0, 0], [-0.5, 0, 0]]
    )
    e0 = sim.kinetic_energy()
    seen_elastic = 0.0
    for _ in range(800):
        sim.step(1)
        el = sim.elastic_energy()
        seen_elastic = max(seen_elastic, el)
        assert sim.kinetic_energy() + el == pytest.approx(e0, rel=2e-3)
    assert seen_elastic > 0.9 * e0  # the spring really took (almost) all of it
