"""Every stage default is the engine's (src/scene/stages.rs): the Python signatures, the
scene's fields and the command line's options take theirs from `granpack._core`."""

from __future__ import annotations

import dataclasses
import inspect

import granpack as gp
from granpack import _core
from granpack.cli import build_parser


def _defaults(fn) -> dict:
    return {
        name: p.default
        for name, p in inspect.signature(fn).parameters.items()
        if p.default is not inspect.Parameter.empty
    }


def test_consolidate_takes_the_engine_defaults():
    got = _defaults(gp.consolidate)
    for key, value in _core.DEFAULT_CONSOLIDATE.items():
        assert got[key] == value, key
    assert set(_core.DEFAULT_CONSOLIDATE) == set(_core.CONSOLIDATE_KEYS) - {"stress"}
    assert got["density_tol"] == _core.DEFAULT_DENSITY_TOL
    # the servo's target is off unless given
    assert got["target_phi"] is None


def test_settle_takes_the_engine_defaults():
    assert _defaults(gp.settle) == dict(_core.DEFAULT_REST)


def test_the_engine_defaults_are_its_checks_resolution_of_nothing():
    scene = gp.PackScene.preset("4.1")
    assert _core.resolve_stage("rest", scene, {}) == dict(_core.DEFAULT_REST)
    density = _core.resolve_stage("density", scene, {})
    assert density == dict(_core.DEFAULT_DENSITY)
    resolved = _core.resolve_stage("consolidate", scene, {"stress": 1e3})
    for key, value in _core.DEFAULT_CONSOLIDATE.items():
        assert resolved[key] == value, key


def test_the_scene_takes_the_engine_density_defaults():
    fields = {f.name: f.default for f in dataclasses.fields(gp.PackScene)}
    for key in (*_core.TARGET_KEYS, "density_tol"):
        assert fields[key] is None  # none: no target; the tolerance, the engine's
    assert fields["density_method"] == _core.DEFAULT_DENSITY["density_method"]
    assert gp.PackScene.TARGET_KEYS == _core.TARGET_KEYS


def test_a_scene_lists_its_stages_with_the_engine_defaults():
    scene = gp.PackScene.preset("4.1").replace(
        consolidate={"stress": 1e3}, rest_tol=1e-3, target_phi=0.8, trim=True
    )
    stages = _core.resolve_scene(scene)["stages"]
    assert stages["rest"] == {**_core.DEFAULT_REST, "unbalanced_tol": 1e-3}
    assert stages["density"] == {**_core.DEFAULT_DENSITY, "target_phi": 0.8}
    assert stages["consolidate"] == {**_core.DEFAULT_CONSOLIDATE, "stress": 1e3}
    assert stages["trim"] == {"height": None}
    plain = _core.resolve_scene(gp.PackScene.preset("4.1"))["stages"]
    assert plain == {"trim": None, "rest": None, "density": None, "consolidate": None}


def test_the_command_line_defaults_are_the_engine_defaults():
    commands = build_parser()._subparsers._group_actions[0].choices  # type: ignore[union-attr]

    def default(command: str, option: str):
        action = next(a for a in commands[command]._actions if option in a.option_strings)
        return action.default

    c = _core.DEFAULT_CONSOLIDATE
    assert default("consolidate", "--mode") == c["mode"]
    assert default("consolidate", "--stress-tol") == c["stress_tol"]
    assert default("consolidate", "--unbalanced-tol") == c["unbalanced_tol"]
    assert default("consolidate", "--max-steps") == c["max_steps"]
    assert default("consolidate", "--density-tol") == _core.DEFAULT_DENSITY_TOL
    assert default("generate", "--consolidate-mode") == c["mode"]


def test_the_stub_literals_spell_the_engine_lists():
    import ast
    import typing
    from pathlib import Path

    stub = Path(gp.__file__).with_name("_core.pyi")
    literals = {}
    for node in ast.parse(stub.read_text()).body:
        if isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            if node.target.id in (
                "ConsolidationMode",
                "DensityMethod",
                "TargetKey",
                "ConsolidateKey",
            ):
                value = eval(ast.unparse(node.value), {"Literal": typing.Literal})  # noqa: S307
                literals[node.target.id] = typing.get_args(value)
    assert literals["ConsolidationMode"] == _core.CONSOLIDATION_MODES
    assert literals["DensityMethod"] == _core.DENSITY_METHODS
    assert literals["TargetKey"] == _core.TARGET_KEYS
    assert literals["ConsolidateKey"] == _core.CONSOLIDATE_KEYS
