"""YADE's drained triaxial compression of a granpack consolidated pack
(studies/triaxial_vs_yade/yade_triaxial.py): YADE starts from granpack's sample, re-seats
it at the consolidation's stresses, holds the confining stress, drives the lid at the set
speed, and its table is the element table's; and granpack's `triaxial` gives YADE's peak
and dilatancy on the same sample.

The samples: small 4.3 deposits consolidated isotropically to 100 kPa, sheared at inertial
number 1e-3: a 0.25 m box (235 spheres, to 20 % axial strain, 20 000 steps of YADE, a few
seconds) for YADE's own checks, a 0.4 m box (720 spheres, to 20 %, under a minute) for the
comparison with granpack. The program is the Debian package ``yade`` (2023.02a);
``.ci/run`` installs it."""

from __future__ import annotations

import json
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


def consolidated(base: float, height: float) -> gp.Pack:
    scene = gp.PackScene.preset("4.3").replace(base=(base, base), height=height, seed=1)
    return gp.consolidate(gp.generate(scene.fast()), CONFINING, mode="isotropic", wall_friction=0.0)


@pytest.fixture(scope="module")
def sample() -> gp.Pack:
    return consolidated(0.25, 0.25)


def run(yade, pack, folder, axial=AXIAL, **kw):
    """YADE's test of `pack` at I = 1e-3, a check every 0.25 % axial strain."""
    table = run_yade_triaxial(
        pack,
        CONFINING,
        axial,
        ("inertial_number", INERTIAL),
        kw.pop("dt", None),
        0.4,
        0.0025,
        folder,
        yade=yade,
        timeout=600,
        **kw,
    )
    return table, json.loads((Path(folder) / "summary.json").read_text())


@pytest.fixture(scope="module")
def yade_run(yade, sample, tmp_path_factory):
    # (the yade fixture first: without YADE nothing runs) the defaults: smooth walls, the
    # sample re-seated first, as granpack.triaxial's
    return run(yade, sample, tmp_path_factory.mktemp("yade_triaxial"))


def test_yade_starts_from_the_consolidated_stresses(yade, sample, tmp_path):
    # without re-seating, the first row is granpack's consolidated sample as it was saved
    table, summary = run(yade, sample, tmp_path, axial=0.0025, reseat=False)
    assert summary["reseat_steps"] == 0
    report = sample.record("consolidate").report
    first = table.row(0, named=True)
    assert first["step"] == 0 and first["eps_a"] == 0.0 and first["eps_v"] == 0.0
    # the same overlaps give the same Hertz normal forces: the walls' stresses are
    # granpack's to the digits the positions carry (YADE's tangential springs start at
    # zero; the normal forces do not depend on them)
    for col, wall in (
        ("sigma_1", "lid"),
        ("sigma_floor", "floor"),
        ("sigma_x_lo", "x_lo"),
        ("sigma_x_hi", "x_hi"),
        ("sigma_y_lo", "y_lo"),
        ("sigma_y_hi", "y_hi"),
    ):
        assert first[col] == pytest.approx(report["wall_stress"][wall], rel=1e-5)
    # the same box: YADE's walls stand where granpack's record puts them
    assert first["phi"] == pytest.approx(report["phi"], rel=1e-12)
    assert first["lid_height"] == pytest.approx(report["height"], rel=1e-12)


def test_yade_reseats_the_sample_at_the_consolidation_stresses(sample, yade_run):
    table, summary = yade_run
    rec = sample.record("consolidate")
    assert summary["reseat_converged"] is True and summary["reseat_steps"] > 0
    first = table.row(0, named=True)
    tol = rec.settings["stress_tol"]
    for col in ("sigma_1", "sigma_x_lo", "sigma_x_hi", "sigma_y_lo", "sigma_y_hi"):
        assert abs(first[col] / CONFINING - 1.0) <= tol
    assert first["unbalanced"] <= rec.settings["unbalanced_tol"]
    # H0 is taken there, and the strains count from it
    assert summary["H0"] == pytest.approx(first["lid_height"], rel=1e-12)
    assert first["eps_a"] == 0.0 and first["eps_v"] == 0.0


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
    table, summary = yade_run
    eps_dot = strain_rate(sample, CONFINING, INERTIAL)
    d_mean = 2.0 * float(np.mean(sample.radii))
    rho = sample.scene.material.density
    assert eps_dot == pytest.approx(INERTIAL / (d_mean * math.sqrt(rho / CONFINING)), rel=1e-12)
    assert summary["lid_speed"] == pytest.approx(eps_dot * summary["H0"], rel=1e-12)
    t = table["time"].to_numpy()
    # eps_a = v t / H0 at every check: the controller does not hold the lid back
    np.testing.assert_allclose(table["eps_a"].to_numpy(), eps_dot * t, rtol=1e-9, atol=1e-12)
    assert float(table["eps_a"][-1]) >= AXIAL - 1e-12
    steps = table["step"].to_numpy()
    np.testing.assert_allclose(t, steps * summary["dt"], rtol=1e-9)
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


def test_smooth_walls_pass_the_lid_load_to_the_floor(yade, sample, yade_run, tmp_path):
    # smooth walls (the default): the side walls carry no vertical load, so the floor
    # carries the lid's force, less the little that accelerates the sample (I = 1e-3)
    table, summary = yade_run
    assert summary["wall_friction"] == 0.0
    ratio = (table["sigma_floor"] / table["sigma_1"]).to_numpy()
    assert np.max(np.abs(ratio - 1.0)) < 0.06
    assert abs(float(np.median(ratio)) - 1.0) < 0.01
    # walls with the particles' friction hold part of it up (Janssen)
    frictional, summary = run(yade, sample, tmp_path, axial=0.05, wall_friction=None)
    assert summary["wall_friction"] == sample.scene.material.friction
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


def test_granpack_triaxial_agrees_with_yade(yade, tmp_path):
    if not hasattr(gp, "triaxial"):
        pytest.skip("this checkout has no granpack.triaxial stage yet")
    pack = consolidated(0.4, 0.3)
    out = gp.triaxial(pack, CONFINING, axial_strain=AXIAL, inertial_number=INERTIAL)
    settings = out.record("triaxial").settings
    # YADE at granpack's dt, walls' friction, rate and damping
    table, _ = run(
        yade, pack, tmp_path, dt=float(settings["dt"]), wall_friction=settings["wall_friction"]
    )
    mine = summary_figures(gp.element_table(out))
    theirs = summary_figures(table)
    assert mine["eta_peak"] == pytest.approx(theirs["eta_peak"], rel=0.05)
    assert abs(mine["phi_p_deg"] - theirs["phi_p_deg"]) <= 1.0
    assert theirs["eps_v_at_10pct"] is not None and mine["eps_v_at_10pct"] is not None
    assert mine["eps_v_at_10pct"] == pytest.approx(theirs["eps_v_at_10pct"], rel=0.20)
