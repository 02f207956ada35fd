"""A scene's ``[triaxial]``, ``[oedometer]`` or ``[isotropic]`` table: the element test
runs after the consolidation, as the function would on the consolidated pack; the table
goes through TOML and the pack file; a scene without one keeps its TOML (and so its
digest) as before; a bad table is a typed error naming ``<test>.<key>``."""

from __future__ import annotations

import hashlib
import warnings

import pytest

import granpack as gp
from granpack import stages
from granpack.analysis.result import MicrostructureWarning
from granpack.contacts import LID_ID

SMALL = gp.PackScene.preset("4.3").replace(seed=3, base=(0.3, 0.3), height=0.2).fast()
CONSOLIDATE = {"stress": 1e5, "mode": "isotropic", "gravity": False, "wall_friction": 0.0}
TRIAXIAL = {"axial_strain": 0.05, "checks": 6}
STRESSES = [150e3, 200e3, 150e3]


@pytest.fixture(scope="module")
def triaxial_pack() -> gp.Pack:
    return gp.generate(SMALL.replace(consolidate=CONSOLIDATE, triaxial=TRIAXIAL))


def test_the_element_tests_run_after_the_consolidation_and_before_the_tiling():
    names = [name for name, _ in stages.STAGES]
    assert names == ["deposit", "rest", "consolidate", *stages.ELEMENT_STAGES, "tile"]
    scene = SMALL.replace(consolidate=CONSOLIDATE, oedometer={"stresses": STRESSES})
    assert [s.stage for s in stages.plan(scene)] == ["deposit", "consolidate", "oedometer"]
    assert stages.plan(scene)[-1].spec == {"stresses": STRESSES}


def test_a_triaxial_table_gives_the_pack_the_function_gives(triaxial_pack):
    assert [r.stage for r in triaxial_pack.history][-2:] == ["consolidate", "triaxial"]
    # the same test by hand, on the same scene's consolidated deposit
    by_hand = gp.triaxial(gp.consolidate(gp.generate(SMALL), **CONSOLIDATE), **TRIAXIAL)
    assert (triaxial_pack.positions == by_hand.positions).all()
    assert gp.element_table(triaxial_pack).equals(gp.element_table(by_hand))
    assert triaxial_pack.scene.triaxial == TRIAXIAL


def test_the_pack_file_keeps_the_scene_table(triaxial_pack, tmp_path):
    back = gp.load_pack(triaxial_pack.save(tmp_path / "tri.npz"))
    assert back.scene == triaxial_pack.scene
    assert back.scene.triaxial == TRIAXIAL
    assert gp.element_table(back).equals(gp.element_table(triaxial_pack))


def test_the_analysis_takes_the_lid_where_the_test_left_it(triaxial_pack):
    # the lid moved down 5 % after the consolidation: the analysis' sample ends there,
    # and the lid's contacts are the particles that reach above it
    lid = triaxial_pack.record("triaxial").report["walls"]["lid"]
    assert lid == pytest.approx(triaxial_pack.height)
    assert lid < triaxial_pack.record("consolidate").report["walls"]["lid"] * 0.97
    with pytest.warns(MicrostructureWarning, match="core window is empty"):
        m = gp.microstructure(triaxial_pack)
    assert m.phi == pytest.approx(gp.element_table(triaxial_pack)["phi"][-1], rel=1e-9)
    top = triaxial_pack.positions[:, -1] + triaxial_pack.radii
    c = triaxial_pack.contacts
    assert set(c.i[c.j == LID_ID]) <= set((top > lid).nonzero()[0])


def test_an_oedometer_table_holds_each_stress_in_turn():
    scene = SMALL.replace(consolidate=CONSOLIDATE, oedometer={"stresses": STRESSES})
    pack = gp.generate(scene)
    assert [r.stage for r in pack.history][-2:] == ["consolidate", "oedometer"]
    table = gp.element_table(pack, "oedometer")
    # the sample as consolidated, then one row per stress
    assert table["target"].to_list()[1:] == STRESSES
    assert ((table["sigma_1"] / table["target"] - 1.0).abs() <= 1e-3 * (1 + 1e-9)).all()


