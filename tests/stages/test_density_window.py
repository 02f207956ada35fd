"""The density window: e_min and e_max are the measured extremes of what granpack makes of
a scene (every deposition friction of the grid, the recipe, and the servo's zero-friction
end where the scene consolidates), ordered, and every sample granpack makes lies inside
it or says why not.

Small 2D scenes: phi is not monotone in the deposition friction once the friction is
restored and the pack settled or consolidated, so the frictionless and the loosest
deposition friction are not the ends; the tests check the window against the packs
themselves (a brute-force oracle: the extremes over the same seed's packs)."""

from __future__ import annotations

import dataclasses
import math
import warnings

import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

import granpack as gp
from granpack.density import MU_DEP_GRID, DensityWindowWarning, _at_friction, sample_phi

#: Example 4.1 (monodisperse discs) in a small box: phi against mu_dep is far from
#: monotone (seed 5 settled deposits, core phi: 0.898, 0.891, 0.908, 0.848, 0.825 at
#: mu_dep 0, 0.1, 0.2 (the recipe's), 0.5, 1).
BOX41 = gp.PackScene.preset("4.1").replace(base=(0.3,), height=0.3, seed=5).fast()
#: The same consolidated to 10 kPa: its servo reaches denser than any deposition friction.
BOX41_C = BOX41.replace(consolidate={"stress": 1e4})
#: Example 4.2 (polydisperse discs) in a small box, consolidated to 10 kPa: the servo at
#: zero friction reaches phi 0.922, every deposition friction 0.873 to 0.890.
BOX42_C = (
    gp.PackScene.preset("4.2")
    .replace(base=(0.25,), height=0.12, seed=1, consolidate={"stress": 1e4})
    .fast()
)


def _phi(scene: gp.PackScene, mu: float) -> float:
    return sample_phi(_at_friction(scene, mu))[0]


@pytest.fixture(scope="module")
def window41() -> gp.VoidRatioLimits:
    return gp.void_ratio_limits(BOX41, packs=1)


@pytest.fixture(scope="module")
def window42c() -> gp.VoidRatioLimits:
    return gp.void_ratio_limits(BOX42_C, packs=1)


def test_the_window_ends_are_the_extremes_where_phi_is_not_monotone(window41):
    w = window41
    phis = {mu: phi for _, mech, mu, phi in w.points if mech == "deposition"}
    assert set(phis) == set(MU_DEP_GRID) | {BOX41.material.friction}
    # phi is not monotone in mu_dep here: the ends of the friction range are not the ends
    # of the window (frictionless is not the densest)
    assert max(phis.values()) > phis[0.0]
    assert w.phi_max == pytest.approx(max(phis.values()), rel=1e-12)
    assert w.phi_min == pytest.approx(min(phis.values()), rel=1e-12)
    assert w.e_min < w.e_max
    densest = max(phis, key=phis.get)
    assert w.e_min_from == (f"layers jammed at mu_dep = {densest:g}",)
    # the point is that friction's pack, made again on its own, bit for bit
    assert _phi(BOX41, densest) == phis[densest]
    # the recipe's own deposit is inside: 0 <= Dr <= 1
    recipe = 1.0 / sample_phi(gp.generate(BOX41))[0] - 1.0
    assert w.e_min <= recipe <= w.e_max
    assert 0.0 <= w.relative_density(recipe) <= 1.0


