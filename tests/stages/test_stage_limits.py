"""The consolidation stage's limits: every target stress is checked against the range the
Hertz law and the positions allow, by its own key, when the scene is built and when the
stage starts; a sample squeezed narrower than a pack's container may be is refused by the
stage in its own terms (the mode and the stress), not as a scene key the user never set."""

from __future__ import annotations

import math
import warnings

import pytest

import granpack as gp
from granpack._core import MIN_OVERLAP_RATIO, overlap_ratio, stress_range
from granpack.consolidation import hertz_overlap, stage_time_step

# a 2D box one particle wide: 6 discs in a column
COLUMN = gp.PackScene(
    dim=2, base=(0.022,), height=0.1, r_mean=0.01, h_layer=0.05, phi_layer=0.3, settle_time=0.3
)
# a 2D box ten particles wide
WIDE = gp.PackScene(
    dim=2, base=(0.2,), height=0.06, r_mean=0.01, h_layer=0.05, phi_layer=0.3, settle_time=0.3
)


def _deposit(scene: gp.PackScene) -> gp.Pack:
    with warnings.catch_warnings():
        # a short settle_time: the deposit need not be at rest for these checks
        warnings.simplefilter("ignore", gp.UnsettledPackWarning)
        return gp.generate(scene)


@pytest.fixture(scope="module")
def wide() -> gp.Pack:
    return _deposit(WIDE)


def test_stress_range_ends_are_the_overlaps_they_name():
    mat = gp.Material()
    for dim in (2, 3):
        lo, hi = stress_range(dim, 0.01, mat.e_star, 0.5)
        assert overlap_ratio(lo, dim, 0.01, mat.e_star) == pytest.approx(
            MIN_OVERLAP_RATIO, rel=1e-9
        )
        assert overlap_ratio(hi, dim, 0.01, mat.e_star) == pytest.approx(0.5, rel=1e-9)
        # the inverse of Hertz's law F = 4/3 E* sqrt(R*) d^(3/2), R* = r/2
        f = hi * 0.02 ** (dim - 1)
        assert hertz_overlap(f, 0.005, mat.e_star) == pytest.approx(0.005, rel=1e-9)


@pytest.mark.parametrize("value", [5e-324, 1e-300, 1e-12, 1e9, 1e12])
@pytest.mark.parametrize(
    ("table", "key"),
    [
        ({"mode": "oedometric"}, "stress"),
        ({"mode": "isotropic"}, "stress"),
        ({"mode": "anisotropic", "lateral": 1e3}, "stress"),
        ({"mode": "anisotropic", "stress": 1e3}, "lateral"),
    ],
)
def test_every_stress_key_out_of_range_is_refused_by_name_with_its_range(wide, table, key, value):
    table = {"stress": 1e3, **table, key: value}
    lo, hi = stress_range(2, WIDE.r_mean, WIDE.material.e_star, WIDE.max_overlap_ratio)
    # when the scene is built ...
    with pytest.raises(gp.InvalidParameterError) as err:
        WIDE.replace(consolidate=table)
    assert err.value.parameter == f"consolidate.{key}"
    assert f"must lie in [{lo:.3g}, {hi:.3g}] Pa" in str(err.value)
    # ... and by the stage itself, before any step
    kwargs = {k: v for k, v in table.items() if k != "stress"}
    with pytest.raises(gp.InvalidParameterError) as err:
        gp.consolidate(wide, table["stress"], **kwargs)
    assert err.value.parameter == f"consolidate.{key}"
    assert "must lie in [" in str(err.value)


def test_stresses_inside_the_range_build_a_scene():
    lo, hi = stress_range(2, WIDE.r_mean, WIDE.material.e_star, WIDE.max_overlap_ratio)
    for value in (lo * 1.001, math.sqrt(lo * hi), hi * 0.999):
        sc = WIDE.replace(consolidate={"stress": value, "mode": "isotropic"})
        assert sc.consolidate["stress"] == value


def test_lateral_pair_names_lateral():
    sc = gp.PackScene.preset("4.3").replace(base=(0.3, 0.3), height=0.2)
    with pytest.raises(gp.InvalidParameterError) as err:
        sc.replace(consolidate={"stress": 1e3, "mode": "anisotropic", "lateral": [1e3, 1e10]})
    assert err.value.parameter == "consolidate.lateral"


@pytest.mark.parametrize("dt", [1.0, 2e-4])
def test_stage_dt_beyond_the_rayleigh_step_is_refused_when_the_scene_is_built(dt):
    crit = WIDE.material.critical_time_step(WIDE.r_min)
    assert dt > crit
    with pytest.raises(gp.UnstableTimeStepError) as err:
        WIDE.replace(consolidate={"stress": 1e3, "dt": dt})
    assert err.value.parameter == "consolidate.dt"
    assert err.value.critical == crit
    with pytest.raises(gp.UnstableTimeStepError) as err:
        gp.PackScene.from_toml_string(
            WIDE.replace(consolidate=None).to_toml() + "[consolidate]\nstress = 1e3\ndt = 1.0\n"
        )
    assert err.value.parameter == "consolidate.dt"
    # at the step itself, it is taken
    assert WIDE.replace(consolidate={"stress": 1e3, "dt": crit}).consolidate["dt"] == crit


def test_stage_dt_beyond_the_rayleigh_step_is_refused_by_the_stage(wide):
    crit = WIDE.material.critical_time_step(float(wide.radii.min()))
    with pytest.raises(gp.UnstableTimeStepError) as err:
        gp.consolidate(wide, 1e3, dt=2.0 * crit)
    assert err.value.parameter == "consolidate.dt"


def test_side_walls_squeezed_below_a_diameter_are_refused_naming_the_stage():
    column = _deposit(COLUMN)
    assert len(column) >= 2
    with pytest.raises(gp.ConsolidationError) as err:
        gp.consolidate(column, 1e3, "isotropic")
    msg = str(err.value)
    assert "isotropic consolidation" in msg and "stress = 1000 Pa" in msg
    assert "2 r_max = 0.02 m" in msg and "oedometric" in msg
    assert "invalid base" not in msg
    assert err.value.steps > 0 and err.value.stress["lid"] == pytest.approx(1e3, rel=1e-2)
    # the same scene consolidated from its own table: the same error, from generate
    with pytest.raises(gp.ConsolidationError, match="isotropic consolidation"):
        _deposit(COLUMN.replace(consolidate={"stress": 1e3, "mode": "isotropic"}))
    # the oedometric stage keeps the side walls, and the sample
    done = gp.consolidate(column, 1e3, "oedometric")
    assert done.scene.base == COLUMN.base


def test_side_walls_that_stay_a_diameter_apart_keep_the_sample(wide):
    done = gp.consolidate(wide, 1e3, "isotropic")
    (width,) = done.scene.base
    assert 2 * WIDE.r_max <= width < WIDE.base[0]
    assert done.record("consolidate").table()["walls"]["x_hi"] - done.record("consolidate").table()[
        "walls"
    ]["x_lo"] == pytest.approx(width)


@pytest.mark.parametrize("stress", [5e-324, 1e-300, 0.0])
def test_the_stage_step_of_a_vanishing_stress_is_the_scene_s(wide, stress):
    # contacts no stress stiffens: the Rayleigh-bounded scene step holds
    assert stage_time_step(wide, stress) == WIDE.dt
