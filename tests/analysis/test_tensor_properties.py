"""Tensor identities of the fabric and contact-force estimators (hypothesis), and their
statistics on normals and forces drawn from the paper's model densities (fixed seeds,
tolerances of 5 standard errors)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from granpack import GranpackError
from granpack.analysis import (
    anisotropy_measures,
    anisotropy_tensor,
    eigen_sorted,
    empirical_z,
    fabric_tensor,
    force_tensors,
    force_tensors_binned,
    phi_d,
    phi_from_void_ratio,
    void_ratio,
)

SETTINGS = settings(max_examples=60, deadline=None)
COEF = {2: 4.0, 3: 7.5}


# --------------------------------------------------------------------------------------
# strategies
# --------------------------------------------------------------------------------------
def unit_rows(v: np.ndarray) -> np.ndarray:
    """Rows scaled to unit length; a (near-)zero row becomes the first axis."""
    v = v.copy()
    small = np.linalg.norm(v, axis=1) < 1e-3
    v[small] = 0.0
    v[small, 0] = 1.0
    return v / np.linalg.norm(v, axis=1)[:, None]


coords = st.floats(-1.0, 1.0, allow_nan=False, allow_subnormal=False)


@st.composite
def contact_sets(draw, dim=None, max_m=40):
    """(normals (M, D), normal forces (M,) > 0, tangential forces (M, D))."""
    d = draw(st.sampled_from([2, 3])) if dim is None else dim
    m = draw(st.integers(1, max_m))
    n = unit_rows(draw(arrays(np.float64, (m, d), elements=coords)))
    fn = draw(arrays(np.float64, (m,), elements=st.floats(0.01, 10.0)))
    ft = draw(arrays(np.float64, (m, d), elements=st.floats(-5.0, 5.0)))
    return n, fn, ft


@st.composite
def rotations(draw, dim):
    if dim == 2:
        a = draw(st.floats(0.0, 2 * math.pi))
        return np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    q = np.array(draw(st.lists(coords, min_size=4, max_size=4)))
    if np.linalg.norm(q) < 0.1:
        q[0] += 1.0
    w, x, y, z = q / np.linalg.norm(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


@st.composite
def rotated_contact_sets(draw):
    d = draw(st.sampled_from([2, 3]))
    return (*draw(contact_sets(dim=d)), draw(rotations(d)))


def bin_free_or_skip(n, fn, ft):
    """The bin-free tensors, for contact sets whose weights 1/w_c are well conditioned.

    w_c = 1 + a^r_kl n_k n_l <= 0 (a fabric too anisotropic for the second-order density)
    is an error, tested elsewhere; near 0 the weights amplify rounding without bound, so
    identities that hold to rounding are checked where w_c >= 0.05.
    """
    d = n.shape[1]
    a_r = anisotropy_tensor(fabric_tensor(n))
    assume(np.min(1 + np.einsum("ci,ij,cj->c", n, a_r, n)) >= 0.05)
    try:
        return force_tensors(n, fn, ft)
    except GranpackError:  # pragma: no cover - excluded by the assumption above
        raise AssertionError(f"bin-free estimator refused a well-conditioned {d}D set") from None


# --------------------------------------------------------------------------------------
# identities
# --------------------------------------------------------------------------------------
@SETTINGS
@given(contact_sets())
def test_fabric_is_symmetric_psd_with_unit_trace(c):
    n, _, _ = c
    r = fabric_tensor(n)
    assert np.trace(r) == pytest.approx(1.0, abs=1e-14)
    np.testing.assert_allclose(r, r.T, atol=1e-16)
    assert np.linalg.eigvalsh(r).min() >= -1e-15
    w, v = eigen_sorted(r)
    assert np.all(np.diff(w) <= 1e-15)
    assert w.sum() == pytest.approx(1.0, abs=1e-14)
    assert np.all((w >= -1e-15) & (w <= 1 + 1e-15))
    np.testing.assert_allclose(v @ np.diag(w) @ v.T, r, atol=1e-14)
    np.testing.assert_allclose(v.T @ v, np.eye(len(w)), atol=1e-14)
    assert 0.0 <= phi_d(np.clip(w, 0, 1)) <= 1.0 + 1e-14


@SETTINGS
@given(contact_sets(), st.data())
def test_estimators_ignore_contact_orientation_and_order(c, data):
    n, fn, ft = c
    m = len(fn)
    flip = np.where(data.draw(arrays(np.bool_, (m,))), -1.0, 1.0)[:, None]
    perm = np.array(data.draw(st.permutations(range(m))))
    # swapping i and j reverses the normal and the tangential force on "j"
    n2, fn2, ft2 = (n * flip)[perm], fn[perm], (ft * flip)[perm]
    np.testing.assert_allclose(fabric_tensor(n2), fabric_tensor(n), atol=1e-15)
    a, b = force_tensors_binned(n, fn, ft, 7), force_tensors_binned(n2, fn2, ft2, 7)
    assert b.f0 == pytest.approx(a.f0, rel=1e-13)
    np.testing.assert_allclose(b.normal, a.normal, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(b.tangential, a.tangential, rtol=1e-12, atol=1e-13)
    a, b = bin_free_or_skip(n, fn, ft), force_tensors(n2, fn2, ft2)
    assert b.f0 == pytest.approx(a.f0, rel=1e-12)
    np.testing.assert_allclose(b.normal, a.normal, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(b.tangential, a.tangential, rtol=1e-12, atol=1e-13)


@SETTINGS
@given(rotated_contact_sets())
def test_tensors_rotate_with_the_contacts(c):
    n, fn, ft, q = c
    nq, ftq = n @ q.T, ft @ q.T
    r, rq = fabric_tensor(n), fabric_tensor(nq)
    np.testing.assert_allclose(rq, q @ r @ q.T, atol=1e-14)
    np.testing.assert_allclose(eigen_sorted(rq)[0], eigen_sorted(r)[0], atol=1e-14)
    assert phi_d(eigen_sorted(rq)[0]) == pytest.approx(phi_d(eigen_sorted(r)[0]), abs=1e-7)
    a, b = bin_free_or_skip(n, fn, ft), force_tensors(nq, fn, ftq)
    assert b.f0 == pytest.approx(a.f0, rel=1e-12)
    for name in ("normal", "tangential", "a_n", "a_t"):
        ta, tb = getattr(a, name), getattr(b, name)
        scale = 1 + np.abs(ta).max()
        np.testing.assert_allclose(tb, q @ ta @ q.T, atol=1e-12 * scale)


@SETTINGS
@given(contact_sets())
def test_anisotropy_tensors_are_traceless(c):
    n, fn, ft = c
    d = n.shape[1]
    a_r = anisotropy_tensor(fabric_tensor(n))
    assert np.trace(a_r) == pytest.approx(0.0, abs=1e-13)
    np.testing.assert_allclose(a_r, COEF[d] * (fabric_tensor(n) - np.eye(d) / d), atol=1e-14)
    binned = force_tensors_binned(n, fn, ft)
    free = bin_free_or_skip(n, fn, ft)
    for t in (binned, free):
        assert np.trace(t.a_n) == pytest.approx(0.0, abs=1e-12)
        assert np.trace(t.a_t) == pytest.approx(0.0, abs=1e-12)
        np.testing.assert_allclose(t.a_t, t.a_t.T, atol=0)
        assert np.trace(t.normal) == pytest.approx(t.f0, rel=1e-12)
    assert np.trace(free.tangential) == pytest.approx(0.0, abs=1e-12 * np.abs(ft).max() + 1e-15)


@SETTINGS
@given(rotations(3), rotations(2))
def test_phi_d_vanishes_for_isotropic_fabric(q3, q2):
    # the six (four) lattice directions, rotated: R = I/D exactly in any orientation
    n3 = np.concatenate([np.eye(3), -np.eye(3)]) @ q3.T
    w3, _ = eigen_sorted(fabric_tensor(n3))
    assert phi_d(w3) == pytest.approx(0.0, abs=1e-7)
    np.testing.assert_allclose(anisotropy_tensor(fabric_tensor(n3)), 0.0, atol=1e-14)
    n2 = np.concatenate([np.eye(2), -np.eye(2)]) @ q2.T
    w2, _ = eigen_sorted(fabric_tensor(n2))
    assert phi_d(w2) == pytest.approx(0.0, abs=1e-14)
    meas = anisotropy_measures(w2, z=4.0)
    assert meas["ibraim"] == pytest.approx(1.0)
    assert meas["thornton"] == pytest.approx(0.0, abs=1e-14)


@SETTINGS
@given(arrays(np.float64, (3,), elements=st.floats(0.0, 1.0)), st.floats(0.0, 12.0))
def test_table1_measures_relations(w, z):
    w = np.sort(w)[::-1]
    meas = anisotropy_measures(w, z)
    assert meas["thornton"] == pytest.approx(2 * meas["curry"])
    assert meas["maeda"] == pytest.approx(z * meas["thornton"])
    assert meas["ibraim"] >= 1.0
    # Phi_d is the root-mean-square of the pairwise gaps; it lies between them
    assert meas["thornton"] - 1e-15 <= phi_d(w) * math.sqrt(2) + 1e-15
    assert phi_d(w) <= meas["thornton"] + 1e-15


@SETTINGS
@given(st.floats(1e-3, 1 - 1e-3))
def test_void_ratio_and_phi_round_trip(phi):
    e = void_ratio(phi)
    assert e == pytest.approx((1 - phi) / phi, rel=1e-15)
    assert phi_from_void_ratio(e) == pytest.approx(phi, rel=1e-14)
    assert void_ratio(phi_from_void_ratio(e)) == pytest.approx(e, rel=1e-12)


def test_empirical_z_reproduces_a_paper_row():
    z = empirical_z(0.171)  # Table 3, pack 1
    assert [round(z[k], 3) for k in ("field", "athanasiou", "yanagisawa", "chang")] == [
        10.248,
        20.544,
        14.306,
        11.912,
    ]
    arr = empirical_z(np.array([0.171, 0.787]))
    np.testing.assert_allclose(arr["athanasiou"], [20.544, 6.812], atol=5e-4)
    assert empirical_z(0.0)["athanasiou"] == math.inf


# --------------------------------------------------------------------------------------
# statistics: samples from the model densities
# --------------------------------------------------------------------------------------
def random_traceless(rng, d, largest):
    b = rng.normal(size=(d, d))
    b = (b + b.T) / 2
    b -= np.trace(b) / d * np.eye(d)
    return largest * b / np.abs(np.linalg.eigvalsh(b)).max()


def uniform_directions(rng, m, d):
    v = rng.normal(size=(m, d))
    return v / np.linalg.norm(v, axis=1)[:, None]


def sample_normals(rng, m, a):
    """Normals with density E(n) = (1 + a_ij n_i n_j)/(4 pi) (2D: /(2 pi)), by rejection."""
    d = a.shape[0]
    top = 1 + np.linalg.eigvalsh(a).max()
    out, k = [], 0
    while k < m:
        n = uniform_directions(rng, 2 * m, d)
        keep = n[rng.uniform(0, top, len(n)) < 1 + np.einsum("ci,ij,cj->c", n, a, n)]
        out.append(keep)
        k += len(keep)
    return np.concatenate(out)[:m]


def model_forces(rng, n, a_n, a_t, f0=1.0, noise=True):
    """f^n = f0 (1 + a^n_ij n_i n_j) and f^t = f0 (a^t_ij n_j - a^t_kl n_k n_l n_i) on
    average, with a Gamma(4) factor on f^n and a zero-mean tangential scatter."""
    fn = f0 * (1 + np.einsum("ci,ij,cj->c", n, a_n, n))
    ft = f0 * (n @ a_t - np.einsum("ci,ij,cj->c", n, a_t, n)[:, None] * n)
    if noise:
        fn = fn * rng.gamma(4.0, 0.25, len(fn))
        extra = rng.normal(scale=0.3 * f0, size=n.shape)
        ft = ft + extra - np.sum(extra * n, axis=1)[:, None] * n
        # random labelling of i and j
        flip = np.where(rng.uniform(size=len(fn)) < 0.5, -1.0, 1.0)[:, None]
        n, ft = n * flip, ft * flip
    return n, fn, ft


def batch_se(estimate, n, fn, ft, k=20):
    """Standard error of an estimator from k interleaved batches."""
    vals = np.array([estimate(n[i::k], fn[i::k], ft[i::k]) for i in range(k)])
    return vals.std(axis=0, ddof=1) / math.sqrt(k)


def quadrature_directions(d, fine):
    """Equal-weight midpoints of `fine` equal-area cells of the circle/sphere (2D: angles;
    3D: fine bands in z x 2 fine sectors): a noise-free stand-in for a uniform sample, whose
    cells nest inside the estimator's groups for any n_bins dividing `fine`."""
    if d == 2:
        t = -math.pi + 2 * math.pi * (np.arange(fine) + 0.5) / fine
        return np.column_stack([np.cos(t), np.sin(t)])
    z = -1 + 2 * (np.arange(fine) + 0.5) / fine
    p = -math.pi + 2 * math.pi * (np.arange(2 * fine) + 0.5) / (2 * fine)
    zz, pp = np.meshgrid(z, p, indexing="ij")
    s = np.sqrt(1 - zz**2)
    return np.column_stack([(s * np.cos(pp)).ravel(), (s * np.sin(pp)).ravel(), zz.ravel()])


