"""Oedometric loading and unloading, and isotropic compression: every stress of the list
held to equilibrium, in the box, the cylinder and the periodic cell; the unloading
stiffer than the loading (Cs < Cc); K0 from the walls (Love-Weber in the periodic
cell); and the refusals."""

from __future__ import annotations

import numpy as np
import pytest

import granpack as gp

SMALL = gp.PackScene.preset("4.3").replace(seed=3, base=(0.3, 0.3), height=0.2)
CONTAINERS = {
    "box": SMALL,
    "cylinder": SMALL.replace(container="cylinder", cylinder_radius=0.15),
    "periodic": SMALL.replace(container="periodic"),
}
PATH = [5e4, 1e5, 2e5, 4e5, 2e5, 1e5, 5e4]


@pytest.fixture(scope="module")
def samples() -> dict[str, gp.Pack]:
    """Each container's deposit consolidated oedometrically to 25 kPa."""
    return {
        name: gp.consolidate(gp.generate(sc.fast()), 2.5e4, gravity=False)
        for name, sc in CONTAINERS.items()
    }


@pytest.fixture(scope="module")
def oedometers(samples) -> dict[str, gp.Pack]:
    return {name: gp.oedometer(pack, PATH) for name, pack in samples.items()}


@pytest.mark.parametrize("name", list(CONTAINERS))
def test_each_stress_is_held_to_equilibrium(oedometers, name):
    out = oedometers[name]
    t = gp.element_table(out)
    assert t.height == len(PATH) + 1  # the start, then each stress
    assert t["target"].to_list()[1:] == PATH
    assert t["target"][0] == pytest.approx(2.5e4, rel=1e-3)
    s1, target = t["sigma_1"].to_numpy(), t["target"].to_numpy()
    assert np.all(np.abs(s1 - target) <= 1e-3 * target)
    assert t["unbalanced"].max() <= 1e-4
    # the steps grow along the path, one equilibrium after another
    assert np.all(np.diff(t["step"].to_numpy()) > 0)


@pytest.mark.parametrize("name", list(CONTAINERS))
def test_the_side_walls_stay_and_the_void_ratio_follows_the_stress(samples, oedometers, name):
    before, out = samples[name], oedometers[name]
    assert out.scene.base == before.scene.base
    t = gp.element_table(out)
    e = t["e"].to_numpy()
    load, unload = e[: len(PATH) // 2 + 2], e[len(PATH) // 2 + 1 :]
    assert np.all(np.diff(load) < 0), load
    assert np.all(np.diff(unload) > 0), unload
    # the same stress on the way down leaves a denser sample than on the way up
    assert e[-1] < e[1]


@pytest.mark.parametrize("name", list(CONTAINERS))
def test_unloading_is_stiffer_than_loading(oedometers, name):
    lab = oedometers[name].record("oedometer").report["lab"]
    assert 0.0 < lab["Cs"] < lab["Cc"], lab


@pytest.mark.parametrize("name", list(CONTAINERS))
def test_k0_on_loading_and_after_unloading(oedometers, name):
    """K0 = sigma_3 / sigma_1: below 1 on first loading (Jaky's 1 - sin phi, about 0.5 to
    0.8 for these grains), and larger after unloading, where the side walls keep the
    stress that the lid gave back (the overconsolidated K0 of the lab)."""
    t = gp.element_table(oedometers[name])
    k0 = t["k0"].to_numpy()
    top = len(PATH) // 2 + 1
    assert 0.3 < k0[top] < 0.95
    assert k0[-1] > k0[top] + 0.1
    assert np.allclose(k0, t["sigma_3"].to_numpy() / t["sigma_1"].to_numpy())


def test_the_periodic_cells_lateral_stress_is_love_weber(oedometers):
    t = gp.element_table(oedometers["periodic"])
    # in the cell sigma_3 is Love-Weber's mean horizontal entry, so lw_p is p
    assert np.allclose(t["lw_p"].to_numpy(), t["p"].to_numpy(), rtol=2e-2)


@pytest.fixture(scope="module")
def isotropic(samples) -> gp.Pack:
    iso = gp.consolidate(gp.generate(SMALL.fast()), 2.5e4, "isotropic", gravity=False)
    return gp.isotropic_compression(iso, [5e4, 1e5, 2e5, 1e5, 5e4])


def test_isotropic_compression_holds_every_wall_at_p(isotropic):
    t = gp.element_table(isotropic)
    assert t.height == 6
    for col in ("sigma_1", "sigma_3", "p"):
        v, target = t[col].to_numpy()[1:], t["target"].to_numpy()[1:]
        assert np.all(np.abs(v - target) <= 1e-3 * target), col
    assert np.all(np.abs(t["q"].to_numpy()[1:]) <= 2e-3 * t["p"].to_numpy()[1:])
    lab = isotropic.record("isotropic").report["lab"]
    assert 0.0 < lab["kappa_ln"] < lab["lambda_ln"]
    assert lab["lambda_ln"] == pytest.approx(lab["Cc"] / np.log(10.0), rel=1e-12)
    # the box's side walls moved with the stress
    assert isotropic.scene.base != SMALL.base


def test_a_periodic_cell_cannot_be_compressed_isotropically(samples):
    with pytest.raises(gp.InvalidParameterError, match="no side walls") as exc:
        gp.isotropic_compression(samples["periodic"], [1e5])
    assert exc.value.parameter == "container"


@pytest.mark.parametrize(
    ("stresses", "parameter"),
    [
        ([], "stresses"),
        ("1e5", "stresses"),
        (1e5, "stresses"),
        ([1e5, -1.0], "stresses[1]"),
        ([float("nan")], "stresses[0]"),
        ([0.0], "stresses[0]"),
        ([2e12], "stresses[0]"),
    ],
)
@pytest.mark.parametrize("test", [gp.oedometer, gp.isotropic_compression])
def test_bad_stress_lists_are_refused_naming_them(samples, test, stresses, parameter):
    with pytest.raises(gp.InvalidParameterError) as exc:
        test(samples["box"], stresses)
    assert exc.value.parameter == parameter


def test_an_unconsolidated_pack_is_refused():
    dep = gp.generate(SMALL.fast())
    for test in (gp.oedometer, gp.isotropic_compression):
        with pytest.raises(gp.InvalidParameterError, match="consolidate") as exc:
            test(dep, [1e5])
        assert exc.value.parameter == "pack"


def test_a_step_budget_too_small_says_how_far_it_got(samples):
    with pytest.raises(gp.ConsolidationError, match="max_steps"):
        gp.oedometer(samples["box"], [4e5], max_steps=200)
