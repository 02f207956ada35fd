"""granpack.microstructure on hand-built configurations with closed-form answers."""

from __future__ import annotations

import math

import numpy as np
import pytest

import granpack as gp
from granpack.analysis import (
    Microstructure,
    MicrostructureWarning,
    force_tensors,
    force_tensors_binned,
    read_xyzr,
    window_volumes,
)

R = 0.01
#: Lattice spacing a hair under 2r, so that neighbours overlap by 1e-9 r (contacts are
#: pairs with positive overlap) while every other number stays as for touching discs.
S = 2 * R * (1 - 1e-9)
DELTA = 1e-12


def analyse(**kwargs) -> Microstructure:
    """gp.microstructure with a core margin to suit these small configurations (the default
    0.1 m would leave no core window and warn)."""
    kwargs.setdefault("core_margin", 2 * R)
    return gp.microstructure(**kwargs)


def square_lattice(n: int, x0: float = R) -> np.ndarray:
    k = np.arange(n)
    gx, gy = np.meshgrid(x0 + k * S, R + k * S, indexing="ij")
    return np.column_stack([gx.ravel(), gy.ravel()])


def cubic_lattice(n: int) -> np.ndarray:
    k = R + np.arange(n) * S
    g = np.meshgrid(k, k, k, indexing="ij")
    return np.column_stack([a.ravel() for a in g])


def hex_patch(n: int, m: int) -> np.ndarray:
    """m rows of n discs, odd rows shifted by half a spacing (contacts at 0, 60, 120 deg)."""
    rows = []
    for j in range(m):
        x = R + (j % 2) * S / 2 + np.arange(n) * S
        rows.append(np.column_stack([x, np.full(n, R + j * S * math.sqrt(3) / 2)]))
    return np.concatenate(rows)


def lattice_box(x: np.ndarray) -> tuple[list[float], list[float]]:
    """Walls touching the outer particles with zero overlap (no wall contacts)."""
    d = x.shape[1]
    return [0.0] * d, [*(x[:, :-1].max(axis=0) + R).tolist(), math.inf]


# --------------------------------------------------------------------------------------
# lattices: coordination and fabric in closed form
# --------------------------------------------------------------------------------------
def test_square_lattice_fabric_is_half_identity_and_z_counts_neighbours():
    n = 7
    x = square_lattice(n)
    m = analyse(positions=x, radii=np.full(n * n, R), box=lattice_box(x))
    assert m.n_contacts == 2 * n * (n - 1)
    assert m.n_wall_contacts == 0
    assert m.z == pytest.approx(4 * (n - 1) / n, rel=1e-15)
    assert m.z_mech == pytest.approx(m.z, rel=1e-15)  # every disc has >= 2 contacts
    assert m.n_rattlers == 0
    np.testing.assert_allclose(m.fabric, np.eye(2) / 2, atol=1e-15)
    np.testing.assert_allclose(m.a_r, 0.0, atol=1e-14)
    np.testing.assert_allclose(m.fabric_eigenvalues, [0.5, 0.5], atol=1e-15)
    assert m.phi_d == pytest.approx(0.0, abs=1e-14)
    assert m.anisotropy["ibraim"] == pytest.approx(1.0, rel=1e-14)
    assert m.anisotropy["thornton"] == pytest.approx(0.0, abs=1e-14)
    area = n * n * math.pi * R**2
    base = (n - 1) * S + 2 * R
    assert m.phi == pytest.approx(area / (base * base), rel=1e-14)
    assert m.void_ratio == pytest.approx((1 - m.phi) / m.phi, rel=1e-14)
    assert m.has_forces is False
    assert math.isnan(m.f0) and np.all(np.isnan(m.a_n))


