"""The stress of a pack, its force networks and its coordination distribution: static
equilibrium of settled packs in every container, covariance under rotations, the strong and
weak fabrics adding up to the whole, P(Z) against a brute-force count, and the stress of a
pack from another DEM code against its weight."""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import granpack as gp
from granpack.analysis import MicrostructureWarning, read_xyzr
from granpack.analysis.stress import contact_forces, love_weber

PEERS = Path(__file__).resolve().parents[2].parent / "shared" / "peers"
PROPS = settings(
    max_examples=40,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.too_slow],
)


def settled_pack(container: str, dim: int = 3) -> gp.Pack:
    if dim == 2:
        scene = gp.PackScene.preset("4.1").replace(
            base=(0.4,), height=0.16, h_layer=0.05, settle_time=1.5, seed=4, container=container
        )
    else:
        scene = gp.PackScene.preset("4.3").replace(
            base=(0.3, 0.3),
            height=0.16,
            h_layer=0.06,
            settle_time=1.5,
            seed=3,
            container=container,
        )
    return gp.generate(scene)


@pytest.fixture(
    scope="module",
    params=[("box", 3), ("periodic", 3), ("cylinder", 3), ("box", 2), ("periodic", 2)],
)
def pack(request):
    container, dim = request.param
    return settled_pack(container, dim)


def masses(pack: gp.Pack) -> np.ndarray:
    """The engine's masses: a sphere's 4/3 pi r^3 rho in 3D and in 2D with inertia_2d =
    "sphere"; a disc of unit thickness, pi r^2 rho, in 2D by default (inertia_2d = "disc")."""
    rho = pack.scene.material.density
    r = pack.radii
    if pack.dim == 2 and pack.scene.inertia_2d == "disc":
        return math.pi * r * r * rho
    return 4.0 / 3.0 * math.pi * r**3 * rho


def test_settled_pack_satisfies_the_virial_identity(pack):
    """Static equilibrium through the virial of the particles.

    Particle i is held by its contact forces and its weight: F_i + m_i g = R_i, with R_i
    the residual of the force balance (zero at rest). With f_c the force of contact c on its
    second body (particle j, or the wall) and l_c its branch (x_j - x_i by minimum image, or
    the centre to the wall contact point x_w), summing x_i (x) (F_i + m_i g) over particles
    and regrouping by contacts gives

        sum_c l_c (x) f_c = - sum_i m_i x_i (x) g + sum_w x_w (x) f_w + sum_i x_i (x) R_i,

    where the last sum is bounded component by component by sum_i |x_ia| |R_ib|. In a
    periodic cell the lateral position of a particle is defined only up to a period, so
    only the vertical row (a = z) is checked there. So: the sigma V of the
    pack equals the moment of gravity plus the walls' term within the residual bound, and
    the bound is below 2 % of the weight's moment.
    """
    m = gp.microstructure(pack, core_margin=0.03)
    c = pack.contacts
    x = pack.positions
    d = pack.dim
    g = np.zeros(d)
    g[-1] = -pack.scene.gravity
    mass = masses(pack)
    f = contact_forces(c.normal, c.force_normal, c.force_tangential)
    wall = c.j < 0
    # force balance: each contact pushes j by f and i by -f; a wall pushes i by -f
    total = np.zeros_like(x)
    np.add.at(total, c.i, -f)
    np.add.at(total, c.j[~wall], f[~wall])
    resid = total + mass[:, None] * g
    x_wall = (
        x[c.i[wall]] + c.normal[wall] * (pack.radii[c.i[wall]] - 0.5 * c.overlap[wall])[:, None]
    )
    rhs = -np.einsum("i,ia,b->ab", mass, x, g) + x_wall.T @ f[wall]
    lhs = love_weber(f, _branches(pack), 1.0, symmetric=False).T  # sum l (x) f
    bound = np.abs(x).T @ np.abs(resid)  # |sum_i x_ia R_ib| <= sum_i |x_ia| |R_ib|
    weight_moment = abs(rhs[-1, -1])
    rows = range(d) if m.container != "periodic" else [d - 1]
    for a in rows:
        for b in range(d):
            assert abs(lhs[a, b] - rhs[a, b]) <= bound[a, b] + 1e-9 * weight_moment, (a, b)
    assert bound[-1, -1] < 0.02 * weight_moment
    # and the stress the analysis reports is that virial over the container volume
    np.testing.assert_allclose(
        m.stress, 0.5 * (lhs + lhs.T).T / m.container_volume, rtol=1e-10, atol=1e-12
    )
    assert m.stress[-1, -1] > 0 and 0.2 < m.k0 < 2.0


