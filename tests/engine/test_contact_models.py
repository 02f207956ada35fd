"""The contact models (`Material.contact_law`, `Material.rolling`) against closed forms.

- rolling resistance ``epsd`` in its plastic regime: a sphere rolling on the floor
  decelerates at a = -M / (r (m + I / r^2)) with M = mu_r r m g, -(5/7) mu_r g for a
  sphere and -(2/3) mu_r g for a disc (the 2D disc convention); on a frictionless
  floor a spin in place brakes at M / I;
- ``epsd`` in its elastic regime: a sphere set rolling with less energy than the spring
  holds below its cap rocks about its start (amplitude v0 sqrt(7 m / (5 k_r)), period
  2 pi sqrt(7 m / (5 k_r))); with more it rolls on plastically to 2.5 x_c and then rocks
  about 1.5 x_c, x_c = mu_r m g / k_r (the engine takes no applied torque: a start with
  spin and speed loads the rolling spring instead);
- the linear law: a head-on contact lasts pi sqrt(m*/k_n) and restitutes exactly the
  speed without damping; with damping, the exit speed of the spring-dashpot that never
  pulls; a column on the floor rests with overlaps W / k_n;
- the same run is bit-identical on one and two threads with each model;
- every bad key of `Material` and a linear stiffness too stiff for dt are refused by
  name.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scenes import outputs_on_threads

import granpack as gp

G = 9.81  # m/s^2


def sphere_mass(r: float, rho: float = 1000.0) -> float:
    return 4.0 / 3.0 * math.pi * r**3 * rho


def floor_sim(dim: int, mat: gp.Material, dt: float, inertia_2d: str = "sphere"):
    gravity = [0.0] * dim
    gravity[-1] = -G
    box = ((-1.0,) * (dim - 1) + (0.0,), (1.0,) * (dim - 1) + (math.inf,))
    return gp.Simulation(
        dim=dim, material=mat, dt=dt, gravity=gravity, box=box, inertia_2d=inertia_2d
    )


def start_rolling(sim: gp.Simulation, dim: int, r: float, height: float, v0: float) -> None:
    """One particle at `height` above the floor, rolling along +x at v0 without slip."""
    x = np.zeros((1, dim))
    x[0, -1] = height
    v = np.zeros((1, dim))
    v[0, 0] = v0
    # the contact point below the centre stays: v + w x (-r e_vertical) = 0
    spins = np.array([-v0 / r]) if dim == 2 else np.array([[0.0, v0 / r, 0.0]])
    sim.add_particles(x, [r], velocities=v, spins=spins)


# -- rolling resistance, plastic --------------------------------------------------------


@pytest.mark.parametrize(
    ("dim", "inertia_2d", "factor"),
    [(3, "sphere", 5.0 / 7.0), (2, "sphere", 5.0 / 7.0), (2, "disc", 2.0 / 3.0)],
)
def test_rolling_resistance_decelerates_a_rolling_sphere_at_its_closed_form(
    dim, inertia_2d, factor
):
    """M = mu_r R* F_n with R* = r on a wall and F_n = m g: a = -M / (r (m + I / r^2)),
    -(5/7) mu_r g for a sphere (I = 2/5 m r^2), -(2/3) mu_r g for a disc (I = m r^2 / 2).
    The default rolling stiffness 2.25 mu_r^2 k_n puts the cap within a fraction of the
    overlap, so the whole run but its first steps is plastic. The modulus is high so that
    the overlap is small: the slip velocity's lever arm r - d/2 shifts a by about d / 6r
    for a disc."""
    mu_r, r, v0 = 0.1, 0.005, 0.1
    mat = gp.Material(young=1e9, damping=0.5, friction=0.5, rolling="epsd", rolling_friction=mu_r)
    sim = floor_sim(dim, mat, 1e-5, inertia_2d)
    start_rolling(sim, dim, r, r, v0)
    a_expected = -factor * mu_r * G
    t_stop = v0 / -a_expected
    ts, vs, xs = [], [], []
    for _ in range(100):
        sim.step(int(round(0.016 * t_stop / 1e-5)))
        ts.append(sim.time)
        vs.append(sim.velocities[0, 0])
        xs.append(sim.positions[0, 0])
    ts, vs, xs = np.array(ts), np.array(vs), np.array(xs)
    # the plastic stretch: after the start's vertical settling, before the stop
    window = (ts > 0.2 * t_stop) & (ts < 0.8 * t_stop)
    a = np.polyfit(ts[window], vs[window], 1)[0]
    assert a == pytest.approx(a_expected, rel=1e-3)
    # it stopped where the closed form says and does not roll on: the last third of the
    # run (0.5 t_stop) only rocks in the elastic regime
    stop = v0 * v0 / (2 * -a_expected)
    assert xs[-1] == pytest.approx(stop, rel=5e-3)
    assert np.ptp(xs[-30:]) < 5e-3 * stop


@pytest.mark.parametrize(("dim", "inertia_2d", "shape"), [(3, "sphere", 0.4), (2, "disc", 0.5)])
def test_rolling_resistance_brakes_a_spin_on_a_frictionless_floor(dim, inertia_2d, shape):
    """Without friction no tangential force acts, but the rolling resistance still does:
    a particle spinning in place on the floor loses spin at M / I = mu_r r m g / (k m r^2)
    = mu_r g / (k r) (k = 2/5 for a sphere, 1/2 for a disc), and does not move."""
    mu_r, r, w0 = 0.1, 0.005, 20.0
    mat = gp.Material(young=1e9, damping=0.5, friction=0.0, rolling="epsd", rolling_friction=mu_r)
    sim = floor_sim(dim, mat, 1e-5, inertia_2d)
    x = np.zeros((1, dim))
    x[0, -1] = r
    spins = np.array([w0]) if dim == 2 else np.array([[0.0, w0, 0.0]])
    sim.add_particles(x, [r], spins=spins)
    rate = mu_r * G / (shape * r)
    t_stop = w0 / rate
    ts, ws = [], []
    for _ in range(100):
        sim.step(int(round(0.016 * t_stop / 1e-5)))
        ts.append(sim.time)
        ws.append(sim.spins[0] if dim == 2 else sim.spins[0, 1])
    ts, ws = np.array(ts), np.array(ws)
    # after the start's vertical settling, before the stop
    window = (ts > 0.2 * t_stop) & (ts < 0.8 * t_stop)
    assert np.polyfit(ts[window], ws[window], 1)[0] == pytest.approx(-rate, rel=1e-3)
    # stopped: over the last third of the run (0.5 t_stop) the spin only swings about
    # zero on the rolling spring, undamped (gamma_r = 0)
    assert np.abs(ws[-30:]).max() < 0.1 * w0
    assert ws[-30:].min() < 0.0 < ws[-30:].max()
    assert np.abs(sim.positions[0, :-1]).max() == 0.0


# -- rolling resistance, elastic --------------------------------------------------------


def _rocking(f: float):
    """A sphere resting on the floor set rolling at f times the critical speed v_c at
    which the rolling spring reaches its cap: (trajectory x(t), v_x(t), t, amplitude
    v0 sqrt(7 m / (5 k_r)), x_c = mu_r m g / k_r, period)."""
    r, mu_r, dt = 0.005, 0.02, 1e-5
    base = gp.Material()
    m = sphere_mass(r)
    e_star = base.e_star
    d0 = (m * G / (4.0 / 3.0 * e_star * math.sqrt(r))) ** (2.0 / 3.0)
    # the default's 2.25 mu_r^2 k_n at rest, held fixed: a soft spring (k_r / k_t = 1e-3,
    # so that the tangential spring in series changes the period by less than 1e-3)
    k_r = 2.25 * mu_r**2 * 2.0 * e_star * math.sqrt(r * d0)
    mat = gp.Material(friction=0.5, rolling="epsd", rolling_friction=mu_r, rolling_stiffness=k_r)
    inertia = 1.4 * m  # m + I / r^2
    period = 2.0 * math.pi * math.sqrt(inertia / k_r)
    x_c = mu_r * m * G / k_r
    v_c = math.sqrt(k_r / inertia) * x_c
    v0 = f * v_c
    sim = floor_sim(3, mat, dt)
    start_rolling(sim, 3, r, r - d0, v0)
    xs, vs = [], []
    for _ in range(int(2.2 * period / dt)):
        sim.step(1)
        xs.append(sim.positions[0, 0])
        vs.append(sim.velocities[0, 0])
    t = dt * np.arange(1, len(xs) + 1)
    return np.array(xs), np.array(vs), t, v0 * math.sqrt(inertia / k_r), x_c, period


def test_rolling_below_the_cap_rocks_elastically_about_the_start():
    x, v, t, amplitude, x_c, period = _rocking(0.5)
    assert amplitude < x_c
    assert x.max() == pytest.approx(amplitude, rel=3e-3)
    # v_x falling through zero: one period apart
    k = np.flatnonzero((v[:-1] > 0) & (v[1:] <= 0))
    crossings = t[k] + (t[1] - t[0]) * v[k] / (v[k] - v[k + 1])
    assert len(crossings) == 2
    assert crossings[1] - crossings[0] == pytest.approx(period, rel=2e-3)
    # the spring brings it back: no permanent rolling
    last = x[-int(period / (t[1] - t[0])) :]
    assert abs(last.mean()) < 5e-3 * amplitude


def test_rolling_above_the_cap_rolls_on_plastically():
    """Energy: 1/2 (7/5 m) v0^2 = 1/2 k_r x_c^2 + mu_r m g (x_max - x_c); at twice the
    critical speed x_max = 2.5 x_c, and the spring unloads by x_c: it rocks about
    1.5 x_c."""
    x, _, t, _, x_c, period = _rocking(2.0)
    assert x.max() == pytest.approx(2.5 * x_c, rel=3e-3)
    last = x[-int(period / (t[1] - t[0])) :]
    assert last.mean() == pytest.approx(1.5 * x_c, rel=5e-3)


# -- the linear law ---------------------------------------------------------------------


def linear_collision(xi: float, steps_per_contact: int) -> tuple[float, float, float, float]:
    """Two spheres meeting head-on under the linear law: (restitution, contact duration
    from the overlap's zero crossings (s), m* (kg), k_n (N/m))."""
    k_n, r1, r2, v = 1e4, 0.01, 0.007, 0.1
    m1, m2 = sphere_mass(r1), sphere_mass(r2)
    m_eff = m1 * m2 / (m1 + m2)
    dt = math.pi * math.sqrt(m_eff / k_n) / steps_per_contact
    mat = gp.Material(damping=xi, friction=0.3, contact_law="linear", normal_stiffness=k_n)
    sim = gp.Simulation(dim=3, material=mat, dt=dt, gravity=[0.0, 0.0, 0.0])
    sim.add_particles(
        [[0.0, 0.0, 0.0], [r1 + r2 + 0.3 * v * dt, 0.0, 0.0]],
        [r1, r2],
        velocities=[[0.0, 0.0, 0.0], [-v, 0.0, 0.0]],
    )

    def gap() -> float:
        p = sim.positions
        return float(p[1, 0] - p[0, 0] - r1 - r2)

    t_in = t_out = None
    before = gap()
    for _ in range(10 * steps_per_contact):
        sim.step(1)
        now = gap()
        # linear interpolation between the steps: the gap moves linearly outside contact
        if t_in is None and now < 0.0:
            t_in = sim.time - dt * now / (now - before)
        elif t_in is not None and now > 0.0:
            t_out = sim.time - dt * now / (now - before)
            break
        before = now
    assert t_in is not None and t_out is not None, "the contact did not open and close"
    sim.step(10)
    vel = sim.velocities
    return float((vel[1, 0] - vel[0, 0]) / v), t_out - t_in, m_eff, k_n


def test_linear_contact_lasts_half_a_period_and_restitutes_all_without_damping():
    e, duration, m_eff, k_n = linear_collision(0.0, 1000)
    assert duration == pytest.approx(math.pi * math.sqrt(m_eff / k_n), rel=2e-6)
    assert e == pytest.approx(1.0, abs=1e-7)


@pytest.mark.parametrize("xi", [0.05, 0.3])
def test_linear_contact_restitutes_the_damped_spring_that_never_pulls(xi):
    """m* d'' = -k_n d - c_n d' with c_n = 2 xi sqrt(m* k_n): beta = xi w0, w = w0 sqrt(1 -
    xi^2). The textbook e = exp(-pi xi / sqrt(1 - xi^2)) is the speed where the overlap
    closes, the dashpot pulling at the end; the force never pulls (f_n >= 0, as LAMMPS'
    limit_damping), so the bodies part where the force vanishes, d'' = 0, at w t* = pi -
    atan(2 beta w / (w^2 - beta^2)), with e = exp(-beta t*) (Schwager and Poeschel 2007)."""
    e, _, m_eff, k_n = linear_collision(xi, 4000)
    w0 = math.sqrt(k_n / m_eff)
    beta = xi * w0
    w = w0 * math.sqrt(1.0 - xi * xi)
    t_star = (math.pi - math.atan(2.0 * beta * w / (w * w - beta * beta))) / w
    expected = math.exp(-beta * t_star)
    assert e == pytest.approx(expected, rel=5e-4)
    # the clamp matters: the textbook value is further off than the tolerance
    textbook = math.exp(-math.pi * xi / math.sqrt(1.0 - xi * xi))
    assert e > textbook * (1.0 + 4e-3)


@pytest.mark.parametrize("dim", [2, 3])
def test_linear_column_rests_with_overlaps_of_the_weight_over_k_n(dim):
    """A column of n equal particles on the floor: the contact below particle k carries
    the weight of the n - k particles from k up, so its overlap is (n - k) m g / k_n and
    its spring holds 1/2 k_n d^2."""
    n, r, k_n = 5, 0.005, 1e4
    mat = gp.Material(damping=0.7, friction=0.3, contact_law="linear", normal_stiffness=k_n)
    m = sphere_mass(r)
    dt = 0.05 * math.sqrt(m / k_n)
    sim = gp.Simulation(
        dim=dim,
        material=mat,
        dt=dt,
        gravity=[0.0] * (dim - 1) + [-G],
        drag=2.0 * math.sqrt(m * k_n) * 0.05,
        box=((-0.1,) * (dim - 1) + (0.0,), (0.1,) * (dim - 1) + (math.inf,)),
        inertia_2d="sphere",
    )
    x = np.zeros((n, dim))
    x[:, -1] = r + 2.0 * r * np.arange(n)
    sim.add_particles(x, np.full(n, r))
    sim.step(int(round(0.3 / dt)))
    z = sim.positions[:, -1]
    overlaps = np.concatenate([[r - z[0]], 2.0 * r - np.diff(z)])
    expected = (n - np.arange(n)) * m * G / k_n
    np.testing.assert_allclose(overlaps, expected, rtol=1e-9)
    # the springs hold 1/2 k_n d^2 each
    assert sim.elastic_energy() == pytest.approx(0.5 * k_n * (expected**2).sum(), rel=1e-8)
    # the column stayed a column: no force across it
    np.testing.assert_array_equal(sim.positions[:, :-1], 0.0)


# -- determinism ------------------------------------------------------------------------

THREADS_SCRIPT = """
import sys, hashlib, numpy as np, granpack as gp
model = sys.argv[1]
keys = (
    dict(rolling="epsd", rolling_friction=0.1)
    if model == "rolling"
    else dict(contact_law="linear", normal_stiffness=1e5)
)
scene = gp.PackScene(dim=3, base=(0.3, 0.3), height=0.15, r_mean=0.02, phi_layer=0.25,
                     seed=3, material=gp.Material(**keys))
p = gp.generate(scene, progress=False)
h = hashlib.sha256()
for a in (p.positions, p.velocities, p.spins, p.radii):
    h.update(np.ascontiguousarray(a).tobytes())
print(len(p), h.hexdigest())
"""


@pytest.mark.parametrize("model", ["rolling", "linear"])
def test_a_deposit_with_each_model_is_bit_identical_on_one_and_two_threads(model):
    out = outputs_on_threads(THREADS_SCRIPT, model)
    assert int(out["1"][0]) > 100
    assert out["1"] == out["2"]


def test_each_model_changes_the_deposit():
    """The keys reach the engine: a deposit with rolling resistance, or with the linear
    law, is not the default one."""
    base = gp.PackScene(
        dim=2, base=(0.2,), height=0.06, r_mean=0.01, phi_layer=0.3, settle_time=0.2, seed=4
    )
    ref = gp.generate(base, progress=False).positions
    for keys in (
        dict(rolling="epsd", rolling_friction=0.2),
        dict(contact_law="linear", normal_stiffness=2e4),
    ):
        got = gp.generate(base.replace(material=gp.Material(**keys)), progress=False)
        assert got.positions.shape != ref.shape or np.abs(got.positions - ref).max() > 1e-6


# -- bad input --------------------------------------------------------------------------

BAD = float("nan"), float("inf"), -float("inf")
LINEAR = dict(contact_law="linear", normal_stiffness=1e5)
EPSD = dict(rolling="epsd", rolling_friction=0.1)


@pytest.mark.parametrize(
    ("keys", "parameter"),
    [
        (dict(contact_law="hooke"), "contact_law"),
        (dict(contact_law=None), "contact_law"),
        (dict(rolling="sds"), "rolling"),
        (dict(rolling=1), "rolling"),
        (dict(contact_law="linear"), "normal_stiffness"),
        (dict(rolling="epsd"), "rolling_friction"),
        # only the linear law takes stiffnesses
        (dict(normal_stiffness=1e5), "normal_stiffness"),
        (dict(tangential_stiffness=1e5), "tangential_stiffness"),
        # only a rolling model takes its keys
        (dict(rolling_friction=0.1), "rolling_friction"),
        (dict(rolling_stiffness=10.0), "rolling_stiffness"),
        (dict(rolling_damping=0.0), "rolling_damping"),
        *[({**LINEAR, "normal_stiffness": v}, "normal_stiffness") for v in (0.0, -1.0, *BAD)],
        *[
            ({**LINEAR, "tangential_stiffness": v}, "tangential_stiffness")
            for v in (0.0, -1.0, *BAD)
        ],
        *[({**EPSD, "rolling_friction": v}, "rolling_friction") for v in (-0.1, *BAD)],
        *[({**EPSD, "rolling_stiffness": v}, "rolling_stiffness") for v in (0.0, -1.0, *BAD)],
        *[({**EPSD, "rolling_damping": v}, "rolling_damping") for v in (-1.0, *BAD)],
        ({**EPSD, "rolling_friction": "0.1"}, "rolling_friction"),
        ({**LINEAR, "normal_stiffness": True}, "normal_stiffness"),
    ],
)
def test_a_bad_model_key_is_refused_by_name(keys, parameter):
    with pytest.raises(gp.InvalidParameterError) as e:
        gp.Material(**keys)
    assert e.value.parameter == parameter
    assert parameter in str(e.value)


def test_the_model_keys_at_their_edges_are_accepted():
    gp.Material(**EPSD, rolling_damping=0.0)
    gp.Material(rolling="epsd", rolling_friction=0.0)
    gp.Material(**LINEAR, tangential_stiffness=1.0)


def test_a_linear_stiffness_too_stiff_for_dt_is_refused():
    """The linear law's critical step is sqrt(m_min / k_n), m_min the smallest mass: a dt
    above it is refused on the first step, naming dt and the estimate (here a dt that
    the larger particle alone would allow); just below it runs."""
    r, k_n = 0.01, 1e9
    critical = math.sqrt(sphere_mass(0.5 * r) / k_n)
    assert 1.5 * critical < math.sqrt(sphere_mass(r) / k_n)
    # far below the Rayleigh step of the default modulus: the linear bound decides
    assert critical < 0.1 * gp.Material().critical_time_step(0.5 * r)
    mat = gp.Material(contact_law="linear", normal_stiffness=k_n)

    def two(dt: float) -> gp.Simulation:
        sim = gp.Simulation(dim=3, material=mat, dt=dt, gravity=[0.0, 0.0, 0.0])
        sim.add_particles([[0.0, 0.0, 0.0], [0.05, 0.0, 0.0]], [r, 0.5 * r])
        return sim

    sim = two(1.5 * critical)
    with pytest.raises(gp.UnstableTimeStepError) as e:
        sim.step(1)
    assert e.value.parameter == "dt"
    assert e.value.critical == pytest.approx(critical, rel=1e-9)
    ok = two(0.9 * critical)
    ok.step(10)
    assert ok.steps == 10