def test_a_density_target_runs_the_test_on_the_sample_it_finds():
    scene = SMALL.replace(
        consolidate=CONSOLIDATE, target_phi=0.59, density_method="servo", triaxial=TRIAXIAL
    )
    pack = gp.generate(scene)
    assert [r.stage for r in pack.history][-3:] == ["consolidate", "density", "triaxial"]
    at_target = gp.generate(scene.replace(triaxial=None))
    assert at_target.history[-1].stage == "density"
    by_hand = gp.triaxial(at_target, **TRIAXIAL)
    assert (pack.positions == by_hand.positions).all()
    assert gp.element_table(pack).equals(gp.element_table(by_hand))


@pytest.mark.parametrize(
    ("key", "table"),
    [
        ("triaxial", {"confining": 8e4, "axial_strain": 0.2, "constant_p": True, "gain": 0.3}),
        ("oedometer", {"stresses": STRESSES, "hold": 3, "wall_friction": 0.1}),
        ("isotropic", {"stresses": [2e5, 4e5], "stress_tol": 1e-4, "gravity": True}),
    ],
)
def test_a_toml_round_trip_keeps_the_tables(key, table):
    scene = SMALL.replace(consolidate=CONSOLIDATE, **{key: table})
    text = scene.to_toml()
    assert f"[{key}]" in text
    back = gp.PackScene.from_toml_string(text)
    assert back == scene
    assert getattr(back, key) == table
    assert back.to_toml() == text


def test_a_none_that_means_the_default_is_left_out():
    scene = SMALL.replace(consolidate=CONSOLIDATE, triaxial={"confining": None, "dt": None})
    assert scene.triaxial == {}
    assert gp.PackScene.from_toml_string(scene.to_toml()) == scene


#: sha256 of `to_toml()` of scenes without an element table, as granpack wrote them
#: before the scene had element tables: the pack files, ensembles and tilings that
#: record a scene's digest keep it.
DIGESTS = {
    "4.1": "98d64118645e9306e88ef3729a694de5380a1696c73903eda57f99c1a2c58976",
    "consolidated": "02e4d5ac74ee802a66a0e5193bed894b00efc02259b701b9981a6c4a456f9a11",
}


def test_a_scene_without_element_tables_keeps_its_toml_and_digest():
    scenes = {
        "4.1": gp.PackScene.preset("4.1"),
        # the table as it was before wall_friction existed
        "consolidated": SMALL.replace(
            consolidate={"stress": 1e5, "mode": "isotropic", "gravity": False}
        ),
    }
    for name, scene in scenes.items():
        text = scene.to_toml()
        assert hashlib.sha256(text.encode()).hexdigest() == DIGESTS[name], name
        for key in ("triaxial", "oedometer", "isotropic"):
            assert f"[{key}]" not in text
            assert getattr(scene, key) is None


@pytest.mark.parametrize(
    ("key", "table", "parameter"),
    [
        ("triaxial", {"axial_strian": 0.1}, "triaxial.axial_strian"),
        ("triaxial", {"axial_strain": 1.0}, "triaxial.axial_strain"),
        ("triaxial", {"confining": -5.0}, "triaxial.confining"),
        ("triaxial", {"inertial_number": 0.5}, "triaxial.inertial_number"),
        ("triaxial", {"checks": 1}, "triaxial.checks"),
        ("triaxial", {"constant_p": "yes"}, "triaxial.constant_p"),
        ("triaxial", {"gravity": 1}, "triaxial.gravity"),
        ("triaxial", {"wall_friction": None}, "triaxial.wall_friction"),
        ("triaxial", {"dt": 0.0}, "triaxial.dt"),
        ("triaxial", 0.1, "triaxial"),
        ("oedometer", {}, "oedometer.stresses"),
        ("oedometer", {"stresses": []}, "oedometer.stresses"),
        ("oedometer", {"stresses": [1e5, -1.0]}, "oedometer.stresses[1]"),
        ("oedometer", {"stresses": [1e5], "hold": 0}, "oedometer.hold"),
        ("isotropic", {"stresses": [1e5], "stress_tol": 2.0}, "isotropic.stress_tol"),
        ("isotropic", {"stresses": [1e5], "stres": 1}, "isotropic.stres"),
    ],
)
def test_a_bad_table_is_a_typed_error_naming_its_key(key, table, parameter):
    with pytest.raises(gp.InvalidParameterError) as info:
        SMALL.replace(consolidate=CONSOLIDATE, **{key: table})
    assert info.value.parameter == parameter
    assert str(info.value).startswith(("invalid " + parameter, "missing " + parameter))