def test_hexagonal_patch_fabric_matches_bond_counts():
    n, m_rows = 9, 7  # m - 1 even: as many 60 as 120 degree bonds
    x = hex_patch(n, m_rows)
    m = analyse(positions=x, radii=np.full(len(x), R))
    horizontal = m_rows * (n - 1)
    diagonal = (m_rows - 1) * (2 * n - 1)
    assert m.n_contacts == horizontal + diagonal
    total = horizontal + diagonal
    want = np.diag([(horizontal + diagonal / 4) / total, diagonal * 3 / 4 / total])
    np.testing.assert_allclose(m.fabric, want, atol=1e-9)
    assert m.z == pytest.approx(2 * total / (n * m_rows), rel=1e-15)
    # an infinite hexagonal packing is isotropic; this patch's bias is the missing bonds
    assert np.trace(m.fabric) == pytest.approx(1.0, abs=1e-15)


def test_simple_cubic_lattice_is_isotropic():
    n = 5
    x = cubic_lattice(n)
    m = analyse(positions=x, radii=np.full(n**3, R), box=lattice_box(x))
    assert m.n_contacts == 3 * n * n * (n - 1)
    assert m.z == pytest.approx(6 * (n - 1) / n, rel=1e-15)
    np.testing.assert_allclose(m.fabric, np.eye(3) / 3, atol=1e-15)
    np.testing.assert_allclose(m.a_r, 0.0, atol=1e-14)
    assert m.phi_d == pytest.approx(0.0, abs=1e-14)
    np.testing.assert_allclose(m.fabric_eigenvalues, [1 / 3] * 3, atol=1e-15)


def test_wall_contacts_are_counted_in_z_walls_only():
    n = 5
    eps = 1e-6 * R  # each outer disc overlaps its wall by eps
    x = square_lattice(n, x0=R - eps)
    x[:, 1] -= eps
    hi = x[:, 0].max() + R - eps
    m = analyse(positions=x, radii=np.full(n * n, R), box=([0.0, 0.0], [hi, 1.0]))
    assert m.n_wall_contacts == 3 * n  # floor, x = 0 and x = L; the top is open
    assert m.z == pytest.approx(4 * (n - 1) / n, rel=1e-15)
    assert m.z_walls == pytest.approx((4 * n * (n - 1) + 3 * n) / n**2, rel=1e-15)
    # only particle-particle contacts enter the fabric
    np.testing.assert_allclose(m.fabric, np.eye(2) / 2, atol=1e-15)


def test_mechanical_z_drops_rattlers():
    # a chain of 4 (degrees 1, 2, 2, 1) and a free disc: 3 contacts, N_0 = 1, N_1 = 2
    x = np.array([[0.1, 0.1], [0.1 + S, 0.1], [0.1 + 2 * S, 0.1], [0.1 + 3 * S, 0.1], [0.5, 0.5]])
    m = analyse(positions=x, radii=np.full(5, R))
    assert m.n_contacts == 3
    assert m.z == pytest.approx(6 / 5)
    assert m.n_rattlers == 3
    assert m.z_mech == pytest.approx((6 - 2) / (5 - 1 - 2))


# --------------------------------------------------------------------------------------
# packing fractions
# --------------------------------------------------------------------------------------
def test_core_fraction_through_lattice_centres_is_exact_2d():
    # The window's edges run through rows and columns of centres: the discs cut in half or in
    # quarters add up to k*l whole discs in k*l cells, so phi_core = pi r^2/s^2 exactly.
    # (The edges sit DELTA outside the centre lines so that rounding cannot move a centre out
    # of the peers' closed window; that changes phi_core by ~DELTA/(k s).)
    n = 9
    x = square_lattice(n)
    m = gp.microstructure(
        positions=x, radii=np.full(n * n, R), box=lattice_box(x), core_margin=R + S - DELTA
    )
    assert m.phi_core == pytest.approx(math.pi * R**2 / S**2, rel=1e-9)
    k = n - 3  # cells across the window; the peers' recipe counts (k + 1)^2 whole discs
    assert m.phi_core_centres == pytest.approx((k + 1) ** 2 * math.pi * R**2 / (k * S) ** 2)


