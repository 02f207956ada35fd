"""Structure beyond contacts on configurations with known answers: Steinhardt's bond order on
ideal lattices, g(r) peaks at the lattice distances and g = 1 for uncorrelated points in every
container, P(Z) a single bar on a lattice."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

import granpack as gp
from granpack.analysis import Container
from granpack.analysis.structure import bond_order, pair_correlation, spherical_harmonics  # noqa: I001

#: Radii a hair above half the spacing: every nearest neighbour is a contact (overlap > 0).
TOUCH = 0.5 * (1.0 + 1e-6)


def fcc(n: int) -> np.ndarray:
    basis = np.array([[0, 0, 0], [0.5, 0.5, 0], [0.5, 0, 0.5], [0, 0.5, 0.5]])
    cells = np.array(list(itertools.product(range(n), repeat=3)), dtype=float)
    return (cells[:, None, :] + basis[None]).reshape(-1, 3) * math.sqrt(2.0)  # spacing 1


def hcp(n: int) -> np.ndarray:
    pts = []
    for k in range(n):
        off = (0.5, math.sqrt(3.0) / 6.0) if k % 2 else (0.0, 0.0)
        for i, j in itertools.product(range(n), repeat=2):
            pts.append(
                [i + 0.5 * j + off[0], j * math.sqrt(3.0) / 2.0 + off[1], k * math.sqrt(2 / 3)]
            )
    return np.array(pts)


def simple_cubic(n: int) -> np.ndarray:
    return np.array(list(itertools.product(range(n), repeat=3)), dtype=float)


def triangular(n: int) -> np.ndarray:
    return np.array(
        [[i + 0.5 * (j % 2), j * math.sqrt(3.0) / 2.0] for i in range(n) for j in range(n)]
    )


def lift(x: np.ndarray) -> np.ndarray:
    """Off the floor at 0, so that no particle touches it."""
    return x - x.min(axis=0) + 1.0


@pytest.mark.parametrize(
    ("lattice", "n", "q6", "bonds"),
    [(fcc, 4, 0.5745, 12), (hcp, 6, 0.4848, 12), (simple_cubic, 5, 0.3536, 6)],
)
def test_q6_of_ideal_lattices(lattice, n, q6, bonds):
    x = lift(lattice(n))
    bo = gp.steinhardt(x, np.full(len(x), TOUCH))
    full = bo.n_bonds == bonds
    assert np.any(full)
    # every particle with the full shell has the lattice value, to the printed digits
    np.testing.assert_allclose(bo.q[full], q6, atol=5e-5)
    # the close-packed lattices crystallise; simple cubic (q6 below 0.45) does not
    expect = 1.0 if q6 > 0.45 else 0.0
    assert np.all(bo.crystal[full] == bool(expect))


def test_psi6_of_the_triangular_lattice_is_one_and_of_the_square_lattice_zero():
    x = lift(triangular(8))
    bo = gp.steinhardt(x, np.full(len(x), TOUCH))
    full = bo.n_bonds == 6
    np.testing.assert_allclose(bo.q[full], 1.0, atol=1e-12)
    assert bo.global_q == pytest.approx(1.0, abs=1e-12)
    sq = lift(np.array(list(itertools.product(range(6), repeat=2)), dtype=float))
    bs = gp.steinhardt(sq, np.full(len(sq), TOUCH))
    np.testing.assert_allclose(bs.q[bs.n_bonds == 4], 0.0, atol=1e-12)
    assert bs.crystal_fraction == 0.0


def test_spherical_harmonics_are_orthonormal():
    # Gauss-Legendre x uniform azimuth integrates Y_lm Y_lm'* exactly for l = 6
    xg, wg = np.polynomial.legendre.leggauss(16)
    ph = 2 * math.pi * np.arange(32) / 32
    ct, p = np.meshgrid(xg, ph, indexing="ij")
    st = np.sqrt(1 - ct**2)
    n = np.stack([st * np.cos(p), st * np.sin(p), ct], -1).reshape(-1, 3)
    w = (wg[:, None] * np.full(32, 2 * math.pi / 32)).ravel()
    y = spherical_harmonics(6, n)
    gram = (y * w[:, None]).T @ np.conj(y)
    np.testing.assert_allclose(gram, np.eye(7), atol=1e-12)


def test_bond_order_is_rotation_invariant():
    rng = np.random.default_rng(3)
    m = 40
    i = rng.integers(0, 10, m)
    j = (i + 1 + rng.integers(0, 9, m)) % 10
    n = rng.normal(size=(m, 3))
    n /= np.linalg.norm(n, axis=1)[:, None]
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    a = bond_order(i, j, n, 10, 3)
    b = bond_order(i, j, n @ q.T, 10, 3)
    np.testing.assert_allclose(a.q, b.q, atol=1e-12)
    assert a.global_q == pytest.approx(b.global_q, abs=1e-12)


@pytest.mark.parametrize(("dim", "bar"), [(2, 2), (3, 6), (3, 4)])
def test_coordination_distribution_is_a_single_bar_on_a_periodic_lattice(dim, bar):
    # a row of discs (2D), a triangular or square monolayer of spheres (3D), periodic
    # laterally: every particle has the same contacts, those across the seam included
    if dim == 2:
        x = np.stack([np.arange(10) + 0.5, np.full(10, 2.0)], 1)
        box = ([0.0, 0.0], [10.0, np.inf])
    elif bar == 6:
        tri = triangular(8)
        x = np.column_stack([tri + [0.25, 0.25], np.full(len(tri), 2.0)])
        box = ([0.0, 0.0, 0.0], [8.0, 8 * math.sqrt(3.0) / 2.0, np.inf])
    else:
        sq = np.array(list(itertools.product(range(7), repeat=2)), dtype=float) + 0.5
        x = np.column_stack([sq, np.full(len(sq), 2.0)])
        box = ([0.0, 0.0, 0.0], [7.0, 7.0, np.inf])
    m = gp.microstructure(
        positions=x,
        radii=np.full(len(x), TOUCH),
        box=box,
        periodic=(True,) * (dim - 1),
        core_margin=0.0,
    )
    p = m.coordination_distribution
    assert p.shape[0] == bar + 1 and p[bar] == 1.0 and np.sum(p) == 1.0
    assert m.z == bar and m.z_std == 0.0 and m.n_wall_contacts == 0


def test_rdf_peaks_at_the_lattice_distances():
    x = lift(fcc(6))
    r, g = gp.rdf(x, np.full(len(x), TOUCH), r_max=2.2, bins=220, margin=0.0)
    peaks = r[(g > 0) & (np.r_[0, g[:-1]] < g) & (np.r_[g[1:], 0] <= g)]
    # FCC shells at sqrt(k) spacings: 1, sqrt 2, sqrt 3, 2
    for shell in (1.0, math.sqrt(2.0), math.sqrt(3.0), 2.0):
        assert np.min(np.abs(peaks - shell)) < 0.011
    # nothing between the shells
    assert np.all(g[(r > 0.02) & (r < 0.99)] == 0.0)
    assert np.all(g[(r > 1.01) & (r < 1.40)] == 0.0)


@pytest.mark.parametrize("kind", ["box", "periodic", "cylinder"])
def test_edge_corrected_rdf_of_uncorrelated_points_is_one(kind):
    # a Poisson process has g = 1 at every r; without the edge correction g would fall with r
    rng = np.random.default_rng(11)
    n = 6000
    lo = np.zeros(3)
    hi = np.array([1.0, 1.0, 0.6])
    x = rng.uniform(lo, hi, size=(3 * n, 3))
    radius = None
    if kind == "cylinder":
        radius = 0.5
        x = x[np.hypot(x[:, 0] - 0.5, x[:, 1] - 0.5) <= radius][:n]
    else:
        x = x[:n]
    cont = Container(kind, lo, hi, (kind == "periodic",) * 2, radius)
    r, g = pair_correlation(x, cont, 0.25, 10)
    # each bin holds thousands of pairs: binomial error a few percent at the first bins
    np.testing.assert_allclose(g[2:], 1.0, atol=0.05)
    assert abs(float(np.mean(g[2:])) - 1.0) < 0.02


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"r_max": -1.0}, "r_max"),
        ({"r_max": 50.0}, "r_max"),
        ({"bins": 0}, "bins"),
        ({"margin": 10.0}, "margin"),
    ],
)
def test_rdf_refuses_bad_input(kwargs, match):
    x = lift(fcc(3))
    with pytest.raises(gp.InvalidParameterError, match=match):
        gp.rdf(x, np.full(len(x), TOUCH), **kwargs)


@pytest.mark.parametrize(("l_value", "match"), [(0, "l"), (17, "l"), (2.5, "l")])
def test_steinhardt_refuses_bad_orders(l_value, match):
    x = lift(fcc(2))
    with pytest.raises(gp.InvalidParameterError, match=match):
        gp.steinhardt(x, np.full(len(x), TOUCH), l=l_value)


def test_radical_voronoi_local_phi_of_fcc_and_of_a_periodic_cell():
    pytest.importorskip("pyvoro2")
    from granpack.analysis import local_phi

    # FCC with periodic x and y: every cell is the rhombic dodecahedron, phi = pi/(3 sqrt 2)
    n = 4
    x = fcc(n)
    side = n * math.sqrt(2.0)
    x[:, 2] += 5.0
    radii = np.full(len(x), 0.5)
    inner = (x[:, 2] > x[:, 2].min() + 0.5) & (x[:, 2] < x[:, 2].max() - 0.5)
    lp = local_phi(
        positions=x, radii=radii, box=([0, 0, 0], [side, side, np.inf]), periodic=(True, True)
    )
    np.testing.assert_allclose(lp[inner], math.pi / (3 * math.sqrt(2.0)), rtol=1e-9)
    # the cells tile the container: the particles' volumes over the cells' sum is phi
    rng = np.random.default_rng(2)
    grid = np.stack(np.meshgrid(np.arange(15), np.arange(15), indexing="ij"), -1).reshape(-1, 2)
    pts = (grid + 0.5 + rng.uniform(-0.2, 0.2, grid.shape)) / 15.0
    r2 = rng.uniform(0.01, 0.03, len(pts))
    lp2 = local_phi(positions=pts, radii=r2, box=([0, 0], [1.0, np.inf]))
    m = gp.microstructure(positions=pts, radii=r2, box=([0, 0], [1.0, np.inf]), core_margin=0.0)
    assert np.sum(math.pi * r2**2 / lp2) == pytest.approx(m.container_volume, rel=1e-9)
    with pytest.raises(gp.InvalidParameterError, match="cylinder"):
        local_phi(
            positions=x,
            radii=radii,
            box=([0, 0, 0], [side, side, np.inf]),
            cylinder_radius=side / 2,
        )
