"""The analysis' contact search (granpack._core.find_contacts, the engine's size-ratio
search) finds exactly the brute-force contacts when one particle is hundreds of times
larger than the others: in a box, and in a periodic cell wider than four large radii that
the small ones leave mostly empty (the search then treats the axis as bounded), with the
cluster across the seam or not."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from granpack import _core


def brute_force(x, r, period=None):
    """Pairs (i < j) with |x_j - x_i| < r_i + r_j, by minimum image along the periods (in
    row blocks, to bound the memory)."""
    out = set()
    for a in range(0, len(x), 256):
        d = x[None, :, :] - x[a : a + 256, None, :]
        if period is not None:
            for k, p in enumerate(period):
                if p:
                    d[:, :, k] -= p * np.round(d[:, :, k] / p)
        near = np.sqrt(np.sum(d * d, axis=-1)) < r[a : a + 256, None] + r[None, :]
        i, j = np.nonzero(near)
        i = i + a
        out |= {(p, q) for p, q in zip(i.tolist(), j.tolist(), strict=True) if p < q}
    return out


def pack(seed: int, n: int, ratio: float, at: float, dim: int):
    """n spheres of radius 0.01 in a jittered cube lattice resting on one of radius
    0.01 ratio, the cluster's corner at a fraction `at` of a period of 4.5 large radii."""
    rng = np.random.default_rng(seed)
    big = 0.01 * ratio
    period = 4.5 * big
    side = int(np.ceil(n ** (1 / dim)))
    g = np.stack(np.meshgrid(*[np.arange(side)] * dim, indexing="ij"), -1).reshape(-1, dim)[:n]
    x = g * 0.0199 + rng.uniform(-2e-3, 2e-3, g.shape)
    x[:, :-1] += at * period
    x[:, -1] += 2 * big + 0.0099
    centre = np.array([*(x[:, :-1].mean(axis=0)), big])
    x = np.vstack([x, centre])
    r = np.append(rng.uniform(0.009, 0.011, n), big)
    return x, r, period


@settings(max_examples=25, deadline=None)
@given(
    seed=st.integers(0, 2**31 - 1),
    n=st.integers(2, 2500),
    ratio=st.floats(16.0, 1000.0),
    at=st.floats(0.0, 1.0),
    dim=st.sampled_from([2, 3]),
)
def test_one_large_sphere_among_small_ones_gives_the_brute_force_contacts(seed, n, ratio, at, dim):
    x, r, period = pack(seed, n, ratio, at, dim)
    lo = [0.0] * dim
    hi = [period] * (dim - 1) + [10.0 * period]
    c = _core.find_contacts(x, r)
    pairs = set(zip(c["i"].tolist(), c["j"].tolist(), strict=True))
    assert pairs == brute_force(x, r)
    flags = [True] * (dim - 1)
    per = [period] * (dim - 1) + [0.0]
    xw = x.copy()
    xw[:, :-1] = np.mod(xw[:, :-1], period)
    c = _core.find_contacts(xw, r, walls=(lo, hi), periodic=flags)
    pairs = {(int(a), int(b)) for a, b in zip(c["i"], c["j"], strict=True) if b >= 0}
    assert pairs == brute_force(xw, r, per)


@pytest.mark.parametrize("periodic", [False, True])
def test_a_large_sphere_under_a_few_thousand_small_ones(periodic):
    x, r, period = pack(7, 3000, 1000.0, 0.98 if periodic else 0.3, 3)
    lo, hi = [0.0, 0.0, 0.0], [period, period, 10.0 * period]
    kw = {"periodic": [True, True]} if periodic else {}
    if periodic:
        x[:, :2] = np.mod(x[:, :2], period)
    c = _core.find_contacts(x, r, walls=(lo, hi), **kw)
    pairs = {(int(a), int(b)) for a, b in zip(c["i"], c["j"], strict=True) if b >= 0}
    expect = brute_force(x, r, [period, period, 0.0] if periodic else None)
    assert pairs == expect
    assert any(b == len(r) - 1 for _, b in expect)  # the large one has contacts