def test_an_unknown_key_lists_the_known_ones_from_toml_too():
    text = SMALL.replace(consolidate=CONSOLIDATE).to_toml() + "\n[triaxial]\nstrain = 0.1\n"
    with pytest.raises(gp.InvalidParameterError) as info:
        gp.PackScene.from_toml_string(text)
    assert info.value.parameter == "triaxial.strain"
    known = str(info.value).split("known: ")[1].split(", ")
    assert known == [
        "confining",
        "axial_strain",
        "inertial_number",
        "constant_p",
        "checks",
        "gravity",
        "local_damping",
        "gain",
        "wall_friction",
        "dt",
    ]


def test_an_element_table_needs_a_consolidation():
    for key, table in (("triaxial", {}), ("isotropic", {"stresses": STRESSES})):
        with pytest.raises(gp.InvalidParameterError, match=r"needs a \[consolidate\]") as info:
            SMALL.replace(**{key: table})
        assert info.value.parameter == key


def test_a_scene_runs_one_element_test():
    with pytest.raises(gp.InvalidParameterError, match="one element test") as info:
        SMALL.replace(consolidate=CONSOLIDATE, triaxial={}, oedometer={"stresses": STRESSES})
    assert info.value.parameter == "oedometer"


def test_a_periodic_cell_takes_the_oedometer_alone():
    cell = SMALL.replace(container="periodic", consolidate={"stress": 1e5})
    assert cell.replace(oedometer={"stresses": STRESSES}).oedometer == {"stresses": STRESSES}
    for key, table in (("triaxial", {"confining": 1e5}), ("isotropic", {"stresses": STRESSES})):
        with pytest.raises(gp.InvalidParameterError, match="no side walls") as info:
            cell.replace(**{key: table})
        assert info.value.parameter == key


def test_a_triaxial_after_an_oedometric_consolidation_needs_its_confining_stress():
    oedometric = SMALL.replace(consolidate={"stress": 1e5})
    with pytest.raises(gp.InvalidParameterError) as info:
        oedometric.replace(triaxial={"axial_strain": 0.1})
    assert info.value.parameter == "triaxial.confining"
    assert oedometric.replace(triaxial={"confining": 5e4}).triaxial == {"confining": 5e4}


@pytest.mark.parametrize(
    ("container", "tables"),
    [
        ("cylinder", {"consolidate": CONSOLIDATE, "triaxial": TRIAXIAL}),
        (
            "periodic",
            {
                "consolidate": {"stress": 1e5, "gravity": False, "wall_friction": 0.0},
                "oedometer": {"stresses": [2e5, 1e5]},
            },
        ),
    ],
)
def test_the_analysis_of_a_tested_pack_measures_the_tables_last_sample(container, tables):
    # the walls as the test left them (the cylinder's radius, the lid): the analysis'
    # phi is the table's last one
    pack = gp.generate(SMALL.replace(container=container, **tables))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MicrostructureWarning)  # a small sample's core
        m = gp.microstructure(pack)
    assert m.phi == pytest.approx(gp.element_table(pack)["phi"][-1], rel=1e-9)