def test_core_fraction_through_lattice_centres_is_exact_3d():
    n = 6
    x = cubic_lattice(n)
    m = analyse(positions=x, radii=np.full(n**3, R), box=lattice_box(x), core_margin=R + S - DELTA)
    assert m.phi_core == pytest.approx(4 / 3 * math.pi * R**3 / S**3, rel=1e-9)
    k = n - 3
    assert m.phi_core_centres == pytest.approx((k + 1) ** 3 * 4 / 3 * math.pi * R**3 / (k * S) ** 3)


def test_window_volumes_closed_forms():
    r = 1.0
    # 2D: centred on a corner -> a quarter; cut by one line at distance d -> disc - segment
    lo, hi = np.array([0.0, 0.0]), np.array([5.0, 5.0])
    d = 0.3
    a = window_volumes(np.array([[0.0, 0.0], [2.0, -d], [2.0, 2.0]]), np.ones(3), lo, hi)
    segment = r * r * math.acos(d / r) - d * math.sqrt(r * r - d * d)
    np.testing.assert_allclose(a, [math.pi / 4, segment, math.pi], rtol=1e-14)
    # 3D: corner -> 1/8, edge -> 1/4, one plane at distance d -> cap pi h^2 (3r - h)/3
    lo3, hi3 = np.zeros(3), np.full(3, 5.0)
    h = r - d
    c = np.array([[0, 0, 0], [2, 0, 0], [2, 2, -d], [2, 2, 2]], dtype=float)
    v = window_volumes(c, np.ones(4), lo3, hi3)
    sphere = 4 / 3 * math.pi
    cap = math.pi * h * h * (3 * r - h) / 3
    # (3D integrates exact slice areas by quadrature: ~1e-11 of the volume, see window_volumes)
    np.testing.assert_allclose(v, [sphere / 8, sphere / 4, cap, sphere], rtol=1e-10)


def test_window_volumes_3d_converges_and_agrees_with_monte_carlo():
    rng = np.random.default_rng(7)
    lo, hi = np.array([0.0, 0.0, 0.0]), np.array([1.0, 0.7, 0.9])
    c = rng.uniform(-0.3, 1.3, size=(40, 3))
    r = rng.uniform(0.2, 0.6, size=40)
    sphere = 4 / 3 * np.pi * r**3
    v12 = window_volumes(c, r, lo, hi)
    v40 = window_volumes(c, r, lo, hi, order=40)
    assert np.max(np.abs(v12 - v40) / sphere) < 1e-10
    # Monte Carlo on four cut spheres; 5 standard errors of a binomial proportion
    k = np.flatnonzero((v12 > 0.05 * sphere) & (v12 < 0.95 * sphere))
    for idx in k[:4]:
        p = rng.uniform(-1, 1, size=(400_000, 3))
        p = p[np.sum(p * p, axis=1) < 1] * r[idx] + c[idx]
        frac = np.mean(np.all((p >= lo) & (p <= hi), axis=1))
        se = math.sqrt(frac * (1 - frac) / len(p))
        assert v12[idx] / (4 / 3 * np.pi * r[idx] ** 3) == pytest.approx(frac, abs=5 * se)


def test_window_volumes_2d_agree_with_monte_carlo():
    rng = np.random.default_rng(8)
    lo, hi = np.array([0.0, 0.0]), np.array([1.0, 0.4])
    c = rng.uniform(-0.2, 1.2, size=(6, 2))
    r = np.full(6, 0.35)
    a = window_volumes(c, r, lo, hi)
    for idx in range(6):
        p = rng.uniform(-1, 1, size=(300_000, 2))
        p = p[np.sum(p * p, axis=1) < 1] * r[idx] + c[idx]
        frac = np.mean(np.all((p >= lo) & (p <= hi), axis=1))
        se = max(math.sqrt(frac * (1 - frac) / len(p)), 1e-12)
        assert a[idx] / (np.pi * r[idx] ** 2) == pytest.approx(frac, abs=5 * se)


