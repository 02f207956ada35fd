"""One fault, one error: the same bad input raises the same class with the same
attributes from every entry point (PackScene and its readers, the engine's layer loop
reading a scene by attribute, Simulation, the command line's message)."""

from __future__ import annotations

import dataclasses
import types

import pytest

import granpack as gp
from granpack import _core
from granpack.cli import main

ATTRS = ("parameter", "value", "expected", "dt", "critical", "r_min")


def _attrs(err: Exception) -> dict:
    return {k: getattr(err, k) for k in ATTRS if hasattr(err, k)}


def _fields(scene: gp.PackScene, **changes) -> types.SimpleNamespace:
    """The scene's keys as a plain object, unchecked: what the engine reads."""
    d = {f.name: getattr(scene, f.name) for f in dataclasses.fields(scene)}
    return types.SimpleNamespace(**{**d, **changes})


@pytest.mark.parametrize("preset", ["4.1", "4.2", "4.3", "4.4"])
def test_a_time_step_above_the_rayleigh_step_is_the_same_error_everywhere(preset, tmp_path):
    scene = gp.PackScene.preset(preset)
    crit = scene.material.critical_time_step(scene.r_min)
    dt = 1.5 * crit
    raised = {}
    with pytest.raises(gp.UnstableTimeStepError) as e:
        gp.PackScene(**{**gp.scene.PRESETS[preset], "dt": dt})
    raised["PackScene"] = e.value
    with pytest.raises(gp.UnstableTimeStepError) as e:
        scene.replace(dt=dt)
    raised["replace"] = e.value
    with pytest.raises(gp.UnstableTimeStepError) as e:
        gp.PackScene.from_toml_string(f'preset = "{preset}"\ndt = {dt!r}\n')
    raised["from_toml_string"] = e.value
    for name, entry in (
        ("resolve_scene", _core.resolve_scene),
        ("LayerPacker", _core.LayerPacker),
    ):
        with pytest.raises(gp.UnstableTimeStepError) as e:
            entry(_fields(scene, dt=dt))
        raised[name] = e.value
    # Simulation: the step checks the particles it holds; the smallest has r_min
    sim = gp.Simulation(dim=scene.dim, material=scene.material, dt=dt)
    sim.add_particles([[0.5] * scene.dim], [scene.r_min])
    with pytest.raises(gp.UnstableTimeStepError) as e:
        sim.step(1)
    raised["Simulation"] = e.value

    want = _attrs(raised["LayerPacker"])
    assert want["parameter"] == "dt" and want["dt"] == dt and want["r_min"] == scene.r_min
    assert want["critical"] == pytest.approx(crit, rel=1e-15)
    for name, err in raised.items():
        assert type(err) is gp.UnstableTimeStepError, name
        assert isinstance(err, gp.InvalidParameterError)
        assert _attrs(err) == want, name
        assert str(err).startswith("invalid dt = "), name

    # the command line says the same, as one line, exit status 2
    f = tmp_path / "scene.toml"
    f.write_text(f'preset = "{preset}"\ndt = {dt!r}\n')
    assert main(["generate", str(f), "--out", str(tmp_path / "out"), "-q"]) == 2
    assert not (tmp_path / "out" / "packs").exists()


@pytest.mark.parametrize(
    "key, value",
    [
        ("phi_layer", 0.9),  # beyond RSA saturation
        ("gravity", 0.0),  # no pull: layers that never fall
        ("h_layer", -1.0),
        ("skin_ratio", -1.0),
        ("settle_dt", 1.0),  # above the Rayleigh step
        ("height", 0.0),
        ("max_overlap_ratio", 2.0),
        ("drag", -1.0),
        ("max_attempts", 0),
        ("base", (0.001,)),
        ("r_mean", -0.01),
        ("container", "sphere"),
        ("radius_law", "normal"),
        ("inertia_2d", "ring"),
        ("skin_ratio", "0.2"),
        ("seed", "1"),
    ],
)
def test_a_bad_key_is_the_same_error_from_the_scene_and_from_the_engine(key, value):
    scene = gp.PackScene.preset("4.1")
    with pytest.raises(gp.InvalidParameterError) as from_scene:
        scene.replace(**{key: value})
    for entry in (_core.resolve_scene, _core.LayerPacker):
        with pytest.raises(gp.InvalidParameterError) as from_engine:
            entry(_fields(scene, **{key: value}))
        assert type(from_engine.value) is type(from_scene.value)
        assert from_engine.value.parameter == from_scene.value.parameter == key


@pytest.mark.parametrize(
    "key, value",
    [("container", 3), ("container", "cone"), ("cylinder_radius", "0.1"), ("skin_ratio", "0.2")],
)
def test_simulation_names_a_setting_of_the_wrong_type(key, value):
    kwargs = {"container": "cylinder", "box": ((0, 0, 0), (0.2, 0.2, 1.0)), key: value}
    with pytest.raises(gp.InvalidParameterError) as e:
        gp.Simulation(dim=3, **kwargs)
    assert e.value.parameter == key


def test_the_command_line_names_out_when_it_would_overwrite_the_scene(tmp_path, capsys):
    out = tmp_path / "out"
    out.mkdir()
    scene_file = out / "scene.toml"  # the folder's record, but not the resolved scene
    scene_file.write_text('preset = "4.1"\nbase = [0.2]\nheight = 0.06\n')
    assert main(["generate", str(scene_file), "--out", str(out), "-q"]) == 2
    err = capsys.readouterr().err
    assert "invalid --out" in err and "would overwrite the scene file" in err