def _branches(pack):
    c = pack.contacts
    x, r = pack.positions, pack.radii
    wall = c.j < 0
    jj = np.where(wall, c.i, c.j)
    dx = x[jj] - x[c.i]
    if getattr(pack.scene, "container", "box") == "periodic":
        base = np.asarray(pack.scene.base)
        dx[:, :-1] -= base * np.round(dx[:, :-1] / base)
    to_wall = c.normal * (r[c.i] - 0.5 * c.overlap)[:, None]
    return np.where(wall[:, None], to_wall, dx)


def test_stress_profile_and_profiles_average_to_the_stress(pack):
    m = gp.microstructure(pack, slices=7, core_margin=0.03)
    edges, szz = m.stress_profile
    np.testing.assert_allclose(
        np.sum(szz * np.diff(edges)) / (edges[-1] - edges[0]), m.stress[-1, -1], rtol=1e-10
    )
    df = gp.profiles(pack, slices=7)
    np.testing.assert_allclose(df["stress_zz"].to_numpy(), szz, rtol=1e-12)
    # under gravity the vertical stress grows with depth; nothing above the top pushes down
    assert np.mean(szz[:3]) > 2.0 * np.mean(szz[4:]) and szz[-1] < 0.2 * np.max(szz)


def test_stress_rotates_with_the_pack():
    # turning a box pack by 90 degrees about the vertical axis: (x, y) -> (y, L - x)
    pack = settled_pack("box")
    c = pack.contacts
    rot = np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    x = pack.positions @ rot.T + [0.0, 0.3, 0.0]
    cols = c.to_dict()
    for key in ("normal", "force_tangential", "branch"):
        cols[key] = cols[key] @ rot.T
    # the walls turn too: x = lo becomes y = hi, x = hi y = lo, y = lo x = lo, y = hi x = hi
    turned = {-1: -1, -2: -5, -3: -4, -4: -2, -5: -3}
    cols["j"] = np.array([turned.get(int(v), int(v)) for v in cols["j"]])
    a = gp.microstructure(pack, core_margin=0.03)
    b = gp.microstructure(
        positions=x,
        radii=pack.radii,
        contacts=cols,
        box=([0, 0, 0], [0.3, 0.3, np.inf]),
        core_margin=0.03,
    )
    np.testing.assert_allclose(b.stress, rot @ a.stress @ rot.T, atol=1e-9 * a.stress[2, 2])
    assert b.k0 == pytest.approx(a.k0, rel=1e-10)
    np.testing.assert_allclose(b.fabric_strong, rot @ a.fabric_strong @ rot.T, atol=1e-12)


@PROPS
@given(
    seed=st.integers(0, 2**31 - 1),
    m=st.integers(1, 60),
    dim=st.sampled_from([2, 3]),
)
def test_love_weber_is_covariant_under_rotations(seed, m, dim):
    rng = np.random.default_rng(seed)
    f = rng.normal(size=(m, dim))
    b = rng.normal(size=(m, dim))
    q, _ = np.linalg.qr(rng.normal(size=(dim, dim)))
    s = love_weber(f, b, 2.5)
    s_rot = love_weber(f @ q.T, b @ q.T, 2.5)
    np.testing.assert_allclose(s_rot, q @ s @ q.T, atol=1e-12 * (1 + np.abs(s).max()))
    np.testing.assert_allclose(s, s.T)