# --------------------------------------------------------------------------------------
# forces: closed forms for both estimators
# --------------------------------------------------------------------------------------
def lattice_contacts_with_forces(n: int, fx: float, fy: float, tau: float = 0.0) -> dict:
    """Square-lattice bonds with normal force fx on horizontal and fy on vertical ones, and
    a tangential force tau on the horizontal bonds."""
    idx = np.arange(n * n).reshape(n, n)
    i_h, j_h = idx[:-1, :].ravel(), idx[1:, :].ravel()
    i_v, j_v = idx[:, :-1].ravel(), idx[:, 1:].ravel()
    mh, mv = len(i_h), len(i_v)
    normal = np.concatenate([np.tile([1.0, 0.0], (mh, 1)), np.tile([0.0, 1.0], (mv, 1))])
    ft = np.concatenate([np.tile([0.0, tau], (mh, 1)), np.zeros((mv, 2))])
    return {
        "i": np.concatenate([i_h, i_v]),
        "j": np.concatenate([j_h, j_v]),
        "normal": normal,
        "force_normal": np.concatenate([np.full(mh, fx), np.full(mv, fy)]),
        "force_tangential": ft,
    }


def test_force_tensors_on_a_loaded_square_lattice():
    # a^r = 0 so w_c = 1: F^n = diag(fx, fy)/2, f0 = (fx + fy)/2, a^n = 4 (F^n/f0 - I/2)
    n = 6
    x = square_lattice(n)
    c = lattice_contacts_with_forces(n, fx=1.0, fy=3.0)
    m = analyse(positions=x, radii=np.full(n * n, R), contacts=c, binned=True, n_bins=3600)
    assert m.has_forces
    assert m.f0 == pytest.approx(2.0, rel=1e-14)
    np.testing.assert_allclose(m.force_normal_tensor, np.diag([0.5, 1.5]), atol=1e-14)
    np.testing.assert_allclose(m.a_n, np.diag([-1.0, 1.0]), atol=1e-13)
    np.testing.assert_allclose(m.force_normal_eigenvalues, [1.5, 0.5], atol=1e-14)
    np.testing.assert_allclose(np.abs(m.force_normal_eigenvectors), np.eye(2)[:, ::-1], atol=0)
    np.testing.assert_allclose(m.a_t, 0.0, atol=1e-15)
    # binned, sectors of h = 0.1 degree: the bonds lie on sector edges, so each is seen at
    # its sector's mean direction, h/2 away: a^n is off by O(h)
    h = 2 * math.pi / 3600
    assert m.f0_binned == pytest.approx(2.0, rel=1e-14)
    np.testing.assert_allclose(m.a_n_binned, np.diag([-1.0, 1.0]), atol=2 * h)


def test_force_tensors_when_all_contacts_lie_on_one_line():
    # normals all +-x: a^r = diag(2, -2), w = 3, f0 = f/3; f_t = tau y on j gives
    # F^t_yx = tau/3 and a^t = 4 sym(F^t)/f0 with a^t_xy = 2 tau/f
    f, tau = 2.0, 0.5
    n = np.tile([1.0, 0.0], (10, 1))
    n[::2] *= -1
    ft = np.tile([0.0, tau], (10, 1))
    ft[::2] *= -1  # the same physical pair with i and j swapped
    out = force_tensors(n, np.full(10, f), ft)
    assert out.f0 == pytest.approx(f / 3)
    np.testing.assert_allclose(out.tangential, [[0, 0], [tau / 3, 0]], atol=1e-15)
    np.testing.assert_allclose(out.a_t, [[0, 2 * tau / f], [2 * tau / f, 0]], atol=1e-15)
    np.testing.assert_allclose(out.a_n, np.diag([2.0, -2.0]), atol=1e-14)


