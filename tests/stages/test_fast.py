"""Skipping what a scene does not need: freezing of buried settled particles and
adaptive settling keep the pack's invariants and stay deterministic."""

from __future__ import annotations

import math

import numpy as np
import pytest

import granpack as gp


@pytest.fixture
def deep_scene() -> gp.PackScene:
    """Enough thin layers that the bottom ones lie deeper than the freezing depth (sphere
    mass: its bounds on overlaps and wall penetration are at that scale)."""
    return gp.PackScene.preset("4.1").replace(
        base=(0.3,), height=0.2, h_layer=0.04, settle_time=0.6, seed=11, inertia_2d="sphere"
    )


def test_freezing_freezes_buried_particles_and_keeps_invariants(deep_scene):
    scene = deep_scene.replace(freeze_depth=0.05)
    pack = gp.generate(scene)
    frozen = [rep["frozen"] for rep in pack.layers]
    assert max(frozen) > 0.2 * len(pack), frozen
    x, r = pack.positions, pack.radii
    # nothing escaped: inside the side walls, above the floor
    assert np.all(x[:, 0] - r >= -1e-3 * r) and np.all(x[:, 0] + r <= 0.3 + 1e-3 * r)
    assert np.all(x[:, 1] - r >= -1e-3 * r)
    # no overlap beyond what the jamming load produces without freezing
    full = gp.generate(deep_scene)
    assert pack.contacts.overlap.max() < 2 * full.contacts.overlap.max()
    assert pack.contacts.overlap.max() < 0.01 * 0.01
    # the frozen part is at rest
    assert np.all(np.isfinite(pack.velocities))


def test_freezing_and_adaptive_settling_are_deterministic(deep_scene):
    scene = deep_scene.replace(freeze_depth=0.05, settle_tol=1e-2)
    a, b = gp.generate(scene), gp.generate(scene)
    assert np.array_equal(a.positions, b.positions)
    assert [r["steps"] for r in a.layers] == [r["steps"] for r in b.layers]


def test_adaptive_settling_stops_early_but_not_before_the_fall(deep_scene):
    """With a loose tolerance the runs end early, never before the new layer has had
    time to fall through its slab, sqrt(2 h_layer / g) = 0.2 s here."""
    scene = deep_scene.replace(settle_tol=1e-2)
    pack = gp.generate(scene)
    steps = np.array([r["steps"] for r in pack.layers])
    full_steps = round(scene.settle_time / scene.dt)
    assert np.all(steps <= full_steps) and np.any(steps < full_steps)
    assert np.all(steps * scene.dt >= np.sqrt(2 * scene.h_layer / scene.gravity) - 1e-9)
    assert pack.height >= scene.height


def test_settle_dt_takes_over_once_the_layer_has_fallen(deep_scene):
    """With settle_dt a layer runs at dt until it has had time to fall through its
    slab (sqrt(2 h_layer / g) = 0.2 s here, checked every 0.01 s), then at settle_dt
    for the rest of settle_time; the pack keeps its invariants."""
    dt, dt2 = deep_scene.dt, 1.5e-4
    pack = gp.generate(deep_scene.replace(settle_dt=dt2))
    t_fall = math.sqrt(2 * deep_scene.h_layer / deep_scene.gravity)
    chunk = round(0.01 / dt)
    # the first check at or after t_fall (0.01 s apart): either of two, as rounding has it
    k = math.ceil(t_fall / 0.01 - 1e-9)
    first = [chunk * k, chunk * (k + 1)]
    expect = {n1 + round((deep_scene.settle_time - n1 * dt) / dt2) for n1 in first}
    steps = [r["steps"] for r in pack.layers]
    assert all(s in expect for s in steps), (steps, expect)
    assert max(expect) < round(deep_scene.settle_time / dt)
    x, r = pack.positions, pack.radii
    assert np.all(x[:, 0] - r >= -1e-3 * r) and np.all(x[:, 0] + r <= 0.3 + 1e-3 * r)
    assert np.all(x[:, 1] - r >= -1e-3 * r)
    assert pack.contacts.overlap.max() < 0.01 * 0.01
    assert pack.height >= deep_scene.height