@pytest.mark.parametrize("d", [2, 3])
def test_isotropic_normals_give_anisotropy_within_sampling_error(d):
    rng = np.random.default_rng(11 + d)
    m = 20_000
    a_r = anisotropy_tensor(fabric_tensor(uniform_directions(rng, m, d)))
    # Var(n_x^2) = 4/45, Var(n_x n_y) = 1/15 on the sphere; 1/8 for both on the circle
    var_diag, var_off = (1 / 8, 1 / 8) if d == 2 else (4 / 45, 1 / 15)
    se = COEF[d] * np.sqrt(np.where(np.eye(d, dtype=bool), var_diag, var_off) / m)
    assert np.all(np.abs(a_r) < 5 * se)


@pytest.mark.parametrize("d", [2, 3])
def test_fabric_recovers_the_anisotropy_of_the_normal_density(d):
    rng = np.random.default_rng(21 + d)
    a = random_traceless(rng, d, 0.6)
    n = sample_normals(rng, 40_000, a)
    est = anisotropy_tensor(fabric_tensor(n))
    # E[c n_i n_j] = c (delta_ij/D + 2 a_ij/(D (D + 2))) = c delta_ij/D + a_ij
    se = COEF[d] * np.einsum("ci,cj->ijc", n, n).std(axis=2, ddof=1) / math.sqrt(len(n))
    assert np.all(np.abs(est - a) < 5 * se)


