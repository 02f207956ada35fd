"""A drained triaxial compression of one small granpack consolidated sample in LIGGGHTS
(studies/triaxial_vs_liggghts/liggghts_triaxial.py: the lid at granpack's constant speed,
the side walls servo-held at sigma_3 times their current area, frictionless walls) beside
`granpack.triaxial` with no local damping: LIGGGHTS holds sigma_3 along the path, starts
from the consolidated lid stress, and its q/p at 5 % axial strain is granpack's.

LIGGGHTS is the Debian package ``liggghts`` (3.8.0); about 270 spheres, a few seconds."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import granpack as gp

STUDY = Path(__file__).resolve().parents[2] / "studies" / "triaxial_vs_liggghts"
SIGMA_3 = 1e5  # Pa, the isotropic consolidation's target
EPS = 0.05


@pytest.fixture(scope="module")
def runs(tmp_path_factory, liggghts):
    sys.path.insert(0, str(STUDY))
    try:
        import liggghts_triaxial as lt
    finally:
        sys.path.remove(str(STUDY))
    scene = gp.PackScene.preset("4.3").replace(seed=3, base=(0.3, 0.3), height=0.2)
    pack = gp.consolidate(gp.generate(scene), SIGMA_3, "isotropic", wall_friction=0.0)
    out = gp.triaxial(pack, axial_strain=EPS, local_damping=0.0)
    rec = out.record("triaxial")
    s, cons = rec.settings, pack.record("consolidate").settings
    setup = lt.Setup(
        dt=s["dt"],
        lid_speed=s["lid_speed"],
        steps=int(rec.steps),
        check_every=max(1, int(rec.steps) // 49),
        confining=s["confining"],
        reseat_steps=int(s["reseat_steps"]),
        wall_vel_max=s["max_wall_speed"],
        lid_stress=float(cons["targets"]["lid"]),
        lid_vel_max=float(cons["max_wall_speed"]),
    )
    res = lt.run(pack, tmp_path_factory.mktemp("triaxial_liggghts"), setup, program=liggghts)
    return gp.element_table(out), res["table"], setup


def eta_at(table, eps: float) -> float:
    return float(np.interp(eps, table["eps_a"].to_numpy(), table["eta"].to_numpy()))


def test_liggghts_holds_sigma_3_along_the_path(runs):
    _, table, _ = runs
    s3 = table["sigma_3"].to_numpy()
    assert np.max(np.abs(s3 / SIGMA_3 - 1.0)) < 0.03
    # the target the servos follow is sigma_3 times each wall's current area
    assert np.allclose(table["target_sigma_3"].to_numpy(), SIGMA_3, rtol=1e-6)


def test_liggghts_starts_at_the_consolidated_lid_stress(runs):
    _, table, _ = runs
    assert table["sigma_1"][0] == pytest.approx(SIGMA_3, rel=0.03)
    assert table["eps_a"][0] == 0.0 and table["eps_v"][0] == 0.0


def test_liggghts_lid_moves_at_granpacks_speed_to_the_same_strain(runs):
    granpack, table, setup = runs
    assert table["step"][-1] == setup.steps
    # the same lid travel over slightly different start heights (each code's re-seat)
    assert table["eps_a"][-1] == pytest.approx(granpack["eps_a"][-1], rel=0.02)
    assert np.all(np.diff(table["eps_a"].to_numpy()) > 0)


def test_granpack_and_liggghts_mobilise_the_same_q_over_p_at_5_percent(runs):
    granpack, table, _ = runs
    eps = min(EPS, float(table["eps_a"][-1]), float(granpack["eps_a"][-1]))
    g, lg = eta_at(granpack, eps), eta_at(table, eps)
    assert g > 0.2  # the sample is sheared, not at rest
    assert lg == pytest.approx(g, rel=0.15)
