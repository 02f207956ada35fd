"""Packs made by other DEM codes (LIGGGHTS 3D, LAMMPS 2D; shared/peers/): granpack reads
them, finds their contacts with the Rust grid and agrees with the numbers the peers'
independent script (shared/peers/analyze_dump.py) printed in shared/peers/README.md."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import granpack as gp
from granpack.analysis import read_xyzr

PEERS = Path(__file__).resolve().parents[2].parent / "shared" / "peers"

#: From the table in shared/peers/README.md (phi_bulk, phi_core, Z), with the number of
#: decimals printed there. Box: side walls at 0 and L = 1 m, floor at 0, core margin 0.1 m.
CASES = {
    "liggghts_3d": ("liggghts/pack3d_final_xyzr.txt", 3, 8952, (0.553, 3), (0.614, 3), (5.01, 2)),
    "lammps_2d": ("lammps/pack2d_final_xyr.txt", 2, 1397, (0.841, 3), (0.874, 3), (5.23, 2)),
}

pytestmark = pytest.mark.skipif(
    not PEERS.is_dir(), reason=f"peer packs not present (expected in {PEERS})"
)


def load(case):
    path, dim, n, *_ = CASES[case]
    f = PEERS / path
    if not f.is_file():
        pytest.skip(f"peer pack {f} not present")
    x, r, d = read_xyzr(f)
    assert d == dim and len(r) == n
    box = ([0.0] * dim, [1.0] * (dim - 1) + [math.inf])
    return x, r, box


@pytest.fixture(scope="module", params=list(CASES))
def peer(request):
    x, r, box = load(request.param)
    return request.param, x, r, box, gp.microstructure(positions=x, radii=r, box=box)


def test_phi_and_z_agree_with_the_peers_script(peer):
    case, _, _, _, m = peer
    _, _, _, (phi, dp), (core, dc), (z, dz) = CASES[case]
    assert round(m.phi, dp) == phi
    assert round(m.phi_core_centres, dc) == core
    assert round(m.z, dz) == z
    assert not m.has_forces and math.isnan(m.f0)  # positions only: no forces, no warning


def test_exact_core_fraction_agrees_with_monte_carlo(peer):
    # random points in the core window, covered if inside some particle; 5 binomial SE
    _, x, r, _, m = peer
    d = x.shape[1]
    lo, hi = m.box
    wlo, whi = lo + 0.1, hi - 0.1
    rng = np.random.default_rng(3)
    pts = rng.uniform(wlo, whi, size=(6000, d))
    near = np.all((x + r[:, None] >= wlo) & (x - r[:, None] <= whi), axis=1)
    xs, rs = x[near], r[near]
    covered = np.zeros(len(pts), dtype=bool)
    for k in range(0, len(rs), 500):
        d2 = np.sum((pts[:, None, :] - xs[None, k : k + 500]) ** 2, axis=2)
        covered |= np.any(d2 < rs[None, k : k + 500] ** 2, axis=1)
    p = covered.mean()
    se = math.sqrt(p * (1 - p) / len(pts))
    assert m.phi_core == pytest.approx(p, abs=5 * se)


def test_grid_contacts_match_a_brute_force_search(peer):
    _, x, r, box, m = peer
    d = x.shape[1]
    # a block of the pack: all pairs with both centres inside it, by brute force
    sub = np.flatnonzero(np.all((x[:, : d - 1] > 0.3) & (x[:, : d - 1] < 0.6), axis=1))
    xs, rs = x[sub], r[sub]
    dist = np.sqrt(np.sum((xs[:, None, :] - xs[None, :, :]) ** 2, axis=2))
    ii, jj = np.nonzero(np.triu(dist < rs[:, None] + rs[None, :], k=1))
    brute = {(int(sub[a]), int(sub[b])) for a, b in zip(ii, jj, strict=True)}
    found = gp._core.find_contacts(x, r, walls=None)
    c = gp.Contacts.from_dict(found).particle_pairs()
    insub = np.isin(c.i, sub) & np.isin(c.j, sub)
    grid = {
        (min(a, b), max(a, b))
        for a, b in zip(c.i[insub].tolist(), c.j[insub].tolist(), strict=True)
    }
    assert len(brute) > 100
    assert grid == brute
    # normals and overlaps of those contacts
    k = np.flatnonzero(insub)
    dx = x[c.j[k]] - x[c.i[k]]
    np.testing.assert_allclose(c.normal[k], dx / np.linalg.norm(dx, axis=1)[:, None], atol=1e-12)
    np.testing.assert_allclose(
        c.overlap[k], r[c.i[k]] + r[c.j[k]] - np.linalg.norm(dx, axis=1), atol=1e-12
    )
    # wall contacts: centre closer to a side wall or the floor than its radius
    lo, hi = np.zeros(d), np.ones(d)
    walls = np.sum(x - r[:, None] < lo, axis=1) + np.sum(x[:, :-1] + r[:, None] > hi[:-1], axis=1)
    assert m.n_wall_contacts == int(walls.sum())
    assert m.z_walls == pytest.approx((2 * m.n_contacts + walls.sum()) / len(r), rel=1e-15)


def test_block_of_a_peer_pack_matches_a_numpy_oracle(peer):
    # Z, Z_m, fabric and Phi_d of a block of the pack, from brute-force pairs
    _, x, r, _, _ = peer
    d = x.shape[1]
    sub = np.all((x[:, : d - 1] > 0.25) & (x[:, : d - 1] < 0.75), axis=1) & (x[:, -1] < 0.3)
    xs, rs = x[sub], r[sub]
    m = gp.microstructure(positions=xs, radii=rs, core_margin=0.05)
    diff = xs[None, :, :] - xs[:, None, :]
    dist = np.sqrt(np.sum(diff**2, axis=2))
    ii, jj = np.nonzero(np.triu(dist < rs[:, None] + rs[None, :], k=1))
    n_c, n_p = len(ii), len(rs)
    assert m.n_contacts == n_c
    assert m.z == pytest.approx(2 * n_c / n_p, rel=1e-15)
    deg = np.bincount(np.concatenate([ii, jj]), minlength=n_p)
    n0, n1 = np.sum(deg == 0), np.sum(deg == 1)
    assert m.n_rattlers == n0 + n1
    assert m.z_mech == pytest.approx((2 * n_c - n1) / (n_p - n0 - n1), rel=1e-15)
    nrm = diff[ii, jj] / dist[ii, jj][:, None]
    fabric = nrm.T @ nrm / n_c
    np.testing.assert_allclose(m.fabric, fabric, atol=1e-14)
    w = np.sort(np.linalg.eigvalsh(fabric))[::-1]
    np.testing.assert_allclose(m.fabric_eigenvalues, w, atol=1e-14)
    if d == 3:  # Barreto, eq. 15
        want = math.sqrt(((w[0] - w[1]) ** 2 + (w[1] - w[2]) ** 2 + (w[2] - w[0]) ** 2) / 2)
    else:
        want = w[0] - w[1]
    assert m.phi_d == pytest.approx(want, abs=1e-14)
    assert m.anisotropy["maeda"] == pytest.approx(m.z * (w[0] - w[-1]), abs=1e-13)