@pytest.mark.parametrize("d", [2, 3])
def test_bin_free_estimator_recovers_the_force_anisotropies(d):
    rng = np.random.default_rng(31 + d)
    a_r = random_traceless(rng, d, 0.5)
    a_n = random_traceless(rng, d, 0.6)
    a_t = random_traceless(rng, d, 0.4)
    n, fn, ft = model_forces(rng, sample_normals(rng, 60_000, a_r), a_n, a_t, f0=2.0)
    est = force_tensors(n, fn, ft)

    def pack(*c):
        out = force_tensors(*c)
        return np.concatenate([[out.f0], out.a_n.ravel(), out.a_t.ravel()])

    se = batch_se(pack, n, fn, ft)
    got = np.concatenate([[est.f0], est.a_n.ravel(), est.a_t.ravel()])
    want = np.concatenate([[2.0], a_n.ravel(), a_t.ravel()])
    assert np.all(np.abs(got - want) <= 5 * se + 1e-12)


@pytest.mark.parametrize("d", [2, 3])
def test_binned_estimator_converges_at_second_order_noise_free(d):
    # Exact model forces on an equal-weight quadrature set: no sampling noise, so what is
    # left is the discretisation of the binned estimator (and ~1e-5 of quadrature error).
    rng = np.random.default_rng(41 + d)
    a_n = random_traceless(rng, d, 0.6)
    a_t = random_traceless(rng, d, 0.4)
    n = quadrature_directions(d, 96_000 if d == 2 else 240)
    n, fn, ft = model_forces(rng, n, a_n, a_t, noise=False)
    free = force_tensors(n, fn, ft)
    assert free.f0 == pytest.approx(1.0, abs=1e-4)
    np.testing.assert_allclose(free.a_n, a_n, atol=1e-4)
    np.testing.assert_allclose(free.a_t, a_t, atol=1e-4)
    levels = [6, 12, 24, 48] if d == 2 else [3, 6, 12, 24]
    errors = []
    for nb in levels:
        b = force_tensors_binned(n, fn, ft, nb)
        errors.append(max(np.abs(b.a_n - a_n).max(), np.abs(b.a_t - a_t).max()))
        if d == 2:
            # isotropic fabric: the sector means and moments each smooth cos 2 theta by
            # sinc(h), so E[a^n_binned] = a^n (sin h / h)^2 exactly
            h = 2 * math.pi / nb
            np.testing.assert_allclose(b.a_n, a_n * (math.sin(h) / h) ** 2, atol=1e-6)
    ratios = np.array(errors[:-1]) / np.array(errors[1:])
    assert np.all(ratios > 3.0), (errors, ratios)  # 4 for an O(h^2) error


