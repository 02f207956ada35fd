"""What each stage that lowers friction does with the rolling model: the material it
builds for each phase, checked without running the phases (the layer loop and the servo
are stood in for, so that only the choice of material is under test).

- the deposit jams with the phase's friction and rolling friction, and the pack keeps
  the scene's material;
- the density window (`void_ratio_limits`) and the target's search jam at every
  deposition friction with the material's rolling model, except the frictionless jam,
  which has no rolling resistance either, and, for a material with a rolling model, at
  the material's friction with each rolling friction of MU_R_GRID;
- the servo keeps the rolling model in every phase but the one at zero friction.
"""

from __future__ import annotations

import copy
import dataclasses
import math

import pytest
from scenes import tiny_periodic_2d

import granpack as gp
from granpack import consolidation, density
from granpack._contact_model import model_record, model_text, phase_material
from granpack.density import MU_DEP_GRID, MU_R_GRID
from granpack.errors import DensityTargetError
from granpack.stages import deposit

ROLLING = gp.Material(
    friction=0.3, rolling="epsd", rolling_friction=0.1, rolling_stiffness=40.0, rolling_damping=0.5
)


@pytest.fixture(scope="module")
def tiny_pack() -> gp.Pack:
    return gp.generate(tiny_periodic_2d())


def _scene(material: gp.Material) -> gp.PackScene:
    return tiny_periodic_2d().replace(material=material)


# -- the phase's material ---------------------------------------------------------------


def test_a_lower_friction_keeps_the_rolling_model_whole():
    mat = phase_material(ROLLING, friction=0.05)
    assert mat == dataclasses.replace(ROLLING, friction=0.05)


def test_a_zero_rolling_friction_is_no_rolling_model_at_all():
    mat = phase_material(ROLLING, friction=0.0, rolling_friction=0.0)
    assert mat == gp.Material(friction=0.0)
    assert model_record(mat) == {"contact_law": "hertz_mindlin", "rolling": "none"}


def test_another_rolling_friction_keeps_the_rolling_spring_and_dashpot():
    mat = phase_material(ROLLING, rolling_friction=0.4)
    assert (mat.rolling, mat.rolling_friction) == ("epsd", 0.4)
    assert (mat.rolling_stiffness, mat.rolling_damping, mat.friction) == (40.0, 0.5, 0.3)


def test_a_rolling_friction_gives_a_material_without_one_the_default_epsd_model():
    mat = phase_material(gp.Material(), rolling_friction=0.2)
    assert mat == gp.Material(rolling="epsd", rolling_friction=0.2)
    # and zero leaves a material without rolling as it is
    plain = gp.Material()
    assert phase_material(plain, friction=0.0, rolling_friction=0.0) == gp.Material(friction=0.0)


def test_a_phase_at_the_materials_own_constants_is_the_material_itself():
    assert phase_material(ROLLING) is ROLLING
    assert phase_material(ROLLING, friction=0.3, rolling_friction=0.1) is ROLLING


def test_the_linear_law_is_kept_in_every_phase():
    lin = gp.Material(
        contact_law="linear", normal_stiffness=1e4, rolling="epsd", rolling_friction=0.1
    )
    mat = phase_material(lin, friction=0.0, rolling_friction=0.0)
    assert (mat.contact_law, mat.normal_stiffness, mat.rolling) == ("linear", 1e4, "none")


def test_the_report_line_names_the_law_and_every_constant():
    assert model_text(gp.Material()) == (
        "Contact model: Hertz-Mindlin (E = 1e+08 Pa, nu = 0.25, damping ratio 0.1, "
        "mu = 0.2), no rolling resistance."
    )
    text = model_text(ROLLING)
    for part in ("mu = 0.3", "epsd", "mu_r = 0.1", "k_r = 40 N/m", "gamma_r = 0.5 N s/m"):
        assert part in text
    lin = gp.Material(
        contact_law="linear", normal_stiffness=1e4, rolling="epsd", rolling_friction=0.1
    )
    assert "linear (k_n = 10000 N/m, k_t = 8571.43 N/m" in model_text(lin)
    assert "k_r = 2.25 mu_r^2 k_n (the default)" in model_text(lin)


# -- the deposit ------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("spec", "expected"),
    [
        (deposit.Spec(), ROLLING),
        (deposit.Spec(friction=0.6), dataclasses.replace(ROLLING, friction=0.6)),
        (deposit.Spec(friction=0.0, rolling_friction=0.0), gp.Material(friction=0.0)),
        (
            deposit.Spec(rolling_friction=0.4),
            dataclasses.replace(ROLLING, rolling_friction=0.4),
        ),
    ],
    ids=["recipe", "friction", "frictionless", "rolling_friction"],
)
def test_the_deposit_jams_with_the_phase_material_and_keeps_the_scene(
    monkeypatch, tiny_pack, spec, expected
):
    jams = []

    def layer_loop(scene, progress, _stacklevel=2):
        jams.append(scene)
        return dataclasses.replace(tiny_pack, scene=scene)

    monkeypatch.setattr(deposit._pack, "deposit", layer_loop)
    scene = _scene(ROLLING)
    pack = deposit.run(scene, spec)
    assert [s.material for s in jams] == [expected]
    # every other key of the scene is the scene's
    assert jams[0].replace(material=ROLLING) == scene
    assert pack.scene is scene