def test_chain_of_discs_one_direction_edge_case():
    x = np.column_stack([0.1 + np.arange(6) * S, np.full(6, 0.2)])
    m = analyse(positions=x, radii=np.full(6, R), core_margin=0.0)
    np.testing.assert_allclose(m.fabric, np.diag([1.0, 0.0]), atol=1e-15)
    np.testing.assert_allclose(m.fabric_eigenvalues, [1.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(m.a_r, np.diag([2.0, -2.0]), atol=1e-14)
    assert m.phi_d == pytest.approx(1.0)
    assert m.anisotropy == pytest.approx(
        {"curry": 0.5, "thornton": 1.0, "ibraim": math.inf, "maeda": m.z}
    )
    # 3D: a column along z, Phi_d = 1 and a^r = 15/2 (e e - I/3)
    x3 = np.column_stack([np.full(5, 0.3), np.full(5, 0.3), R + np.arange(5) * S])
    m3 = analyse(positions=x3, radii=np.full(5, R), core_margin=0.0)
    np.testing.assert_allclose(m3.a_r, np.diag([-2.5, -2.5, 5.0]), atol=1e-14)
    assert m3.phi_d == pytest.approx(1.0)
    np.testing.assert_allclose(np.abs(m3.fabric_eigenvectors[:, 0]), [0, 0, 1], atol=1e-15)


def test_too_anisotropic_fabric_warns_and_keeps_the_binned_estimator():
    # 40 vertical contacts and one horizontal: w = 1 + a^r_kl n_k n_l < 0 for the latter
    n = 41
    normal = np.tile([0.0, 1.0], (n, 1))
    normal[0] = [1.0, 0.0]
    c = {
        "i": np.zeros(n, int),
        "j": np.arange(1, n + 1),
        "normal": normal,
        "force_normal": np.ones(n),
        "force_tangential": np.zeros((n, 2)),
    }
    # particle 0 a unit disc, the others around it, touching it
    ang = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    ring = (1.0 + 0.99 * R) * np.column_stack([np.cos(ang), np.sin(ang)])
    x = np.vstack([[0.0, 0.0], ring])
    radii = np.array([1.0, *np.full(n, R)])
    with pytest.warns(MicrostructureWarning, match="too anisotropic"):
        m = analyse(positions=x, radii=radii, contacts=c, binned=True)
    assert math.isnan(m.f0) and np.all(np.isnan(m.a_n))
    assert m.f0_binned == pytest.approx(1.0)
    with pytest.raises(gp.GranpackError, match="too anisotropic"):
        force_tensors(normal, np.ones(n), np.zeros((n, 2)))
    assert force_tensors_binned(normal, np.ones(n), np.zeros((n, 2))).f0 == pytest.approx(1.0)


# --------------------------------------------------------------------------------------
# edge cases: a clear answer, documented warnings
# --------------------------------------------------------------------------------------
def test_no_contacts_gives_zero_z_and_nan_fabric_with_a_warning():
    x = np.array([[0.2, 0.2], [0.5, 0.5]])
    with pytest.warns(MicrostructureWarning, match="no particle-particle contacts"):
        m = analyse(positions=x, radii=[R, R], box=([0, 0], [1, 1]), core_margin=0.1)
    assert m.z == 0.0 and m.z_walls == 0.0 and math.isnan(m.z_mech)
    assert m.n_rattlers == 2
    assert np.all(np.isnan(m.fabric)) and math.isnan(m.phi_d)
    assert math.isnan(m.anisotropy["curry"])
    assert m.phi == pytest.approx(2 * math.pi * R**2 / (0.5 + R))
    row = m.to_dict()
    assert row["z"] == 0.0 and math.isnan(row["fabric_xx"])


def test_single_particle():
    with pytest.warns(MicrostructureWarning) as rec:
        m = analyse(positions=[[0.5, 0.5, R]], radii=[R], box=([0, 0, 0], [1, 1, 1]))
    messages = sorted(str(w.message).split(" ")[0] for w in rec)
    assert messages == ["core", "no"]  # empty core window (H_top = 2r) and no contacts
    assert m.n_particles == 1 and m.z == 0.0 and m.n_wall_contacts == 0
    assert m.phi == pytest.approx(4 / 3 * math.pi * R**3 / (2 * R))
    assert math.isnan(m.phi_core)
    # with no margin the window is the box and the fraction exact
    with pytest.warns(MicrostructureWarning, match="no particle-particle"):
        m0 = analyse(
            positions=[[0.5, 0.5, R]], radii=[R], box=([0, 0, 0], [1, 1, 1]), core_margin=0.0
        )
    assert m0.phi_core == pytest.approx(m0.phi, rel=1e-12)


def test_wall_only_contacts():
    x = np.column_stack([0.1 + 0.1 * np.arange(5), np.full(5, R * (1 - 1e-6))])
    with pytest.warns(MicrostructureWarning, match="no particle-particle"):
        m = analyse(positions=x, radii=np.full(5, R), box=([0, 0], [1, 1]), core_margin=0.0)
    assert m.n_wall_contacts == 5 and m.n_contacts == 0
    assert m.z == 0.0 and m.z_walls == 1.0
    assert np.all(np.isnan(m.fabric))


# --------------------------------------------------------------------------------------
# the object and its inputs
# --------------------------------------------------------------------------------------
def test_to_dict_is_flat_scalars_with_named_components():
    x = cubic_lattice(3)
    m = analyse(positions=x, radii=np.full(27, R), binned=True)
    row = m.to_dict()
    assert all(isinstance(v, bool | int | float) for v in row.values())
    for key in (
        "fabric_xx",
        "fabric_xz",
        "a_r_yz",
        "fabric_eig3",
        "z_athanasiou",
        "phi_d",
        "force_tangential_zx",
        "a_t_xy",
        "f0_binned",
        "a_n_binned_zz",
    ):
        assert key in row
    assert row["fabric_eig1"] == pytest.approx(1 / 3)
    m2 = analyse(positions=square_lattice(3), radii=np.full(9, R))
    row2 = m2.to_dict()
    assert "fabric_zz" not in row2 and "fabric_yy" in row2 and "f0_binned" not in row2
    assert m2.f0_binned is None
    assert m2.z_empirical["athanasiou"] == pytest.approx(3 * (1 + m2.void_ratio) / m2.void_ratio)
    assert "Microstructure(dim=2" in repr(m2)
    with pytest.raises(ValueError):
        m2.fabric[0, 0] = 1.0  # read-only


def test_generated_pack_forces_and_geometric_contacts_agree(tiny_scene_2d):
    # the paper's full 1 s per layer: the gravity check below needs a pack at rest
    # (after 0.3 s the last layer still bounces and a_n can take either sign)
    pack = gp.generate(tiny_scene_2d.replace(settle_time=1.0))
    m = gp.microstructure(pack, binned=True, core_margin=0.02)
    assert isinstance(m, Microstructure) and m.has_forces
    assert m.f0 > 0 and m.f0_binned > 0
    assert np.trace(m.a_n) == pytest.approx(0.0, abs=1e-12)
    # same particles without the contact table: the Rust grid finds the same pairs
    geo = analyse(positions=pack.positions, radii=pack.radii, box=pack.box, core_margin=0.02)
    assert geo.n_contacts == m.n_contacts and geo.n_wall_contacts == m.n_wall_contacts
    np.testing.assert_allclose(geo.fabric, m.fabric, atol=1e-12)
    assert geo.phi == pytest.approx(pack.phi, rel=1e-12)
    assert not geo.has_forces and math.isnan(geo.f0)
    # gravity loads vertical contacts harder than horizontal ones
    assert m.a_n[1, 1] > 0


def test_the_entry_point_does_not_shadow_the_analysis_package():
    import importlib
    import types

    assert isinstance(gp.analysis, types.ModuleType)
    assert gp.microstructure is gp.analysis.microstructure
    assert gp.analysis.read_xyzr is read_xyzr
    assert gp.analysis.Microstructure is Microstructure
    # no module is hidden behind a function of the same name
    for name in ("compute", "result", "tensors", "volumes", "reader", "relations", "inputs"):
        mod = importlib.import_module(f"granpack.analysis.{name}")
        assert getattr(gp.analysis, name) is mod


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"positions": np.zeros((3, 4)), "radii": np.ones(3)}, "positions"),
        ({"positions": np.zeros((0, 2)), "radii": np.ones(0)}, "positions"),
        ({"positions": np.zeros((3, 2)), "radii": np.ones(2)}, "radii"),
        ({"positions": np.zeros((2, 2)), "radii": [0.1, -1.0]}, r"radii\[1\]"),
        ({"positions": [[0, 0], [np.nan, 0]], "radii": [1, 1]}, "positions"),
        ({"positions": [[0.5, 0.5]], "radii": [0.1], "box": ([0, 0], [-1, 1])}, "box"),
        ({"positions": [[0.5, 0.5]], "radii": [0.1], "box": 3}, "box"),
        ({"positions": [[0.5, 0.5]], "radii": [0.1], "core_margin": -1}, "core_margin"),
        ({"positions": [[0.5, 0.5]], "radii": [0.1], "binned": True, "n_bins": 0}, "n_bins"),
        ({"positions": [[0.5, 0.5]], "radii": [0.1], "contacts": 5}, "contacts"),
        (
            {
                "positions": [[0.5, 0.5]],
                "radii": [0.1],
                "contacts": {"i": [0], "j": [7], "normal": [[1.0, 0.0]]},
            },
            "contacts.j",
        ),
        (
            {
                "positions": [[0.5, 0.5], [0.6, 0.5]],
                "radii": [0.1, 0.1],
                "contacts": {
                    "i": [0],
                    "j": [1],
                    "normal": [[1.0, 0.0]],
                    "force_normal": [-1.0],
                    "force_tangential": [[0.0, 0.0]],
                },
            },
            "force_normal",
        ),
        ({"positions": [[1.5, 0.5]], "radii": [0.1], "box": ([0, 0], [1, 1])}, "outside"),
        ({"radii": [0.1]}, "positions"),
        ({"positions": [[0.1, 0.1], [0.1, 0.1]], "radii": [0.01, 0.01]}, "not a valid pack"),
    ],
)
def test_bad_input_is_a_granpack_error_naming_the_parameter(kwargs, match):
    with pytest.raises(gp.GranpackError, match=match):
        gp.microstructure(**kwargs)


