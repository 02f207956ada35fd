"""Figures: what is drawn matches the pack (one disc per particle, colours by layer,
densities that integrate to one, line widths proportional to force), PNGs on disk."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from matplotlib.collections import EllipseCollection, LineCollection

import granpack as gp
from granpack import plot

PNG = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def pack2d() -> gp.Pack:
    scene = gp.PackScene.preset("4.2").replace(base=(0.3,), height=0.1, settle_time=0.5, seed=2)
    return gp.generate(scene)


@pytest.fixture(scope="module")
def pack3d() -> gp.Pack:
    scene = gp.PackScene.preset("4.3").replace(base=(0.2, 0.2), height=0.1, settle_time=0.5, seed=2)
    return gp.generate(scene)


def _widths(coll: EllipseCollection) -> np.ndarray:
    """Full widths (matplotlib >= 3.9 has get_widths; older ones keep half-widths)."""
    if hasattr(coll, "get_widths"):
        return np.asarray(coll.get_widths())
    return 2 * np.asarray(coll._widths)


def _ellipses(ax) -> EllipseCollection:
    (coll,) = [c for c in ax.collections if isinstance(c, EllipseCollection)]
    return coll


def test_2d_pack_is_one_disc_per_particle_coloured_by_layer(pack2d, tmp_path):
    fig = plot.pack_figure(pack2d, title="tiny")
    coll = _ellipses(fig.axes[0])
    np.testing.assert_array_equal(coll.get_offsets(), pack2d.positions)
    np.testing.assert_allclose(_widths(coll), 2 * pack2d.radii)
    colors = coll.get_facecolors()
    assert len(np.unique(pack2d.layer)) > 1
    for layer in np.unique(pack2d.layer):  # one colour per layer, neighbours differ
        assert len(np.unique(colors[pack2d.layer == layer], axis=0)) == 1
    first = colors[pack2d.layer == 0][0]
    second = colors[pack2d.layer == 1][0]
    assert not np.array_equal(first, second)
    path = plot.save(fig, tmp_path / "p.png")
    assert path.read_bytes()[:8] == PNG


def test_3d_pack_view_draws_every_sphere_and_the_slice_cuts_the_mid_plane(pack3d, tmp_path):
    fig = plot.pack_figure(pack3d)
    view, cut = fig.axes[:2]
    assert len(_ellipses(view).get_offsets()) == len(pack3d)
    d = np.abs(pack3d.positions[:, 1] - 0.1)
    hit = d < pack3d.radii
    assert 0 < hit.sum() < len(pack3d)
    slice_coll = _ellipses(cut)
    np.testing.assert_allclose(slice_coll.get_offsets(), pack3d.positions[hit][:, [0, 2]])
    np.testing.assert_allclose(
        _widths(slice_coll), 2 * np.sqrt(pack3d.radii[hit] ** 2 - d[hit] ** 2)
    )
    assert plot.save(fig, tmp_path / "p3.png").read_bytes()[:8] == PNG


def test_packs_grid_has_one_panel_per_pack(pack2d, pack3d):
    fig = plot.packs_figure([pack2d] * 3, labels=["a", "b", "c"])
    drawn = [ax for ax in fig.axes if ax.collections]
    assert [ax.get_title() for ax in drawn] == ["a", "b", "c"]
    assert len(fig.axes) == 4  # 2 columns, the spare panel blank
    with pytest.raises(gp.GranpackError):
        plot.packs_figure([])


def test_rose_is_a_density_over_angle(pack2d):
    normals = pack2d.contacts.particle_pairs().normal
    fig = plot.normals_figure(normals)
    ax = fig.axes[0]
    bars = ax.patches
    assert len(bars) == 36
    area = sum(b.get_height() * b.get_width() for b in bars)
    assert area == pytest.approx(1.0)
    # The fabric curve integrates to one too (a^r is traceless).
    (curve, _iso) = [ln for ln in ax.lines][:2]
    t, e = curve.get_data()
    assert np.trapezoid(e, t) == pytest.approx(1.0, rel=1e-6)


def test_orientation_density_of_isotropic_normals_is_one():
    rng = np.random.default_rng(0)
    n = rng.normal(size=(60000, 3))
    n /= np.linalg.norm(n, axis=1)[:, None]
    fig = plot.normals_figure(n, bins=16)
    (img,) = fig.axes[0].images
    density = np.asarray(img.get_array().filled(np.nan))
    # Equal-area projection: every cell of an isotropic distribution reads about 1.
    inside = np.isfinite(density)
    assert inside.sum() > 100
    assert np.mean(density[inside]) == pytest.approx(1.0, abs=0.02)
    assert np.all(np.abs(density[inside] - 1.0) < 0.25)


def test_force_chain_widths_follow_the_normal_force(pack2d, pack3d, tmp_path):
    fig = plot.force_chain_figure(pack2d, max_width=3.0)
    (lines,) = [c for c in fig.axes[0].collections if isinstance(c, LineCollection)]
    widths = np.sort(np.asarray(lines.get_linewidths()))
    fn = np.sort(pack2d.contacts.force_normal)
    np.testing.assert_allclose(widths, 3.0 * fn / fn.max())
    assert len(lines.get_segments()) == len(pack2d.contacts)
    fig3 = plot.force_chain_figure(pack3d)
    assert plot.save(fig3, tmp_path / "f3.png").read_bytes()[:8] == PNG


def test_phi_histogram_counts_every_pack():
    fig = plot.phi_histogram_figure(
        {"ON": [0.85, 0.86, 0.855], "OFF": [0.83, 0.84]}, {"ON": [0.854, 0.863]}
    )
    ax = fig.axes[0]
    heights = [p.get_height() for p in ax.patches]
    assert sum(heights) == 5
    labels = ax.get_legend_handles_labels()[1]
    assert any("paper: 0.8585" in lab for lab in labels)


def test_plot_never_imports_pyplot():
    code = "import granpack.plot, sys; print('matplotlib.pyplot' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_bad_normals_are_a_clear_error():
    with pytest.raises(gp.GranpackError, match="normals"):
        plot.normals_figure(np.zeros((3, 4)))