@pytest.mark.parametrize("d", [2, 3])
def test_binned_estimator_on_samples_matches_its_noise_free_value(d):
    # the binned estimator on a sample is unbiased for its own (discretised) continuum value
    rng = np.random.default_rng(51 + d)
    a_n = random_traceless(rng, d, 0.6)
    a_t = random_traceless(rng, d, 0.4)
    nb = 36 if d == 2 else 6
    q = quadrature_directions(d, 36_000 if d == 2 else 240)
    exact = force_tensors_binned(*model_forces(rng, q, a_n, a_t, noise=False), nb)
    n, fn, ft = model_forces(rng, uniform_directions(rng, 60_000, d), a_n, a_t)
    est = force_tensors_binned(n, fn, ft, nb)

    def pack(*c):
        out = force_tensors_binned(*c, nb)
        return np.concatenate([[out.f0], out.a_n.ravel(), out.a_t.ravel()])

    se = batch_se(pack, n, fn, ft)
    got = np.concatenate([[est.f0], est.a_n.ravel(), est.a_t.ravel()])
    want = np.concatenate([[exact.f0], exact.a_n.ravel(), exact.a_t.ravel()])
    assert np.all(np.abs(got - want) <= 5 * se + 1e-12)


@pytest.mark.parametrize("d", [2, 3])
def test_binned_estimator_approaches_bin_free_as_groups_are_refined(d):
    rng = np.random.default_rng(61 + d)
    a_r = random_traceless(rng, d, 0.5)
    a_n = random_traceless(rng, d, 0.6)
    a_t = random_traceless(rng, d, 0.4)
    n, fn, ft = model_forces(rng, sample_normals(rng, 200_000, a_r), a_n, a_t)
    free = force_tensors(n, fn, ft)
    diffs = []
    for nb in [8, 16, 32] if d == 2 else [4, 8, 16]:
        b = force_tensors_binned(n, fn, ft, nb)
        diffs.append(max(np.abs(b.a_n - free.a_n).max(), np.abs(b.a_t - free.a_t).max()))
    ratios = np.array(diffs[:-1]) / np.array(diffs[1:])
    # second order (4 per halving of the groups), well above first order (2)
    assert np.all(ratios > 2.5), (diffs, ratios)