def random_contacts(rng, n: int, m: int, dim: int) -> dict:
    """Up to m contacts of neighbours along a row (particles k and k + 1, which touch),
    with random normals and forces."""
    i = rng.integers(0, n - 1, m)
    j = i + 1
    pairs = np.unique(np.stack([i, j], 1), axis=0)
    i, j = pairs[:, 0], pairs[:, 1]
    normal = rng.normal(size=(len(i), dim))
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    return {
        "i": i,
        "j": j,
        "normal": normal,
        "force_normal": rng.exponential(1.0, len(i)),
        "force_tangential": np.zeros((len(i), dim)),
    }


@PROPS
@given(seed=st.integers(0, 2**31 - 1), m=st.integers(2, 200), dim=st.sampled_from([2, 3]))
def test_strong_and_weak_fabrics_weighted_by_counts_give_the_fabric(seed, m, dim):
    rng = np.random.default_rng(seed)
    n = 40
    # a row of unit spheres, each touching the next
    x = np.stack([np.arange(n) * 1.9] + [np.full(n, 2.0)] * (dim - 1), 1)
    cols = random_contacts(rng, n, m, dim)
    with warnings.catch_warnings():
        # a few random normals can make the fabric too anisotropic for the bin-free force
        # estimator (its quantities NaN, with a warning): not what this test checks
        warnings.simplefilter("ignore", MicrostructureWarning)
        res = gp.microstructure(positions=x, radii=np.ones(n), contacts=cols, core_margin=0.0)
    fn = cols["force_normal"]
    n_s = int(np.sum(fn > np.mean(fn)))
    n_c = len(fn)
    assert res.n_strong == n_s and res.strong_fraction == pytest.approx(n_s / n_c)
    parts = np.zeros((dim, dim))
    if n_s:
        parts += n_s * res.fabric_strong
    if n_c - n_s:
        parts += (n_c - n_s) * res.fabric_weak
    np.testing.assert_allclose(parts, n_c * res.fabric, atol=1e-12 * n_c)
    edges, pdf = res.force_distribution
    assert np.sum(pdf * np.diff(edges)) == pytest.approx(1.0)


@PROPS
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(2, 300), dim=st.sampled_from([2, 3]))
def test_coordination_distribution_sums_to_one_with_mean_z(seed, n, dim):
    rng = np.random.default_rng(seed)
    side = math.ceil(n ** (1 / dim))
    grid = np.stack(np.meshgrid(*[np.arange(side)] * dim, indexing="ij"), -1).reshape(-1, dim)
    x = grid[:n] + rng.uniform(-0.1, 0.1, size=(n, dim))  # spacing 1: overlaps stay below r
    r = rng.uniform(0.4, 0.6, n)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MicrostructureWarning)  # a pack without contacts
        m = gp.microstructure(positions=x, radii=r, core_margin=0.0)
    p = m.coordination_distribution
    k = np.arange(p.shape[0])
    assert np.sum(p) == pytest.approx(1.0, abs=1e-12)
    assert np.sum(k * p) == pytest.approx(m.z, abs=1e-12)
    assert m.z_std == pytest.approx(math.sqrt(max(0.0, np.sum(k * k * p) - m.z**2)))
    # rattlers (no walls here): the removal needing D + 1 contacts takes at least the one
    # needing D, which takes at least every particle with fewer than D to begin with
    assert m.n_rattlers_iterative >= m.n_rattlers_frictional
    assert m.n_rattlers_frictional >= round(n * float(np.sum(p[:dim])))