# -- the density window and the search ----------------------------------------------------


class _Stub:
    """The stage list stood in for: each call returns a pack (the tiny one, its scene
    the scene's) and keeps the jam it was asked for and whether a settling followed;
    `phi` gives each pack's phi by its jam."""

    def __init__(self, tiny_pack, phi):
        self.tiny = tiny_pack
        self.phi = phi
        self.jams: list[tuple[float, float | None, bool]] = []
        self.by_pack: dict[int, float] = {}

    def run(self, scene, steps, progress=False, *, _stacklevel=2):
        spec = next(s.spec for s in steps if s.stage == "deposit")
        settles = any(s.stage == "rest" for s in steps)
        assert not any(s.stage == "consolidate" for s in steps)
        self.jams.append((spec.friction, spec.rolling_friction, settles))
        jam_mat = phase_material(scene.material, spec.friction, spec.rolling_friction)
        pack = dataclasses.replace(self.tiny, scene=scene)
        self.by_pack[id(pack)] = self.phi(jam_mat)
        return pack

    def measured(self, pack, parameter, value):
        return self.by_pack[id(pack)]


def _loosening(mat: gp.Material) -> float:
    """A stand-in phi: looser with the jam's friction and, more, its rolling friction."""
    mu_r = mat.rolling_friction if mat.rolling != "none" else 0.0
    return 0.84 - 0.03 * mat.friction - 0.1 * mu_r


@pytest.fixture
def stub(monkeypatch, tiny_pack):
    s = _Stub(tiny_pack, _loosening)
    monkeypatch.setattr(density.stages, "run", s.run)
    monkeypatch.setattr(density, "_measured_phi", s.measured)
    return s


def test_the_window_of_a_rolling_material_also_varies_mu_r_at_its_friction(stub):
    lim = density.void_ratio_limits(_scene(ROLLING), packs=1)
    line = sorted({*MU_DEP_GRID, 0.3})
    rolls = sorted({*MU_R_GRID, 0.1} - {0.1})
    # the deposition frictions with the material's mu_r, but no rolling at mu_dep = 0,
    # then the material's friction with each mu_r of the grid
    expected = [(0.0, 0.0)] + [(mu, 0.1) for mu in line[1:]] + [(0.3, r) for r in rolls]
    assert [(f, r) for f, r, _ in stub.jams] == expected
    assert [(p[2], r) for p, r in zip(lim.points, lim.rolling_frictions, strict=True)] == expected
    # a jam above the material's friction or rolling friction settles once restored
    assert [s for *_, s in stub.jams] == [f > 0.3 or r > 0.1 for f, r in expected]
    # the loose end is the loosest pack: the largest mu_r, named with both knobs
    assert lim.e_max_from == ("layers jammed at mu_dep = 0.3, mu_r = 0.4",)
    assert lim.e_max == pytest.approx(1.0 / (0.84 - 0.009 - 0.04) - 1.0, rel=1e-12)
    assert lim.e_min_from == ("layers jammed at mu_dep = 0, mu_r = 0",)
    assert lim.e_min == pytest.approx(1.0 / 0.84 - 1.0, rel=1e-12)


def test_the_window_of_a_material_without_rolling_has_the_deposition_grid_only(stub):
    lim = density.void_ratio_limits(_scene(gp.Material()), packs=1)
    frictions = sorted({*MU_DEP_GRID, 0.2})
    # the deposit is asked for no rolling friction at all, as before the rolling model
    assert stub.jams == [(mu, None, mu > 0.2) for mu in frictions]
    assert [p[2] for p in lim.points] == frictions
    assert lim.rolling_frictions == ()
    assert lim.e_max_from == ("layers jammed at mu_dep = 1",)
    assert lim.e_min_from == ("layers jammed at mu_dep = 0",)


def test_a_frictionless_rolling_material_keeps_its_rolling_in_the_recipe(stub):
    mat = dataclasses.replace(ROLLING, friction=0.0)
    density.void_ratio_limits(_scene(mat), packs=1)
    jams = [(f, r) for f, r, _ in stub.jams]
    # the recipe (mu_dep = 0 with mu_r 0.1) is jammed as the material is, and the
    # rolling-free frictionless jam comes from the rolling frictions' grid
    assert jams[0] == (0.0, 0.1)
    assert (0.0, 0.0) in jams
    assert len(jams) == len(set(jams))


