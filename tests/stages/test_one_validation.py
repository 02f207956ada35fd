"""Every stage key is checked once, by the engine (src/scene/stages.rs): a bad value
raises the same error class and names the same parameter whether it comes from a scene
(built in Python or read from TOML), from the stage's Python function, or from the
command line (exit status 2, the parameter named on stderr)."""

from __future__ import annotations

import math

import pytest

import granpack as gp
from granpack import _core
from granpack.cli import main

# a 2D box nine discs wide, two layers: a deposit in a fraction of a second
SCENE = gp.PackScene(
    dim=2, base=(0.18,), height=0.04, r_mean=0.01, h_layer=0.04, phi_layer=0.3, settle_time=0.2
)

# (key, bad value, error class, parameter): every key of the [consolidate] table
CONSOLIDATE = [
    ("stress", -1.0, gp.InvalidParameterError),
    ("stress", 1e13, gp.InvalidParameterError),
    ("mode", "triaxial", gp.InvalidParameterError),
    ("lateral", 1e3, gp.InvalidParameterError),  # an oedometric stage has no lateral target
    ("gravity", "yes", gp.InvalidParameterError),
    ("stress_tol", 0.0, gp.InvalidParameterError),
    ("unbalanced_tol", 1.0, gp.InvalidParameterError),
    ("hold", 0, gp.InvalidParameterError),
    ("check_every", 10**7, gp.InvalidParameterError),
    ("max_steps", 0, gp.InvalidParameterError),
    ("max_wall_speed", 2e6, gp.InvalidParameterError),
    ("gain", 0.0, gp.InvalidParameterError),
    ("local_damping", 1.0, gp.InvalidParameterError),
    ("dt", -1.0, gp.InvalidParameterError),
    ("dt", 1.0, gp.UnstableTimeStepError),  # beyond the Rayleigh step
    ("wall_friction", -0.1, gp.InvalidParameterError),
]

# the scene's density-target keys, and the settling's tolerance
SCENE_KEYS = [
    ("target_phi", 1.5, gp.InvalidParameterError),
    ("target_void_ratio", -0.5, gp.InvalidParameterError),
    ("target_relative_density", 1.5, gp.InvalidParameterError),
    ("density_tol", 0.5, gp.InvalidParameterError),
    ("density_method", "fastest", gp.InvalidParameterError),
    ("rest_tol", 0.0, gp.InvalidParameterError),
]

# `settle`'s keywords, the settling stage's settings
REST = [
    ("unbalanced_tol", 0.0),
    ("hold", 1001),
    ("check_every", 0),
    ("max_steps", 10**11),
    ("local_damping", -0.1),
]


def _toml_value(value) -> str:
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, float) and math.isinf(value):
        return "inf"
    return repr(value)


@pytest.fixture(scope="module")
def deposit() -> gp.Pack:
    return gp.generate(SCENE)


def _cli_error(capsys, argv: list[str]) -> str:
    try:
        status = main(argv)
    except SystemExit as exc:  # argparse's own errors
        status = exc.code
    assert status == 2
    return capsys.readouterr().err


def test_the_lists_cover_every_stage_key():
    assert {k for k, *_ in CONSOLIDATE} == set(_core.CONSOLIDATE_KEYS)
    assert {k for k, *_ in SCENE_KEYS} == {*_core.TARGET_KEYS, "density_tol", "density_method"} | {
        "rest_tol"
    }
    assert {k for k, _ in REST} == set(_core.DEFAULT_REST)


@pytest.mark.parametrize(("key", "value", "error"), CONSOLIDATE)
def test_a_bad_consolidate_setting_is_named_alike_everywhere(
    deposit, tmp_path, capsys, key, value, error
):
    parameter = f"consolidate.{key}"
    table = {"stress": 1e3, key: value}
    # the scene, built in Python ...
    with pytest.raises(error) as err:
        SCENE.replace(consolidate=table)
    assert err.value.parameter == parameter
    # ... and read from TOML
    toml = (
        SCENE.to_toml()
        + "\n[consolidate]\n"
        + "".join(f"{k} = {_toml_value(v)}\n" for k, v in table.items())
    )
    with pytest.raises(error) as err:
        gp.PackScene.from_toml_string(toml)
    assert err.value.parameter == parameter
    # the stage's function
    kwargs = {k: v for k, v in table.items() if k != "stress"}
    with pytest.raises(error) as err:
        gp.consolidate(deposit, table["stress"], **kwargs)
    assert err.value.parameter == parameter
    # the command line, from a scene file
    path = tmp_path / "scene.toml"
    path.write_text(toml)
    stderr = _cli_error(capsys, ["generate", str(path), "--out", str(tmp_path / "o"), "-q"])
    assert parameter in stderr and "Traceback" not in stderr
    assert not (tmp_path / "o").exists()


