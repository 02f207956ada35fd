"""YADE's drained triaxial compression of a granpack consolidated pack
(studies/triaxial_vs_yade/yade_triaxial.py): YADE starts from granpack's sample, holds
the confining stress, drives the lid at the set speed, and its table is the element table's;
and, where this checkout has the stage, granpack's `triaxial` gives YADE's peak and
dilatancy.

The sample: a small 4.3 deposit (a 0.25 m box, about 240 spheres) consolidated isotropically
to 100 kPa, sheared to 20 % axial strain at inertial number 1e-3 (15 000 steps of YADE, a few
seconds). The program is the Debian package ``yade`` (2023.02a); ``.ci/run`` installs it."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

import granpack as gp
from granpack.errors import InvalidParameterError

STUDY = Path(__file__).resolve().parents[2] / "studies" / "triaxial_vs_yade"
sys.path.insert(0, str(STUDY))
from yade_triaxial import run_yade_triaxial, strain_rate, summary_figures  # noqa: E402

CONFINING = 1e5
INERTIAL = 1e-3
AXIAL = 0.20


def small_consolidated() -> gp.Pack:
    scene = gp.PackScene.preset("4.3").replace(base=(0.25, 0.25), height=0.25, seed=1)
    return gp.consolidate(gp.generate(scene.fast()), CONFINING, mode="isotropic")


@pytest.fixture(scope="module")
def sample() -> gp.Pack:
    return small_consolidated()


@pytest.fixture(scope="module")
def yade_run(yade, sample, tmp_path_factory):
    # (the yade fixture first: without YADE nothing runs)
    work = tmp_path_factory.mktemp("yade_triaxial")
    table = run_yade_triaxial(
        sample,
        CONFINING,
        AXIAL,
        ("inertial_number", INERTIAL),
        None,
        0.4,
        0.0025,
        work,
        yade=yade,
        timeout=600,
    )
    return table, work


def test_yade_starts_from_the_consolidated_stresses(sample, yade_run):
    table, _ = yade_run
    report = sample.record("consolidate").report
    first = table.row(0, named=True)
    assert first["step"] == 0 and first["eps_a"] == 0.0 and first["eps_v"] == 0.0
    # the same overlaps give the same Hertz normal forces: the lid's and the floor's
    # stresses are granpack's to the digits the positions carry (the tangential springs
    # start at zero in YADE, the normal forces do not depend on them)
    assert first["sigma_1"] == pytest.approx(report["wall_stress"]["lid"], rel=1e-5)
    assert first["sigma_floor"] == pytest.approx(report["wall_stress"]["floor"], rel=1e-5)
    for yade_col, gp_wall in (
        ("sigma_x_lo", "x_lo"),
        ("sigma_x_hi", "x_hi"),
        ("sigma_y_lo", "y_lo"),
        ("sigma_y_hi", "y_hi"),
    ):
        assert first[yade_col] == pytest.approx(report["wall_stress"][gp_wall], rel=1e-5)
    # the same box: YADE's walls stand where granpack's record puts them
    assert first["phi"] == pytest.approx(report["phi"], rel=1e-12)
    assert first["lid_height"] == pytest.approx(report["height"], rel=1e-12)


def test_yade_holds_the_confining_stress_along_the_path(yade_run):
    table, _ = yade_run
    s3 = table["sigma_3"].to_numpy()
    assert np.max(np.abs(s3 / CONFINING - 1.0)) < 0.02
    # each side wall, not only their mean
    for col in ("sigma_x_lo", "sigma_x_hi", "sigma_y_lo", "sigma_y_hi"):
        assert np.max(np.abs(table[col].to_numpy() / CONFINING - 1.0)) < 0.05
    # while the lid's stress rises well above it: the sample is sheared
    assert float(table["q"].max()) > 0.3 * CONFINING


def test_the_lid_moves_at_the_constant_speed_of_the_inertial_number(sample, yade_run):
    table, work = yade_run
    eps_dot = strain_rate(sample, CONFINING, INERTIAL)
    d_mean = 2.0 * float(np.mean(sample.radii))
    rho = sample.scene.material.density
    assert eps_dot == pytest.approx(INERTIAL / (d_mean * math.sqrt(rho / CONFINING)), rel=1e-12)
    t = table["time"].to_numpy()
    # eps_a = v t / H0 at every check: the controller does not hold the lid back
    np.testing.assert_allclose(table["eps_a"].to_numpy(), eps_dot * t, rtol=1e-9, atol=1e-12)
    assert float(table["eps_a"][-1]) >= AXIAL - 1e-12
    steps = table["step"].to_numpy()
    dt = sample.record("consolidate").settings["dt"]
    np.testing.assert_allclose(t, steps * dt, rtol=1e-12)
    assert np.all(np.diff(steps) == steps[1] - steps[0])


def test_yade_volumetric_strain_is_the_change_of_the_walls_volume(sample, yade_run):
    table, _ = yade_run
    w_x = table["width_x"].to_numpy()
    w_y = table["width_y"].to_numpy()
    h = table["lid_height"].to_numpy()
    v = w_x * w_y * h
    np.testing.assert_allclose(table["eps_v"].to_numpy(), 1.0 - v / v[0], rtol=1e-12, atol=1e-15)
    # the side walls move (the sample bulges and contracts): eps_v is not the axial strain
    lateral = 1.0 - (w_x * w_y) / (w_x[0] * w_y[0])
    assert np.max(np.abs(lateral)) > 0.01
    # phi and e from the same volume and the spheres' own
    solid = float(np.sum(4.0 / 3.0 * np.pi * sample.radii**3))
    np.testing.assert_allclose(table["phi"].to_numpy(), solid / v, rtol=1e-12)
    np.testing.assert_allclose(table["e"].to_numpy(), v / solid - 1.0, rtol=1e-12)
    # p, q and eta as the element table defines them
    s1, s3 = table["sigma_1"].to_numpy(), table["sigma_3"].to_numpy()
    np.testing.assert_allclose(table["p"].to_numpy(), (s1 + 2.0 * s3) / 3.0, rtol=1e-12)
    np.testing.assert_allclose(table["eta"].to_numpy(), (s1 - s3) / ((s1 + 2.0 * s3) / 3.0))


def test_frictionless_walls_pass_the_lid_load_to_the_floor(yade, sample, yade_run, tmp_path):
    # frictionless walls: the side walls carry no vertical load, so once the tangential
    # forces of granpack's frictional consolidation are gone (the first rows) the floor
    # carries the lid's force, less the little that accelerates the sample (I = 1e-3)
    table = run_yade_triaxial(
        sample,
        CONFINING,
        0.05,
        ("inertial_number", INERTIAL),
        None,
        0.4,
        0.0025,
        tmp_path,
        wall_friction=0.0,
        yade=yade,
        timeout=600,
    )
    ratio = (table["sigma_floor"] / table["sigma_1"]).to_numpy()[1:]
    assert np.max(np.abs(ratio - 1.0)) < 0.06
    assert abs(float(np.median(ratio)) - 1.0) < 0.01
    # walls with the particles' friction (granpack's) hold part of it up
    frictional, _ = yade_run
    ratio = (frictional["sigma_floor"] / frictional["sigma_1"]).to_numpy()[1:]
    assert np.max(ratio) < 0.95


def test_an_unconsolidated_pack_is_refused(tmp_path):
    deposit = gp.generate(
        gp.PackScene.preset("4.3").replace(base=(0.15, 0.15), height=0.1, seed=1).fast()
    )
    with pytest.raises(InvalidParameterError, match="not consolidated") as err:
        run_yade_triaxial(
            deposit, CONFINING, 0.1, ("inertial_number", 1e-3), None, 0.4, 0.01, tmp_path
        )
    assert err.value.parameter == "pack"


@pytest.mark.parametrize(
    ("rate", "axial"),
    [(("inertial_number", -1e-3), 0.1), (("speed", 0.1), 0.1), (("lid_speed", 0.1), 1.5)],
)
def test_a_bad_rate_or_strain_is_refused_by_name(sample, tmp_path, rate, axial):
    with pytest.raises(InvalidParameterError) as err:
        run_yade_triaxial(sample, CONFINING, axial, rate, None, 0.4, 0.01, tmp_path)
    assert err.value.parameter in ("strain_rate_or_lid_speed", "axial_strain")
    assert not (tmp_path / "yade.log").exists()  # refused before YADE starts


def test_a_wall_friction_above_the_particles_is_refused(sample, tmp_path):
    with pytest.raises(InvalidParameterError, match="wall_friction") as err:
        run_yade_triaxial(
            sample,
            CONFINING,
            0.1,
            ("inertial_number", 1e-3),
            None,
            0.4,
            0.01,
            tmp_path,
            wall_friction=0.5,
        )
    assert err.value.parameter == "wall_friction"
    assert not (tmp_path / "yade.log").exists()  # refused before YADE starts


def test_granpack_triaxial_agrees_with_yade(yade, sample, tmp_path):
    if not hasattr(gp, "triaxial"):
        pytest.skip("this checkout has no granpack.triaxial stage yet")
    out = gp.triaxial(sample, CONFINING, axial_strain=AXIAL, inertial_number=INERTIAL)
    dt = float(out.record("triaxial").settings["dt"])
    # YADE at granpack's dt, rate and damping
    table = run_yade_triaxial(
        sample,
        CONFINING,
        AXIAL,
        ("inertial_number", INERTIAL),
        dt,
        0.4,
        0.0025,
        tmp_path,
        yade=yade,
        timeout=600,
    )
    mine = summary_figures(gp.element_table(out))
    theirs = summary_figures(table)
    assert mine["eta_peak"] == pytest.approx(theirs["eta_peak"], rel=0.05)
    assert abs(mine["phi_p_deg"] - theirs["phi_p_deg"]) <= 1.0
    assert theirs["eps_v_at_10pct"] is not None and mine["eps_v_at_10pct"] is not None
    assert mine["eps_v_at_10pct"] == pytest.approx(theirs["eps_v_at_10pct"], rel=0.20)