def test_a_target_looser_than_every_deposition_friction_is_met_by_rolling_friction(stub):
    # the deposition frictions reach phi 0.84 - 0.03 - 0.01 = 0.80 at the loosest;
    # rolling friction 0.4 reaches 0.791
    scene = _scene(ROLLING).replace(target_phi=0.795, density_tol=0.0005)
    pack = density.generate_at_density(scene)
    rec = pack.record("density")
    assert rec is not None
    assert rec.report["method"] == "deposition"
    assert rec.report["friction"] == 0.3
    mu_r = rec.report["rolling_friction"]
    assert 0.2 < mu_r < 0.4
    assert abs(rec.report["phi"] - 0.795) <= 0.0005
    assert rec.report["phi"] == pytest.approx(0.84 - 0.009 - 0.1 * mu_r, rel=1e-12)
    # every pack of the search is named by both knobs
    assert all({"friction", "rolling_friction"} <= set(h) for h in rec.report["history"])
    # the pack keeps the scene's material
    assert pack.scene.material == ROLLING


def test_without_rolling_the_same_target_is_out_of_reach(stub):
    scene = _scene(gp.Material(friction=0.3))
    with pytest.raises(DensityTargetError) as info:
        density.generate_at_density(scene.replace(target_phi=0.795, density_tol=0.0005))
    assert info.value.phi_min == pytest.approx(0.84 - 0.03, rel=1e-12)
    assert "mu_r" not in str(info.value)


# -- the servo ------------------------------------------------------------------------------


class _Engine:
    """The servo's engine stood in for: phi grows as the friction falls, and more where
    rolling resistance is off, and keeps the densest it reached (a pack does not loosen
    when the friction is restored); it logs every friction and rolling friction it is
    set to (one log for every clone)."""

    def __init__(self, mu0: float, mu_r0: float | None):
        self.mu, self.mu_r = mu0, mu_r0
        self.densest = 0.0
        self.calls: list[tuple[str, float]] = []

    def set_friction(self, mu):
        self.calls.append(("friction", mu))
        self.mu = mu

    def set_rolling_friction(self, mu_r):
        self.calls.append(("rolling_friction", mu_r))
        self.mu_r = mu_r

    def clone(self):
        return copy.copy(self)

    def phi(self) -> float:
        now = 0.80 + 0.05 * (1.0 - self.mu / 0.3) + (0.01 if not self.mu_r else 0.0)
        self.densest = max(self.densest, now)
        return self.densest


class _Sim:
    def __init__(self, engine):
        self._sim = engine


def _servo(mat, target, tol=0.002):
    sim = _Sim(_Engine(mat.friction, mat.rolling_friction))
    try:
        _, record = consolidation._lower_friction(
            sim, lambda: {"steps": 10}, lambda: sim._sim.phi(), {"steps": 10}, target, tol, mat
        )
    except DensityTargetError as e:
        return sim._sim, None, e
    return sim._sim, record, None


def test_the_servo_keeps_the_rolling_model_above_zero_friction():
    engine, record, error = _servo(ROLLING, 0.82)
    assert error is None
    assert all(mu > 0.0 for kind, mu in engine.calls if kind == "friction")
    # every phase sets the material's own mu_r, the restored one included
    assert {mu_r for kind, mu_r in engine.calls if kind == "rolling_friction"} == {0.1}
    assert all(p["rolling_friction"] == 0.1 for p in record["phases"])
    assert (engine.mu, engine.mu_r) == (0.3, 0.1)


def test_the_servo_turns_rolling_off_at_zero_friction_and_back_on_after():
    # 0.86 is reached only at zero friction without rolling resistance
    engine, record, error = _servo(ROLLING, 0.86, tol=0.002)
    assert error is None
    zero = [k for k, c in enumerate(engine.calls) if c == ("friction", 0.0)]
    assert zero and engine.calls[zero[0] + 1] == ("rolling_friction", 0.0)
    assert [p["rolling_friction"] for p in record["phases"] if p["friction"] == 0.0] == [0.0]
    # the densest state, kept once the friction and the rolling model are restored
    assert record["phases"][-1]["phi"] == pytest.approx(0.86, rel=1e-12)
    assert engine.calls[-2:] == [("friction", 0.3), ("rolling_friction", 0.1)]


def test_the_servo_leaves_a_material_without_rolling_alone():
    engine, record, error = _servo(gp.Material(friction=0.3), 0.99)
    assert record is None and error is not None
    # the window's dense end: zero friction
    assert error.phi_max == pytest.approx(0.86, rel=1e-12)
    assert all(kind == "friction" for kind, _ in engine.calls)
    assert math.isfinite(error.phi_min)