def test_pack_and_arrays_are_exclusive(tiny_scene_2d):
    pack = gp.generate(tiny_scene_2d)
    with pytest.raises(gp.GranpackError, match="either pack"):
        gp.microstructure(pack, positions=pack.positions)


# --------------------------------------------------------------------------------------
# x y z r files
# --------------------------------------------------------------------------------------
def test_read_xyzr_formats(tmp_path):
    f3 = tmp_path / "a.txt"
    f3.write_text("# x y z r\n0.1 0.2 0.3 0.01\n\n0.4, 0.5, 0.6, 0.02  # trailing\n")
    x, r, d = read_xyzr(f3)
    assert d == 3 and x.shape == (2, 3) and x.flags.c_contiguous
    np.testing.assert_array_equal(r, [0.01, 0.02])
    f2 = tmp_path / "b.txt"
    f2.write_text("0.1 0.2 0 0.01\n0.3 0.4 0 0.01\n")
    x, r, d = read_xyzr(f2)
    assert d == 2 and x.tolist() == [[0.1, 0.2], [0.3, 0.4]]
    f2z = tmp_path / "c.txt"
    f2z.write_text("0.1 0 0.2 0.01\n0.3 0 0.4 0.01\n")
    assert read_xyzr(f2z)[0].tolist() == [[0.1, 0.2], [0.3, 0.4]]
    assert read_xyzr(f2, dim=3)[2] == 3
    f_three = tmp_path / "d.txt"
    f_three.write_text("0.1 0.2 0.01\n")
    assert read_xyzr(f_three)[2] == 2