def test_fast_settings_keep_physics_constants():
    for preset in ("4.1", "4.2", "4.3", "4.4"):
        s = gp.PackScene.preset(preset)
        f = s.fast()
        assert f.settle_tol is not None and f.freeze_depth is not None
        for name in ("material", "settle_time", "gravity", "drag", "phi_layer", "h_layer"):
            assert getattr(f, name) == getattr(s, name)
        # dt: a fraction of the stable step, never below the scene's own
        crit = s.material.critical_time_step(s.r_min)
        assert f.dt == max(s.dt, 0.55 * crit) and f.dt < crit
        # and after each landing 0.75 of it, where that is larger than dt
        assert f.settle_dt == (0.75 * crit if 0.75 * crit > f.dt else None)
    # 4.3's spheres take 1.9 times the paper's step; 4.1's discs keep it
    assert gp.PackScene.preset("4.3").fast().dt == pytest.approx(1.883e-4, rel=1e-3)
    assert gp.PackScene.preset("4.1").fast().dt == 1e-4
    # 4.2's 1e-4 s is already 0.83 of its estimate: one step throughout
    assert gp.PackScene.preset("4.2").fast().settle_dt is None


def test_fast_settings_keep_a_freeze_depth_the_scene_sets():
    s = gp.PackScene.preset("4.3")
    assert s.freeze_depth is None
    assert s.fast().freeze_depth == gp.scene.FAST_FREEZE_LAYERS * s.h_layer
    # a tall pack's bed frozen for good 4 h_layer down: fast() keeps both settings
    tall = s.replace(height=1.5, freeze_depth=0.4, freeze_force=10.0).fast()
    assert (tall.freeze_depth, tall.freeze_force) == (0.4, 10.0)
    assert tall.settle_tol == gp.scene.FAST_SETTLE_TOL and tall.dt == s.fast().dt
    # and fast() of a fast scene is the same scene
    assert tall.fast() == tall and s.fast().fast() == s.fast()


def ensemble(scene: gp.PackScene, core_margin: float, packs: int = 8):
    """phi and Z of `packs` packs (streams 0..packs-1), and their total DEM steps."""
    phi, z, steps = [], [], 0
    for k in range(packs):
        pack = gp.generate(scene.replace(stream=k))
        m = gp.microstructure(pack, core_margin=core_margin)
        phi.append(pack.phi)
        z.append(m.z)
        steps += sum(r["steps"] for r in pack.layers)
    return np.array(phi), np.array(z), steps


def test_fast_defaults_match_the_full_fidelity_statistics():
    """The fast defaults (adaptive settling, freezing one h_layer deep, final relax)
    reproduce the full-fidelity ensemble: the mean packing fraction and coordination
    number of 8 packs lie within one standard deviation (ddof = 1) of the mean of 8
    full-fidelity packs of the same seed and streams. Fixed seed: deterministic."""
    scene = gp.PackScene.preset("4.2").replace(
        base=(0.3,), height=0.12, h_layer=0.04, settle_time=1.0, seed=3
    )
    (phi_full, z_full, steps_full), (phi_fast, z_fast, steps_fast) = (
        ensemble(scene, 0.02),
        ensemble(scene.fast(), 0.02),
    )
    assert steps_fast < 0.9 * steps_full  # the fast settings do skip work
    assert abs(phi_fast.mean() - phi_full.mean()) <= phi_full.std(ddof=1)
    assert abs(z_fast.mean() - z_full.mean()) <= z_full.std(ddof=1)


def test_fast_time_step_keeps_the_3d_statistics():
    """In 3D `fast()` also takes dt = 0.55 of the Rayleigh estimate (1.9 times the
    paper's for 4.3) and settle_dt = 0.75 of it once each layer has landed: on a
    reduced 4.3 scene the mean packing fraction and coordination number of 8 fast packs
    lie within one standard deviation (ddof = 1) of the mean of 8 full-fidelity packs
    of the same seed and streams (measured -0.06 and +0.14 sd), in well under half
    the steps (37 %). Fixed seed: deterministic."""
    scene = gp.PackScene.preset("4.3").replace(base=(0.3, 0.3), height=0.2, seed=3)
    (phi_full, z_full, steps_full), (phi_fast, z_fast, steps_fast) = (
        ensemble(scene, 0.04),
        ensemble(scene.fast(), 0.04),
    )
    assert scene.fast().dt > 1.8 * scene.dt
    assert scene.fast().settle_dt > 1.3 * scene.fast().dt
    assert steps_fast < 0.6 * steps_full
    assert abs(phi_fast.mean() - phi_full.mean()) <= phi_full.std(ddof=1)
    assert abs(z_fast.mean() - z_full.mean()) <= z_full.std(ddof=1)
