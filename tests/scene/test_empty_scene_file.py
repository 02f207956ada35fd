"""A scene file that sets no key (empty, whitespace, comments only) is refused by name
instead of running the defaults silently; ``preset = "4.1"`` asks for them."""

from __future__ import annotations

import pytest

import granpack as gp
from granpack.cli import main


@pytest.mark.parametrize("text", ["", "\n\n", "# a scene, to be written\n", "   \t\n# x\n"])
def test_a_scene_file_that_sets_no_key_is_refused(tmp_path, text):
    path = tmp_path / "scene.toml"
    path.write_text(text)
    with pytest.raises(gp.FileFormatError) as err:
        gp.PackScene.from_toml(path)
    assert str(path) in str(err.value) and "sets no key" in str(err.value)
    assert 'preset = "4.1"' in str(err.value)
    with pytest.raises(gp.InvalidParameterError) as err:
        gp.PackScene.from_toml_string(text)
    assert err.value.parameter == "scene" and "sets no key" in str(err.value)


def test_the_generate_command_refuses_an_empty_scene_file_before_any_work(tmp_path, capsys):
    path = tmp_path / "scene.toml"
    path.write_text("")
    out = tmp_path / "run"
    assert main(["generate", str(path), "--out", str(out), "-q"]) == 2
    assert "sets no key" in capsys.readouterr().err
    assert not (out / "packs").exists()


def test_the_defaults_by_name_and_a_single_key_still_read(tmp_path):
    path = tmp_path / "scene.toml"
    path.write_text('preset = "4.1"\n')
    assert gp.PackScene.from_toml(path) == gp.PackScene()
    assert gp.PackScene.from_toml_string("seed = 4\n") == gp.PackScene(seed=4)
