"""A pack's history: one typed record per stage, in the order the stages ran, kept by the
pack file; the pack files of granpack 0.1.0 (five separate tables) read into it."""

from __future__ import annotations

import dataclasses
import json
import warnings
import zipfile
from pathlib import Path

import numpy as np
import pytest

import granpack as gp
from granpack import stages
from granpack.history import TABLE_NAMES, StageRecord
from granpack.pack import FORMAT_VERSION
from granpack.stages import deposit, rest

OLD = Path(__file__).parents[1] / "data" / "packs_0_1_0"
OLD_FILES = sorted(OLD.glob("*.npz"))
#: The tables of a 0.1.0 pack file, by the stage each became.
OLD_TABLES = {table: stage for stage, table in TABLE_NAMES.items()}


def _meta(path: Path) -> dict:
    with zipfile.ZipFile(path) as z, z.open("meta.json.npy") as f:
        return json.loads(np.lib.format.read_array(f).tobytes())


def _same(a, b) -> bool:
    # (json's text compares the NaN entries of a periodic sample's boundary_stress)
    return json.dumps(a, sort_keys=True) == json.dumps(b, sort_keys=True)


def test_the_old_files_hold_each_of_the_five_tables():
    held = {key for path in OLD_FILES for key in _meta(path) if key in OLD_TABLES}
    assert held == set(OLD_TABLES)
    assert all(_meta(path)["version"] == 1 for path in OLD_FILES)


@pytest.mark.parametrize("path", OLD_FILES, ids=lambda p: p.stem)
def test_the_tables_of_an_old_file_read_back_as_history(path):
    meta = _meta(path)
    pack = gp.load_pack(path)
    tables = {key: meta[key] for key in OLD_TABLES if key in meta}
    # one record per table, in the order generate runs the stages
    order = [s for s in TABLE_NAMES if TABLE_NAMES[s] in tables]
    assert [rec.stage for rec in pack.history] == order
    for key, table in tables.items():
        rec = pack.record(OLD_TABLES[key])
        assert rec is not None and _same(rec.table(), table)
        assert rec.steps == table.get("steps", 0)
        assert rec.seconds == table.get("seconds", 0.0)
        assert not set(rec.settings) & set(rec.report)


@pytest.mark.parametrize("path", OLD_FILES, ids=lambda p: p.stem)
def test_an_old_file_saved_again_keeps_its_history(path, tmp_path):
    pack = gp.load_pack(path)
    again = gp.load_pack(pack.save(tmp_path / path.name))
    assert _meta(tmp_path / path.name)["version"] == FORMAT_VERSION
    assert _same([r.to_json() for r in again.history], [r.to_json() for r in pack.history])
    np.testing.assert_array_equal(again.positions, pack.positions)


@pytest.mark.parametrize("key", sorted(OLD_TABLES))
def test_the_old_attributes_warn_and_give_the_old_tables(key):
    path = next(p for p in OLD_FILES if key in _meta(p))
    pack = gp.load_pack(path)
    with pytest.warns(DeprecationWarning, match=rf"Pack\.{key} is deprecated"):
        table = getattr(pack, key)
    assert _same(table, _meta(path)[key])
    plain = dataclasses.replace(pack, history=())
    with pytest.warns(DeprecationWarning):
        assert getattr(plain, key) is None


def test_a_damaged_history_is_refused(tmp_path):
    pack = gp.load_pack(OLD / "trim_rest.npz")
    wrong = dataclasses.replace(pack, history=(StageRecord("trim", report={"removed": 1}),))
    path = wrong.save(tmp_path / "damaged.npz")
    with pytest.raises(gp.FileFormatError, match="'top'"):
        gp.load_pack(path)
    with pytest.raises(ValueError, match="unknown stage"):
        StageRecord("squeeze")


def test_an_unknown_stage_name_is_refused_by_name():
    pack = gp.load_pack(OLD / "trim_rest.npz")
    with pytest.raises(gp.InvalidParameterError, match="consolidation") as err:
        pack.record("consolidation")
    assert err.value.parameter == "stage"


SCENE = (
    gp.PackScene.preset("4.2")
    .replace(seed=7, base=(0.1,), height=0.06, container="periodic")
    .fast()
)


def test_generate_runs_the_stages_the_scene_lists_in_order():
    scene = SCENE.replace(trim=True, rest_tol=1e-3, consolidate={"stress": 1e4})
    assert [s.stage for s in stages.plan(scene)] == ["deposit", "rest", "consolidate"]
    pack = gp.generate(scene)
    assert [r.stage for r in pack.history] == ["trim", "rest", "consolidate"]
    settled, sample = pack.record("rest"), pack.record("consolidate")
    assert settled.settings["unbalanced_tol"] == 1e-3 and settled.report["unbalanced"] <= 1e-3
    assert sample.settings["targets"] == {"lid": 1e4} and sample.settings["mode"] == "oedometric"
    assert sample.steps > 0 and sample.report["height"] == pack.height
    # the same pack from the stage list run by hand
    again = stages.run(scene, stages.plan(scene))
    np.testing.assert_array_equal(again.positions, pack.positions)


def test_a_changed_deposit_spec_jams_the_layers_at_that_friction():
    mu = 0.5
    steps = stages.with_spec(stages.plan(SCENE), "deposit", deposit.Spec(friction=mu))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", gp.UnsettledPackWarning)
        pack = stages.run(SCENE, steps)
        jammed = gp.generate(
            SCENE.replace(material=dataclasses.replace(SCENE.material, friction=mu))
        )
    np.testing.assert_array_equal(pack.positions, jammed.positions)
    # the pack keeps the scene's material, whose friction is restored once it is jammed
    assert pack.scene == SCENE and pack.history == ()


def test_a_spec_added_to_the_list_runs_in_the_stage_order():
    scene = SCENE.replace(consolidate={"stress": 1e4})
    steps = stages.with_spec(stages.plan(scene), "rest", rest.Spec(1e-3))
    assert [s.stage for s in steps] == ["deposit", "rest", "consolidate"]
    assert [s.stage for s in stages.with_spec(steps, "consolidate", None)] == ["deposit", "rest"]