@pytest.mark.parametrize(
    ("text", "dim", "match"),
    [
        ("0.1 0.2 0.3 0.01\n0.1 0.2 0.3\n", None, r":2: expected 4 numbers"),
        ("# c\n0.1 0.2 0.3 abc\n", None, r":2: 'abc' is not a number"),
        ("0.1 0.2 0.3 0.01\n\n0.1 0.2 0.3 -0.01\n", None, r":3: radius"),
        ("0.1 0.2 0.3 nan\n", None, r":1: non-finite"),
        ("0.1 0.2\n", None, r":1: expected 4 numbers"),
        ("# only a comment\n", None, "no particles"),
        ("0.1 0.2 0.3 0.01\n", 2, "all-zero"),
        ("0.1 0.2 0.01\n", 3, "four columns"),
    ],
)
def test_read_xyzr_errors_name_the_line(tmp_path, text, dim, match):
    f = tmp_path / "bad.txt"
    f.write_text(text)
    with pytest.raises(gp.GranpackError, match=match):
        read_xyzr(f, dim=dim)


def test_read_xyzr_missing_file(tmp_path):
    with pytest.raises(gp.GranpackError, match="no such file"):
        read_xyzr(tmp_path / "nope.txt")


def test_phi_centres_measures_the_height_at_the_highest_centre():
    """Two discs stacked on the floor (touching, overlap 1e-6 m): H_top = 4 r, highest
    centre at 3 r."""
    r = 0.1
    x = np.array([[0.5, r], [0.5, 3 * r - 1e-6]])
    m = gp.microstructure(positions=x, radii=[r, r], box=([0.0, 0.0], [1.0, 1.0]), core_margin=0.0)
    area = 2 * np.pi * r * r
    assert m.phi == pytest.approx(area / (1.0 * (4 * r - 1e-6)))
    assert m.phi_centres == pytest.approx(area / (1.0 * (3 * r - 1e-6)))