def test_the_command_line_options_meet_the_same_check(tmp_path, capsys):
    out = ["--out", str(tmp_path / "o"), "-q"]
    stderr = _cli_error(capsys, ["generate", "4.1", "--consolidate", "-5", *out])
    assert "consolidate.stress" in stderr
    with pytest.raises(gp.InvalidParameterError) as err:
        gp.PackScene.preset("4.1").replace(consolidate={"stress": -5.0})
    assert err.value.parameter == "consolidate.stress"
    # anisotropic is offered, and needs the table's lateral target
    stderr = _cli_error(
        capsys,
        ["generate", "4.1", "--consolidate", "1e3", "--consolidate-mode", "anisotropic", *out],
    )
    assert "consolidate.lateral" in stderr
    for option, key, value in (
        ("--target-phi", "target_phi", 1.5),
        ("--target-void-ratio", "target_void_ratio", -0.5),
        ("--target-relative-density", "target_relative_density", 1.5),
    ):
        stderr = _cli_error(capsys, ["generate", "4.1", option, str(value), *out])
        assert f"invalid {key}" in stderr
    stderr = _cli_error(
        capsys, ["generate", "4.1", "--target-phi", "0.6", "--density-tol", "0.5", *out]
    )
    assert "invalid density_tol" in stderr
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize(("key", "value", "error"), SCENE_KEYS)
def test_a_bad_scene_stage_key_is_named_alike_everywhere(tmp_path, capsys, key, value, error):
    with pytest.raises(error) as err:
        SCENE.replace(**{key: value})
    assert err.value.parameter == key
    # a top-level key, before the scene's tables, in place of the scene's own
    lines = [line for line in SCENE.to_toml().splitlines() if not line.startswith(f"{key} =")]
    toml = f"{key} = {_toml_value(value)}\n" + "\n".join(lines) + "\n"
    with pytest.raises(error) as err:
        gp.PackScene.from_toml_string(toml)
    assert err.value.parameter == key
    path = tmp_path / "scene.toml"
    path.write_text(toml)
    stderr = _cli_error(capsys, ["generate", str(path), "--out", str(tmp_path / "o"), "-q"])
    assert f"invalid {key}" in stderr


@pytest.mark.parametrize(("key", "value"), [("target_phi", 1.0), ("density_tol", 0.0)])
def test_the_servo_target_is_checked_as_the_scene_checks_it(deposit, key, value):
    args = {"target_phi": 0.8, key: value}
    with pytest.raises(gp.InvalidParameterError) as err:
        gp.consolidate(deposit, 1e3, **args)
    assert err.value.parameter == key
    with pytest.raises(gp.InvalidParameterError) as err:
        SCENE.replace(**args)
    assert err.value.parameter == key


@pytest.mark.parametrize(("key", "value"), REST)
def test_a_bad_settling_setting_is_named_by_the_engine(deposit, key, value):
    with pytest.raises(gp.InvalidParameterError) as err:
        gp.settle(deposit, **{key: value})
    assert err.value.parameter == key
    # the scene's rest_tol is the same check, under the scene's name
    if key == "unbalanced_tol":
        with pytest.raises(gp.InvalidParameterError) as scene_err:
            SCENE.replace(rest_tol=value)
        assert scene_err.value.parameter == "rest_tol"
        assert scene_err.value.expected == err.value.expected


def test_the_flat_top_is_refused_where_it_would_remove_every_particle():
    with pytest.raises(gp.InvalidParameterError) as err:
        SCENE.replace(trim=True, height=0.015)  # below 2 r_min = 0.02 m
    assert err.value.parameter == "height"


def test_the_wall_speed_range_agrees_everywhere(deposit):
    # the engine's range (0, MAX_WALL_SPEED], in the scene and the function alike
    top = _core.MAX_WALL_SPEED
    assert (
        SCENE.replace(consolidate={"stress": 1e3, "max_wall_speed": top}).consolidate[
            "max_wall_speed"
        ]
        == top
    )
    for bad in (0.0, math.nextafter(top, math.inf), math.inf):
        with pytest.raises(gp.InvalidParameterError) as err:
            SCENE.replace(consolidate={"stress": 1e3, "max_wall_speed": bad})
        assert f"must lie in (0, {top:.0f}]" in str(err.value)
        with pytest.raises(gp.InvalidParameterError) as err:
            gp.consolidate(deposit, 1e3, max_wall_speed=bad)
        assert err.value.parameter == "consolidate.max_wall_speed"


def test_the_command_offers_every_mode_and_method():
    from granpack.cli import build_parser

    commands = build_parser()._subparsers._group_actions[0].choices  # type: ignore[union-attr]

    def choices(command: str, option: str):
        action = next(a for a in commands[command]._actions if option in a.option_strings)
        return tuple(action.choices)

    assert choices("generate", "--consolidate-mode") == _core.CONSOLIDATION_MODES
    assert choices("consolidate", "--mode") == _core.CONSOLIDATION_MODES
    assert choices("generate", "--density-method") == _core.DENSITY_METHODS


def test_a_walled_pack_is_refused_by_the_tiling_alike_everywhere(deposit, tmp_path, capsys):
    with pytest.raises(gp.InvalidParameterError) as err:
        gp.tile(deposit, (2,))
    assert err.value.parameter == "pack"
    assert "container is 'box'" in str(err.value)
    with pytest.raises(gp.InvalidParameterError) as err:
        _core.resolve_stage("tile", deposit.scene, {"counts": [2]})
    assert err.value.parameter == "pack"
    path = deposit.save(tmp_path / "box.npz")
    stderr = _cli_error(capsys, ["tile", str(path), "2", "--out", str(tmp_path / "t.npz")])
    assert "container is 'box'" in stderr
    assert not (tmp_path / "t.npz").exists()