def brute_force_degrees(x, r, chunk=1024):
    """Contacts per particle by every pair's distance (numpy only)."""
    n = len(r)
    deg = np.zeros(n, dtype=np.int64)
    for a in range(0, n, chunk):
        dx = x[a : a + chunk, None, :] - x[None, :, :]
        dist = np.sqrt(np.sum(dx * dx, axis=-1))
        touch = dist < r[a : a + chunk, None] + r[None, :]
        touch[np.arange(touch.shape[0]), np.arange(a, a + touch.shape[0])] = False
        deg[a : a + chunk] = np.sum(touch, axis=1)
    return deg


def test_iterative_rattlers_on_a_known_network():
    # a chain 0-1-2-3 and a triangle 4-5-6 hanging from 3: in 2D (need 3 contacts) the
    # chain's end goes first, then the next, until nothing is left
    i = np.array([0, 1, 2, 3, 4, 5, 3])
    j = np.array([1, 2, 3, 4, 5, 6, 6])
    from granpack.analysis.coordination import rattlers_iterative

    ratt, live = rattlers_iterative(i, j, 7, 2)
    assert np.all(ratt) and live == 0
    # with 2 needed: the chain 0-1-2 peels off, the cycle 3-4-5-6 stays
    ratt, live = rattlers_iterative(i, j, 7, 2, min_contacts=2)
    assert ratt.tolist() == [True, True, True, False, False, False, False] and live == 4
    # a wall contact holds particle 0: the chain now stays
    ratt, live = rattlers_iterative(np.r_[i, 0], np.r_[j, -1], 7, 2, min_contacts=2)
    assert not np.any(ratt) and live == 7


def peer_pack():
    f = PEERS / "liggghts" / "pack3d_final_xyzr.txt"
    if not f.is_file():
        pytest.skip(f"peer pack {f} not present")
    return read_xyzr(f)


def test_coordination_distribution_of_a_liggghts_pack_matches_brute_force():
    x, r, _ = peer_pack()
    m = gp.microstructure(positions=x, radii=r, box=([0.0] * 3, [1.0, 1.0, math.inf]))
    deg = brute_force_degrees(x, r)
    np.testing.assert_array_equal(m.coordination_distribution, np.bincount(deg) / len(r))
    assert round(m.z, 2) == 5.01  # the peers' own script (shared/peers/README.md)


def test_stress_of_a_liggghts_pack_balances_its_weight():
    """LIGGGHTS' final pack of example 4.3 (E = 1e8 Pa, nu = 0.25, rho = 1000 kg/m^3,
    g = 2 m/s^2, walls at 0 and 1 m): its contacts' Hertz forces 4/3 E* sqrt(R*) d^(3/2)
    from the overlaps it left give a vertical stress that carries its weight,
    sigma_zz V = g sum m_i z_i (floor at z = 0), to the tangential forces' and the
    damping's share (a few per mille here)."""
    x, r, _ = peer_pack()
    box = ([0.0] * 3, [1.0, 1.0, math.inf])
    h_top = float(np.max(x[:, 2] + r))
    c = gp._core.find_contacts(x, r, walls=([0.0] * 3, [1.0, 1.0, h_top]))
    e_star = 1e8 / (2 * (1 - 0.25**2))
    jj = np.maximum(c["j"], 0)
    r_star = np.where(c["j"] >= 0, r[c["i"]] * r[jj] / (r[c["i"]] + r[jj]), r[c["i"]])
    cols = dict(c)
    cols["force_normal"] = 4.0 / 3.0 * e_star * np.sqrt(r_star) * c["overlap"] ** 1.5
    m = gp.microstructure(positions=x, radii=r, box=box, contacts=cols)
    weight = 2.0 * np.sum(1000.0 * 4.0 / 3.0 * math.pi * r**3 * x[:, 2])
    assert m.stress[2, 2] * m.container_volume == pytest.approx(weight, rel=0.01)
    assert 0.5 < m.k0 < 1.0
    assert 0.3 < m.strong_fraction < 0.45  # the strong network: a third of the contacts