def test_the_volumes_in_the_window_do_not_depend_on_the_quadrature_block(monkeypatch):
    """The sphere-box and sphere-cylinder quadratures go a block of spheres at a time; each
    sphere's volume is the same to the bit in blocks of 3 as in one block, and the
    volumes of spheres wholly inside are whole."""
    from granpack.analysis import volumes

    rng = np.random.default_rng(11)
    x = rng.uniform(0.0, 1.0, (700, 3))
    r = rng.uniform(0.02, 0.12, 700)
    lo, hi = np.array([0.1, 0.15, 0.2]), np.array([0.9, 0.8, 0.85])
    one_block = volumes.window_volumes(x, r, lo, hi)
    one_cyl = volumes.cylinder_volumes(x, r, (0.5, 0.5), 0.4, 0.2, 0.85)
    monkeypatch.setattr(volumes, "_QUAD_ROWS", 3)
    np.testing.assert_array_equal(volumes.window_volumes(x, r, lo, hi), one_block)
    np.testing.assert_array_equal(
        volumes.cylinder_volumes(x, r, (0.5, 0.5), 0.4, 0.2, 0.85), one_cyl
    )
    inside = np.all((x - r[:, None] >= lo) & (x + r[:, None] <= hi), axis=1)
    np.testing.assert_allclose(one_block[inside], 4.0 / 3.0 * np.pi * r[inside] ** 3, rtol=1e-15)
    cut = ~inside & (one_block > 0)
    assert 100 < np.sum(cut) and np.all(one_block[cut] < 4.0 / 3.0 * np.pi * r[cut] ** 3)