def test_a_consolidating_scenes_window_holds_the_servos_end(window42c):
    w = window42c
    dep = [phi for _, mech, _, phi in w.points if mech == "deposition"]
    servo = [phi for _, mech, _, phi in w.points if mech == "servo"]
    assert len(servo) == 1
    # the servo at zero friction packs the discs far denser than any deposition
    # friction: the window's dense end is the servo's
    assert servo[0] > max(dep) + 0.01
    assert w.phi_max == pytest.approx(servo[0], rel=1e-12)
    assert w.phi_min == pytest.approx(min(dep), rel=1e-12)
    assert w.e_min_from == ("the recipe's sample, friction lowered to zero under the servo",)
    # a target that only the servo reaches is met, and lies inside the window
    target = round(max(dep) + 0.5 * (servo[0] - max(dep)), 4)
    sample = gp.generate(BOX42_C.replace(target_phi=target))
    assert sample.record("density").table()["method"] == "servo"
    e = sample.record("density").table()["void_ratio"]
    assert w.e_min <= e <= w.e_max
    # and the same target as a relative density reports Dr in [0, 1]
    dr = round(w.relative_density(1.0 / target - 1.0), 4)
    again = gp.generate(BOX42_C.replace(target_relative_density=dr))
    assert (
        again.record("density").table()["e_min"] == w.e_min
        and again.record("density").table()["e_max"] == w.e_max
    )
    assert 0.0 <= again.record("density").table()["relative_density"] <= 1.0


def test_a_target_out_of_reach_is_refused_with_the_ordered_window(window41):
    w = window41
    # beyond every pack by far: phi of this small box scatters by a few hundredths
    # between neighbouring deposition frictions, and hexagonal order caps it at 0.9069
    for target in (round(w.phi_min - 0.08, 4), round(w.phi_max + 0.01, 4)):
        with pytest.raises(gp.DensityTargetError) as info:
            gp.generate(BOX41.replace(target_phi=target))
        e = info.value
        assert "out of reach" in str(e)
        # ordered, and at least the window of void_ratio_limits' packs (same seed and
        # stream): the search's own packs can only widen it
        assert e.phi_min < e.phi_max
        assert e.phi_min <= w.phi_min * (1 + 1e-12) and e.phi_max >= w.phi_max * (1 - 1e-12)
        assert not e.phi_min <= target <= e.phi_max
        assert f"[{e.phi_min:.4f}, {e.phi_max:.4f}]" in str(e)


def test_a_target_between_the_frictionless_pack_and_the_densest_is_met(window41):
    # denser than the frictionless pack, but not than the densest: reachable
    phis = {mu: phi for _, mech, mu, phi in window41.points if mech == "deposition"}
    assert window41.phi_max - phis[0.0] > 0.0023
    target = round(window41.phi_max - 0.0003, 4)
    assert target > phis[0.0] + 0.002
    pack = gp.generate(BOX41.replace(target_phi=target))
    assert abs(pack.record("density").table()["phi"] - target) <= 0.002
    assert pack.record("density").table()["generations"] <= 12


def test_a_target_in_a_gap_of_phi_is_refused_with_the_span_the_packs_made(window41):
    # the small 4.1 box's core holds a few dozen discs, ordered or not: phi jumps by a
    # few hundredths between neighbouring deposition frictions, and a target in the
    # middle of its window (0.8668) falls between the packs any friction makes
    w = window41
    target = round(w.phi_min + 0.5 * (w.phi_max - w.phi_min), 4)
    with pytest.raises(gp.DensityTargetError) as info:
        gp.generate(BOX41.replace(target_phi=target))
    e = info.value
    assert "not reached" in str(e) and "out of reach" not in str(e)
    # the span of the packs it made holds the target and the window, and the nearest
    # pack is reported, outside the band
    assert e.phi_min <= w.phi_min * (1 + 1e-12) and e.phi_max >= w.phi_max * (1 - 1e-12)
    assert e.phi_min < target < e.phi_max
    assert abs(e.realised - target) > 0.002
    assert f"nearest: phi = {e.realised:.4f}" in str(e)


