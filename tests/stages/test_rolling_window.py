"""The density window of a material with rolling resistance, run through the engine: a
small 2D deposit of the paper's 4.2 discs with mu_r = 0.2, consolidated to 10 kPa.

The window holds the deposition frictions at the material's mu_r (none at mu_dep = 0),
the servo's frictionless end, and the material's friction at each mu_r of MU_R_GRID; its
ends are the extremes over all of them, named by both knobs."""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest
from scenes import small_scene

import granpack as gp
from granpack.density import MU_DEP_GRID, MU_R_GRID, _deposit_at
from granpack.pack import UnsettledPackWarning

BASE = small_scene(2).replace(consolidate={"stress": 1e4}).fast()
MAT = dataclasses.replace(BASE.material, rolling="epsd", rolling_friction=0.2)
SCENE = BASE.replace(material=MAT)


@pytest.fixture(scope="module")
def window() -> gp.VoidRatioLimits:
    return gp.void_ratio_limits(SCENE, packs=1)


def test_the_window_measures_every_jam_of_both_grids_and_the_servo(window):
    mu0 = MAT.friction
    line = [(mu, 0.0 if mu == 0.0 else 0.2) for mu in sorted({*MU_DEP_GRID, mu0})]
    rolls = [(mu0, r) for r in MU_R_GRID if r != 0.2]
    got = [(p[1], p[2], r) for p, r in zip(window.points, window.rolling_frictions, strict=True)]
    deposition = [(mu, r) for m, mu, r in got if m == "deposition"]
    assert deposition == line + rolls
    # the servo's end, at zero friction, without rolling resistance
    assert [(mu, r) for m, mu, r in got if m == "servo"] == [(0.0, 0.0)]


def test_the_ends_are_the_extremes_over_every_pack_named_by_both_knobs(window):
    phis = [p[3] for p in window.points]
    assert window.e_max == 1.0 / min(phis) - 1.0
    assert window.e_min == 1.0 / max(phis) - 1.0
    loosest = int(np.argmin(phis))
    _, mech, mu, _ = window.points[loosest]
    mu_r = window.rolling_frictions[loosest]
    assert mech == "deposition"
    assert window.e_max_from == (f"layers jammed at mu_dep = {mu:g}, mu_r = {mu_r:g}",)
    densest = int(np.argmax(phis))
    _, mech, mu, _ = window.points[densest]
    mu_r = window.rolling_frictions[densest]
    assert window.e_min_from == (
        "the recipe's sample, friction lowered to zero under the servo (rolling resistance off)"
        if mech == "servo"
        else f"layers jammed at mu_dep = {mu:g}, mu_r = {mu_r:g}",
    )


def test_the_frictionless_jam_has_no_rolling_resistance_and_the_others_keep_it():
    plain = BASE.replace(material=dataclasses.replace(MAT, rolling="none", rolling_friction=None))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UnsettledPackWarning)
        # mu_dep = 0 with mu_r = 0 is the same jam as the material without rolling
        a = _deposit_at(SCENE, 0.0, rolling_friction=0.0)
        b = _deposit_at(plain, 0.0, rolling_friction=0.0)
        np.testing.assert_array_equal(a.positions, b.positions)
        assert a.scene.material == MAT
        # at mu_dep = 0.1 the rolling resistance is kept: another deposit
        c = _deposit_at(SCENE, 0.1, rolling_friction=0.2)
        d = _deposit_at(plain, 0.1, rolling_friction=0.0)
        assert not np.array_equal(c.positions, d.positions)
