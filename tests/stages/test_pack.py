"""Layer-by-layer generation: RSA layers, radius law, determinism, presets, files."""

from __future__ import annotations

import math
import textwrap

import numpy as np
import pytest
from scenes import outputs_on_threads

import granpack as gp


def pair_overlaps(x: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Brute-force overlaps r_i + r_j - |x_i - x_j| over all pairs i < j."""
    d = np.linalg.norm(x[:, None, :] - x[None, :, :], axis=-1)
    iu = np.triu_indices(len(r), 1)
    return (r[:, None] + r[None, :] - d)[iu]


# settle_time = 0 keeps the raw RSA layers, which have not fallen (UnsettledPackWarning)
@pytest.mark.filterwarnings("ignore::granpack.UnsettledPackWarning")
@pytest.mark.parametrize("preset", ["4.1", "4.3"])
def test_rsa_layers_have_no_overlaps_and_reach_phi_layer(preset):
    """With no settling the pack is the raw RSA output, layer by layer."""
    scene = gp.PackScene.preset(preset)
    scene = scene.replace(base=(0.3,) * (scene.dim - 1), height=0.3, settle_time=0.0, seed=3)
    pack = gp.generate(scene)
    assert pack.n_layers >= 2
    assert np.all(pair_overlaps(pack.positions, pack.radii) <= 0.0)
    slab = scene.base_area * scene.h_layer
    one = scene.particle_volume(scene.r_mean) / slab
    for k in range(pack.n_layers):
        sel = pack.layer == k
        phi = np.sum([scene.particle_volume(r) for r in pack.radii[sel]]) / slab
        assert scene.phi_layer <= phi < scene.phi_layer + one
        assert pack.layers[k]["phi_rsa"] == pytest.approx(phi)
    # inside the walls and above the floor
    x, r = pack.positions, pack.radii
    assert np.all(x[:, :-1] - r[:, None] >= 0) and np.all(x[:, :-1] + r[:, None] <= 0.3)
    assert np.all(x[:, -1] - r >= 0)


def truncated_normal_cdf(x, mean, sd, lo, hi):
    phi = np.vectorize(lambda z: 0.5 * (1 + math.erf(z / math.sqrt(2))))
    a, b = phi((lo - mean) / sd), phi((hi - mean) / sd)
    return (phi((x - mean) / sd) - a) / (b - a)


# settle_time = 0 keeps the raw RSA layers, which have not fallen (UnsettledPackWarning)
@pytest.mark.filterwarnings("ignore::granpack.UnsettledPackWarning")
def test_radii_follow_the_truncated_gaussian():
    """Kolmogorov-Smirnov against the truncated law; a clipped sampler would put mass
    at the bounds and fail. Fixed seed; 1 % critical value 1.63 / sqrt(n)."""
    scene = gp.PackScene.preset("4.2").replace(
        r_std=0.003, settle_time=0.0, height=1.5, seed=2
    )  # a wide law (truncation at +-1 sd) makes clipping visible
    pack = gp.generate(scene)
    r = np.sort(pack.radii)
    n = len(r)
    assert n > 1000
    cdf = truncated_normal_cdf(r, 0.01, 0.003, 0.007, 0.013)
    ks = max(np.max(np.arange(1, n + 1) / n - cdf), np.max(cdf - np.arange(n) / n))
    assert ks < 1.63 / math.sqrt(n), ks
    assert r.min() >= 0.007 and r.max() <= 0.013
    assert np.mean(r == 0.007) == 0 and np.mean(r == 0.013) == 0


def test_small_pack_settles_into_a_dense_pack(tiny_scene_2d):
    # the paper's 1 s per layer: the last layer falls its slab and discs that roll on the
    # top (no rolling resistance) come to rest
    pack = gp.generate(tiny_scene_2d.replace(settle_time=1.0))
    assert pack.height >= tiny_scene_2d.height
    assert pack.n_layers == len(np.unique(pack.layer)) >= 3
    # jammed: dense (a narrow box with a rough top, measured to H_top), little overlap,
    # nothing moving fast
    assert 0.65 < pack.phi < 0.91
    assert pair_overlaps(pack.positions, pack.radii).max() < 0.02 * 0.01
    assert np.max(np.linalg.norm(pack.velocities, axis=1)) < 0.05
    pp = pack.contacts.particle_pairs()
    assert 3.0 < 2 * len(pp) / len(pack) < 6.0
    assert np.all(pack.contacts.force_normal >= 0)


def test_same_seed_same_pack_different_seed_or_stream_different(tiny_scene_2d):
    a = gp.generate(tiny_scene_2d)
    b = gp.generate(tiny_scene_2d)
    assert np.array_equal(a.positions, b.positions) and np.array_equal(a.spins, b.spins)
    c = gp.generate(tiny_scene_2d.replace(seed=6))
    d = gp.generate(tiny_scene_2d.replace(stream=1))
    for other in (c, d):
        assert len(other) != len(a) or not np.array_equal(a.positions, other.positions)


#: A reduced 4.3 (about 150 spheres of 8 mm, two layers) that packs in about 0.2 s.
TINY_3D = dict(
    base=(0.12, 0.12),
    r_mean=0.008,
    dt=5e-5,
    height=0.05,
    h_layer=0.03,
    settle_time=0.4,
    seed=5,
)


@pytest.mark.parametrize("dim", [2, 3])
def test_a_finished_packer_gives_its_state_and_contacts_and_is_spent(tiny_scene_2d, dim):
    """`LayerPacker.finish` frees the engine while it builds the pack: what it gives is
    what `state()` and `contacts()` give a twin packer of the same scene, to the bit,
    and the spent packer refuses every call by name."""
    from granpack import _core

    scene = tiny_scene_2d
    if dim == 3:
        scene = gp.PackScene.preset("4.3").replace(**TINY_3D)
    twins = [_core.LayerPacker(scene) for _ in range(2)]
    for packer in twins:
        while not packer.done:
            packer.next_layer()
    state, contacts = twins[0].state(), twins[0].contacts()
    got_state, got_contacts = twins[1].finish()
    assert len(contacts["i"]) > len(state["radii"]) > 20
    assert set(got_state) == set(state) and set(got_contacts) == set(contacts)
    for want, got in ((state, got_state), (contacts, got_contacts)):
        for key, value in want.items():
            assert np.array_equal(np.asarray(got[key]), np.asarray(value)), key
            assert np.asarray(got[key]).dtype == np.asarray(value).dtype, key
    for call in (lambda p: p.done, lambda p: p.next_layer(), lambda p: p.finish()):
        with pytest.raises(RuntimeError, match=r"LayerPacker\.finish"):
            call(twins[1])


THREAD_SCRIPT = textwrap.dedent(
    """
    import hashlib, sys, granpack as gp
    scene = gp.PackScene.preset("4.1").replace(
        r_mean=0.004, height=0.25, settle_time=0.05, dt=5e-5, seed=9
    )
    if sys.argv[1] == "fast":
        # freezing (and thawing, partial rebuilds) and adaptive settling too
        scene = scene.replace(
            height=0.15, settle_time=0.4, settle_tol=1e-2, freeze_depth=0.02,
            freeze_speed=2e-2, freeze_force=0.5, settle_dt=6.5e-5,
        )
    elif sys.argv[1] == "resorted":
        # layers of 4 096 discs and more: the pack is re-sorted after each layer
        scene = scene.replace(base=(5.5,), height=0.08, settle_time=0.35)
    p = gp.generate(scene)
    h = hashlib.sha256()
    c = p.contacts
    for a in (p.positions, p.velocities, p.spins, c.force_normal, c.force_tangential):
        h.update(a.tobytes())
    print(len(p), max(r["frozen"] for r in p.layers), h.hexdigest())
    """
)


@pytest.mark.parametrize("mode", ["paper", "fast", "resorted"])
def test_bit_identical_on_one_and_two_threads(mode):
    """More than one parallel chunk (512 particles) so that threads really split work;
    in `fast` mode particles freeze, thaw and the pair list is partly rebuilt, and the
    step changes to settle_dt once each layer has fallen; in `resorted` mode the layers
    are large enough for the pack to be re-sorted into one row-major order after each."""
    out = outputs_on_threads(THREAD_SCRIPT, mode)
    assert int(out["1"][0]) > (2 * 4096 if mode == "resorted" else 2 * 512)
    if mode == "fast":
        assert int(out["1"][1]) > 0, "some particles froze"
    assert out["1"] == out["2"]


def test_a_pack_of_large_layers_is_stored_in_one_row_major_order():
    """Layers of 4 096 discs or more re-sort the whole pack into one row-major order of
    cells after each, rows of the vertical axis slowest: the layers interleave in the
    arrays, the index follows the height (in a Morton order of this 5.5 m x 0.08 m pack
    it follows the width), each particle keeps its layer, and the contact table names
    the particles it joins (each overlap is r_i + r_j - |x_j - x_i| of the pack's own
    arrays)."""
    scene = gp.PackScene.preset("4.1").replace(
        r_mean=0.004, base=(5.5,), height=0.08, settle_time=0.35, dt=5e-5, seed=9
    )
    p = gp.generate(scene)
    added = [r["added"] for r in p.layers]
    assert len(added) >= 2 and min(added) >= 4096, added
    assert np.bincount(p.layer).tolist() == added
    assert np.any(np.diff(p.layer) < 0), "the layers do not interleave"
    index = np.arange(len(p))
    along_height = np.corrcoef(index, p.positions[:, 1])[0, 1]
    along_width = np.corrcoef(index, p.positions[:, 0])[0, 1]
    assert along_height > 0.9 and abs(along_width) < 0.2, (along_height, along_width)
    c = p.contacts
    pp = c.j >= 0
    i, j = c.i[pp], c.j[pp]
    assert pp.sum() > len(p)
    overlap = p.radii[i] + p.radii[j] - np.linalg.norm(p.positions[j] - p.positions[i], axis=1)
    np.testing.assert_allclose(overlap, c.overlap[pp], rtol=0, atol=1e-12)


def test_a_layer_that_stops_above_the_height_but_settles_below_it_is_not_the_last():
    """With adaptive settling the last layer runs its whole settle_time. 4.3 `fast()`
    with seed 5 is a pack whose eleventh layer stops at or above the 0.5 m target while
    its top still settles: it runs on past its adaptive stop, the height falls below the
    target, and it ends there (not the last); a twelfth layer follows and is the one that
    runs the whole settle_time, then the final relax."""
    s = gp.PackScene.preset("4.3").replace(seed=5).fast()
    p = gp.generate(s)
    *early, before, last = p.layers
    whole = last["steps"] - round(0.1 / s.settle_dt)  # the last layer's settle_time
    assert len(p.layers) == 12
    assert before["height"] < s.height <= last["height"]
    # past its adaptive stop (the layers below stop at it), short of the whole second
    assert max(r["steps"] for r in early[1:]) < before["steps"] < whole, (before, whole)


def test_presets_carry_the_papers_numbers():
    p41, p42, p43, p44 = (gp.PackScene.preset(k) for k in ("4.1", "4.2", "4.3", "4.4"))
    for s in (p41, p42, p43, p44):
        assert s.height == 0.5 and s.h_layer == 0.1 and s.dt == 1e-4 and s.settle_time == 1.0
        assert s.gravity == 2.0 and s.drag == 0.005 and s.rotations
        assert s.material == gp.Material(1000.0, 1e8, 0.25, 0.1, 0.2)
    assert (p41.dim, p41.base, p41.r_mean, p41.radius_law, p41.phi_layer) == (
        2,
        (1.0,),
        0.01,
        "constant",
        0.4,
    )
    assert (p42.r_mean, p42.r_std, p42.r_min, p42.r_max) == (0.01, 0.001, 0.007, 0.013)
    assert (p43.dim, p43.base, p43.r_mean, p43.phi_layer) == (3, (1.0, 1.0), 0.02, 0.25)
    assert (p44.r_mean, p44.r_std, p44.r_min, p44.r_max) == (0.02, 0.002, 0.014, 0.026)


def test_scene_toml_round_trip_and_errors(tmp_path):
    s = gp.PackScene.preset("4.4").replace(rotations=False, seed=17, settle_time=0.5)
    path = tmp_path / "scene.toml"
    path.write_text(s.to_toml())
    assert gp.PackScene.from_toml(path) == s
    path.write_text('preset = "4.3"\nseed = 4\n[material]\nfriction = 0.5\n')
    t = gp.PackScene.from_toml(path)
    assert t.dim == 3 and t.seed == 4 and t.material.friction == 0.5 and t.material.young == 1e8
    path.write_text('preset = "4.3"\nphi_layr = 0.2\n')
    with pytest.raises(ValueError, match="did you mean 'phi_layer'"):
        gp.PackScene.from_toml(path)
    path.write_text("dim = [\n")
    with pytest.raises(ValueError, match="invalid scene file"):
        gp.PackScene.from_toml(path)


@pytest.mark.parametrize(
    ("changes", "name"),
    [
        ({"phi_layer": 0.6}, "phi_layer"),
        ({"phi_layer": 0.0}, "phi_layer"),
        ({"radius_law": "gaussian", "r_std": 0.001, "r_min": 0.012, "r_max": 0.013}, "r_mean"),
        ({"radius_law": "gaussian", "r_std": 0.001, "r_min": 0.012, "r_max": 0.011}, "r_max"),
        ({"radius_law": "gaussian", "r_std": -0.001}, "r_std"),
        ({"base": (0.01,)}, "base"),
        ({"base": (1.0, 1.0)}, "base"),
        ({"height": -1.0}, "height"),
        ({"dt": 1e-3}, "dt"),
        ({"settle_dt": 0.0}, "settle_dt"),
        ({"settle_dt": 1e-3}, "settle_dt.*Rayleigh"),
        ({"seed": -1}, "seed"),
        ({"radius_law": "weibull"}, "radius_law"),
        ({"r_mean": 1e-5, "dt": 1e-8, "base": (100.0,)}, "about .* particles"),
    ],
)
def test_scene_validation_names_the_field(changes, name):
    with pytest.raises(ValueError, match=name):
        gp.PackScene.preset("4.1").replace(**changes)


def test_rsa_saturation_is_a_clear_error():
    scene = gp.PackScene.preset("4.1").replace(
        base=(0.1,), phi_layer=0.54, max_attempts=2000, settle_time=0.0
    )
    with pytest.raises(ValueError, match=r"saturated: layer 0 reached solid fraction 0\.\d+"):
        gp.generate(scene)


def test_pack_file_round_trip_and_corruption(tmp_path, tiny_scene_2d):
    pack = gp.generate(tiny_scene_2d)
    path = pack.save(tmp_path / "p.npz")
    back = gp.load_pack(path)
    assert back.scene == pack.scene and back.height == pack.height
    for name in ("positions", "radii", "velocities", "spins", "layer"):
        assert np.array_equal(getattr(back, name), getattr(pack, name))
    for k, v in pack.contacts.to_dict().items():
        assert np.array_equal(getattr(back.contacts, k), v)
    assert back.layers == pack.layers
    data = path.read_bytes()
    (tmp_path / "cut.npz").write_bytes(data[: len(data) // 2])
    with pytest.raises(ValueError, match="corrupt or truncated"):
        gp.load_pack(tmp_path / "cut.npz")
    with pytest.raises(ValueError, match="no such file"):
        gp.load_pack(tmp_path / "missing.npz")
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")]


def test_progress_callback_sees_every_layer(tiny_scene_2d):
    seen = []
    pack = gp.generate(tiny_scene_2d, progress=seen.append)
    assert [r["layer"] for r in seen] == list(range(pack.n_layers))
    assert seen[-1]["total"] == len(pack) and seen[-1]["height"] == pack.height


def test_a_scene_too_large_for_memory_is_refused_before_any_work():
    from granpack.pack import check_memory

    big = gp.PackScene.preset("4.3").replace(base=(200.0, 200.0))  # ~3e8 spheres
    with pytest.raises(ValueError, match=r"would not fit in this machine's memory"):
        check_memory(big, total_bytes=24 * 2**30)
    check_memory(gp.PackScene.preset("4.3"), total_bytes=24 * 2**30)  # 1e4 spheres: fine
    with pytest.raises(ValueError, match="would not fit"):
        gp.generate(gp.PackScene.preset("4.3").replace(base=(250.0, 250.0)))  # 3.5e8