def test_a_frictionless_material_has_an_ordered_window():
    base = gp.PackScene.preset("4.1").replace(base=(0.3,), height=0.12, seed=2)
    scene = base.replace(
        material=dataclasses.replace(base.material, friction=0.0), consolidate={"stress": 1e4}
    ).fast()
    w = gp.void_ratio_limits(scene, packs=1)
    assert w.e_min <= w.e_max
    phis = [phi for *_, phi in w.points]
    assert w.phi_max == pytest.approx(max(phis), rel=1e-12)
    assert w.phi_min == pytest.approx(min(phis), rel=1e-12)
    if w.e_max > w.e_min:
        loose = gp.generate(scene.replace(target_relative_density=0.0)).record("density").table()
        dense = gp.generate(scene.replace(target_relative_density=1.0)).record("density").table()
        # Dr 1 is the denser
        assert dense["void_ratio"] <= loose["void_ratio"]
    else:
        with pytest.raises(gp.InvalidParameterError, match="no width"):
            gp.generate(scene.replace(target_relative_density=0.5))


def test_a_window_without_width_refuses_a_relative_density():
    w = gp.VoidRatioLimits(0.2, 0.2, 0.0, 0.0, (0.2,), (0.2,), "core", 1)
    with pytest.raises(gp.InvalidParameterError, match="no width") as info:
        w.relative_density(0.2)
    assert info.value.parameter == "target_relative_density"


# -- the property: every sample granpack makes lies in its scene's window ---------------

#: Small scenes, each a few seconds a pack: 2D boxes of 4.1 (monodisperse) and 4.2
#: (polydisperse), as deposits (core phi) and consolidated (floor to lid).
_SCENES = {
    "4.1 box": BOX41,
    "4.1 box, 10 kPa": BOX41_C,
    "4.2 box, 10 kPa": BOX42_C,
}


@settings(
    max_examples=2,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)
@given(
    name=st.sampled_from(sorted(_SCENES)),
    seed=st.integers(1, 3),
    kind=st.sampled_from(["recipe", "target_relative_density", "target_phi"]),
    level=st.floats(0.0, 1.0),
    method=st.sampled_from(["auto", "deposition", "servo"]),
)
# a relative density that only the servo reaches
@example(name="4.2 box, 10 kPa", seed=1, kind="target_relative_density", level=0.9, method="auto")
def test_every_sample_lies_in_its_window_or_a_warning_says_why(name, seed, kind, level, method):
    scene = _SCENES[name].replace(seed=seed)
    if method == "servo" and scene.consolidate is None:
        method = "auto"
    scene = scene.replace(density_method=method)
    w = gp.void_ratio_limits(scene, packs=1)
    assert w.e_min <= w.e_max
    phis = [phi for *_, phi in w.points]
    assert w.phi_min == pytest.approx(min(phis), rel=1e-12)
    assert w.phi_max == pytest.approx(max(phis), rel=1e-12)
    tol = 0.002
    if kind == "target_relative_density":
        scene = scene.replace(target_relative_density=round(level, 4))
    elif kind == "target_phi":
        if w.phi_max - w.phi_min <= 2 * tol:
            return
        # inside the window by the tolerance: a sample within it of the target is inside
        scene = scene.replace(
            target_phi=round(w.phi_min + tol + level * (w.phi_max - w.phi_min - 2 * tol), 4)
        )
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            pack = gp.generate(scene)
        except gp.DensityTargetError as err:
            # a target inside the window is never refused as out of reach; a target the
            # search did not meet says so with the window measured, ordered
            assert "out of reach" not in str(err)
            assert not err.phi_min > err.phi_max
            return
    phi, _ = sample_phi(pack)
    e = 1.0 / phi - 1.0
    said = [c for c in caught if issubclass(c.category, DensityWindowWarning)]
    if said:
        assert "outside [0, 1]" in str(said[0].message)
    else:
        assert w.e_min <= e <= w.e_max
    others = [
        c
        for c in caught
        if not issubclass(c.category, (DensityWindowWarning, gp.UnsettledPackWarning))
    ]
    assert not others, [str(c.message) for c in others]
    if pack.record("density") is not None and "relative_density" in pack.record("density").table():
        assert (
            pack.record("density").table()["e_min"] == w.e_min
            and pack.record("density").table()["e_max"] == w.e_max
        )
        assert math.isclose(
            pack.record("density").table()["relative_density"], w.relative_density(e)
        )
