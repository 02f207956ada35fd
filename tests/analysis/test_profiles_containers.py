"""Depth and radial profiles, exact volumes of slabs and cylinders, and the analysis in each
container: periodic contacts against a brute-force minimum-image search, translation
invariance of a periodic pack, the cylinder's volume and core window."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import granpack as gp
from granpack.analysis import cylinder_volumes, slab_volumes
from granpack.analysis.system import _prepare

PROPS = settings(
    max_examples=30,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.too_slow],
)


# --------------------------------------------------------------------------------------
# exact volumes
# --------------------------------------------------------------------------------------
def test_slab_volumes_of_spheres_and_discs_are_exact():
    x3 = np.array([[0.0, 0.0, 1.0]])
    r = np.array([0.5])
    assert slab_volumes(x3, r, 1.0, 9.0)[0] == pytest.approx(2 / 3 * math.pi * 0.125, rel=1e-15)
    # a cap of height h: pi h^2 (3r - h)/3
    h = 0.2
    assert slab_volumes(x3, r, 1.5 - h, 9.0)[0] == pytest.approx(math.pi * h * h * (1.5 - h) / 3)
    x2 = np.array([[0.0, 1.0]])
    # a circular segment of height h: r^2 acos((r - h)/r) - (r - h) sqrt(2 r h - h^2)
    seg = 0.25 * math.acos((0.5 - h) / 0.5) - (0.5 - h) * math.sqrt(h - h * h)
    assert slab_volumes(x2, r, 1.5 - h, 9.0)[0] == pytest.approx(seg, rel=1e-13)
    assert slab_volumes(x2, r, -9.0, 9.0)[0] == pytest.approx(math.pi * 0.25, rel=1e-15)


@pytest.mark.parametrize("big_r", [0.1, 0.3, 0.45])
def test_sphere_inside_a_coaxial_cylinder_is_exact(big_r):
    # sphere of radius r on the axis of a cylinder of radius R < r:
    # V = 4 pi/3 (r^3 - (r^2 - R^2)^(3/2))
    r = 0.5
    exact = 4 * math.pi / 3 * (r**3 - (r * r - big_r * big_r) ** 1.5)
    got = cylinder_volumes(np.array([[0.0, 0.0, 0.0]]), np.array([r]), (0.0, 0.0), big_r, -1, 1)
    assert got[0] == pytest.approx(exact, rel=1e-10)


def test_cylinder_volumes_agree_with_monte_carlo():
    rng = np.random.default_rng(5)
    k = 12
    c = np.column_stack([rng.uniform(-0.6, 0.6, (k, 2)), rng.uniform(-0.3, 0.3, k)])
    r = rng.uniform(0.1, 0.4, k)
    got = cylinder_volumes(c, r, (0.0, 0.0), 0.5, -0.2, 0.25)
    n = 200_000
    for q in range(k):
        u = rng.uniform(-1.0, 1.0, (n, 3)) * r[q] + c[q]
        inside = (
            (np.sum((u - c[q]) ** 2, 1) <= r[q] ** 2)
            & (np.hypot(u[:, 0], u[:, 1]) <= 0.5)
            & (u[:, 2] >= -0.2)
            & (u[:, 2] <= 0.25)
        )
        box = (2 * r[q]) ** 3
        p = np.mean(inside)
        se = box * math.sqrt(p * (1 - p) / n) + 1e-12
        assert abs(got[q] - box * p) < 5 * se, q


# --------------------------------------------------------------------------------------
# profiles
# --------------------------------------------------------------------------------------
def cells(n: int, dim: int) -> int:
    """Grid cells per axis: at least 3, so that a period exceeds 4 r_max."""
    return max(3, math.ceil(n ** (1 / dim)))


def jittered(n: int, dim: int, rng) -> tuple[np.ndarray, np.ndarray]:
    side = cells(n, dim)
    grid = np.stack(np.meshgrid(*[np.arange(side)] * dim, indexing="ij"), -1).reshape(-1, dim)
    x = (grid[:n] + 0.5 + rng.uniform(-0.1, 0.1, size=(n, dim))) * 0.1
    r = rng.uniform(0.04, 0.06, n)
    return x, r


@PROPS
@given(
    seed=st.integers(0, 2**31 - 1),
    n=st.integers(4, 200),
    dim=st.sampled_from([2, 3]),
    slices=st.integers(1, 25),
    periodic=st.booleans(),
)
def test_thickness_weighted_profiles_add_up_to_phi(seed, n, dim, slices, periodic):
    rng = np.random.default_rng(seed)
    x, r = jittered(n, dim, rng)
    side = 0.1 * cells(n, dim)
    box = ([0.0] * dim, [side] * (dim - 1) + [np.inf])
    kw = {"periodic": (True,) * (dim - 1)} if periodic else {}
    df = gp.profiles(positions=x, radii=r, box=box, slices=slices, **kw)
    with np.errstate(all="ignore"):
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("ignore", gp.analysis.MicrostructureWarning)
            m = gp.microstructure(positions=x, radii=r, box=box, core_margin=0.0, **kw)
    dz = (df["z_hi"] - df["z_lo"]).to_numpy()
    assert np.sum(df["phi"].to_numpy() * dz) / np.sum(dz) == pytest.approx(m.phi, rel=1e-12)
    assert int(df["n_particles"].sum()) == n
    # Z weighted by the particles of each slice is the pack's Z
    zs = df["Z"].to_numpy()
    w = df["n_particles"].to_numpy()
    assert np.nansum(zs * w) / n == pytest.approx(m.z, abs=1e-12)
    assert int(df["n_contacts"].sum()) == m.n_contacts
    assert df.columns[:3] == ["z_lo", "z_hi", "phi"] and "stress_zz" in df.columns


@pytest.fixture(scope="module")
def cylinder_pack():
    scene = gp.PackScene.preset("4.3").replace(
        base=(0.4, 0.4), height=0.2, h_layer=0.06, settle_time=0.8, seed=2, container="cylinder"
    )
    return gp.generate(scene)


@pytest.fixture(scope="module")
def periodic_pack():
    scene = gp.PackScene.preset("4.3").replace(
        base=(0.3, 0.3), height=0.15, h_layer=0.06, settle_time=0.6, seed=8, container="periodic"
    )
    return gp.generate(scene)


def test_cylinder_phi_is_over_the_cylinder_and_its_core_is_coaxial(cylinder_pack):
    p = cylinder_pack
    m = gp.microstructure(p, core_margin=0.04)
    big_r = 0.2
    vol = np.sum(4 / 3 * math.pi * p.radii**3)
    assert m.container == "cylinder"
    assert m.container_volume == pytest.approx(math.pi * big_r**2 * m.h_top, rel=1e-14)
    assert m.phi == pytest.approx(vol / (math.pi * big_r**2 * m.h_top), rel=1e-14)
    assert {int(j) for j in p.contacts.j[p.contacts.j < 0]} <= {-1, -2}
    # the core: a coaxial cylinder of radius R - 0.04 from 0.04 to H_top - 0.04, by Monte Carlo
    rng = np.random.default_rng(1)
    n = 60_000
    rc = big_r - 0.04
    t = rng.uniform(0, 2 * math.pi, n)
    s = rc * np.sqrt(rng.uniform(0, 1, n))
    u = np.column_stack(
        [0.2 + s * np.cos(t), 0.2 + s * np.sin(t), rng.uniform(0.04, m.h_top - 0.04, n)]
    )
    covered = np.zeros(n, dtype=bool)
    for q in range(len(p.radii)):
        covered |= np.sum((u - p.positions[q]) ** 2, 1) <= p.radii[q] ** 2
    est = np.mean(covered)
    assert abs(m.phi_core - est) < 5 * math.sqrt(est * (1 - est) / n)


def test_radial_profiles_of_a_cylinder_add_up_to_phi(cylinder_pack):
    df = gp.radial_profiles(cylinder_pack, shells=6)
    m = gp.microstructure(cylinder_pack, core_margin=0.04)
    area = (df["r_hi"] ** 2 - df["r_lo"] ** 2).to_numpy()
    assert np.sum(df["phi"].to_numpy() * area) / np.sum(area) == pytest.approx(m.phi, rel=1e-10)
    assert int(df["n_particles"].sum()) == m.n_particles
    # the wall's layering: the centres of the spheres on the wall crowd the shell at R - r,
    # one radius from the wall, and leave the shell a radius further in nearly empty
    fine = gp.radial_profiles(cylinder_pack, shells=40)
    r_lo, r_hi = fine["r_lo"].to_numpy(), fine["r_hi"].to_numpy()
    density = fine["n_particles"].to_numpy() / (r_hi**2 - r_lo**2)
    mean = m.n_particles / 0.2**2
    k = int(np.argmax(density))
    assert r_lo[k] <= 0.2 - 0.02 <= r_hi[k] and density[k] > 3.0 * mean
    gap = (r_lo >= 0.2 - 0.04) & (r_hi <= 0.2 - 0.025)
    assert np.all(density[gap] < mean)
    with pytest.raises(gp.InvalidParameterError, match="cylinder"):
        gp.radial_profiles(positions=np.array([[0.5, 0.5, 0.5]]), radii=np.array([0.1]))


def brute_periodic_contacts(x, r, periods):
    """Every pair by its minimum-image distance (numpy only)."""
    dx = x[None, :, :] - x[:, None, :]
    for k, p in enumerate(periods):
        if p is not None:
            dx[..., k] -= p * np.round(dx[..., k] / p)
    dist = np.sqrt(np.sum(dx * dx, -1))
    i, j = np.nonzero(dist < r[:, None] + r[None, :])
    keep = i < j
    return i[keep], j[keep], dx[i[keep], j[keep]]


@PROPS
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(2, 150), dim=st.sampled_from([2, 3]))
def test_periodic_contacts_and_branches_equal_a_minimum_image_search(seed, n, dim):
    rng = np.random.default_rng(seed)
    x, r = jittered(n, dim, rng)
    side = 0.1 * cells(n, dim)
    x[:, :-1] = np.mod(x[:, :-1] + rng.uniform(0, side), side)  # pairs across the seam
    x[:, -1] += 0.1
    box = ([0.0] * dim, [side] * (dim - 1) + [np.inf])
    prep = _prepare(None, x, r, None, box, (True,) * (dim - 1), None)
    c = prep.contacts
    pp = c.j >= 0
    got = {(int(a), int(b)): k for k, (a, b) in enumerate(zip(c.i, c.j, strict=True)) if b >= 0}
    bi, bj, bdx = brute_periodic_contacts(x, r, [side] * (dim - 1) + [None])
    assert set(got) == set(zip(bi.tolist(), bj.tolist(), strict=True))
    if len(bi):
        order = [got[(int(a), int(b))] for a, b in zip(bi, bj, strict=True)]
        np.testing.assert_allclose(prep.branches()[order], bdx, atol=1e-12)
    # no side walls in a periodic cell: only the floor
    assert set(np.unique(c.j[~pp]).tolist()) <= {-1}


def test_a_periodic_pack_is_invariant_under_lateral_shifts(periodic_pack):
    p = periodic_pack
    base = np.asarray(p.scene.base)
    a = gp.microstructure(p, core_margin=0.03)
    for shift in ([0.1234, 0.0], [0.29, 0.17], [-0.05, 0.31]):
        x = p.positions.copy()
        x[:, :2] = np.mod(x[:, :2] + shift, base)
        b = gp.microstructure(
            positions=x,
            radii=p.radii,
            box=([0, 0, 0], [*base, np.inf]),
            periodic=(True, True),
            core_margin=0.03,
        )
        assert b.n_contacts == a.n_contacts and b.z == pytest.approx(a.z, abs=1e-12)
        np.testing.assert_allclose(b.fabric, a.fabric, atol=1e-12)
        assert b.phi == pytest.approx(a.phi, rel=1e-12)
        assert b.phi_core == pytest.approx(a.phi_core, rel=1e-12)
        np.testing.assert_allclose(b.q6, a.q6, atol=1e-10, equal_nan=True)


def test_periodic_pack_contacts_across_the_seam_count(periodic_pack):
    p = periodic_pack
    c = p.contacts
    pp = c.j >= 0
    dx = p.positions[c.j[pp]] - p.positions[c.i[pp]]
    seam = np.any(np.abs(dx[:, :2]) > 0.5 * np.asarray(p.scene.base), axis=1)
    assert np.any(seam)  # the engine keeps pairs across the seam
    geo = gp.microstructure(
        positions=p.positions,
        radii=p.radii,
        box=([0, 0, 0], [*p.scene.base, np.inf]),
        periodic=(True, True),
        core_margin=0.03,
    )
    assert geo.n_contacts == int(np.sum(pp))
    assert geo.phi == pytest.approx(gp.microstructure(p, core_margin=0.03).phi, rel=1e-14)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"periodic": (True, True)}, "box"),
        ({"periodic": (True,), "box": ([0, 0, 0], [1, 1, 9])}, "periodic"),
        ({"cylinder_radius": -1.0, "box": ([0, 0, 0], [1, 1, 9])}, "cylinder_radius"),
        (
            {"cylinder_radius": 0.5, "periodic": (True, True), "box": ([0, 0, 0], [1, 1, 9])},
            "periodic",
        ),
        ({"slices": 0}, "slices"),
    ],
)
def test_container_arguments_are_checked(kwargs, match):
    x = np.array([[0.5, 0.5, 0.5], [0.5, 0.5, 0.7]])
    with pytest.raises(gp.GranpackError, match=match):
        gp.microstructure(positions=x, radii=np.array([0.1, 0.1]), **kwargs)


def test_analysis_figure_draws_packs_of_every_container(periodic_pack, cylinder_pack, tmp_path):
    from granpack import plot

    for k, pack in enumerate((periodic_pack, cylinder_pack)):
        m = gp.microstructure(pack, core_margin=0.03)
        path = plot.save(plot.analysis_figure([pack], [m], title="t"), tmp_path / f"a{k}.png")
        assert path.stat().st_size > 20_000
        assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
