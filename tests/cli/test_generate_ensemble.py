"""`granpack.generate_ensemble`, the library call behind ``granpack generate``: the same
folder from the function as from the command."""

from __future__ import annotations

import numpy as np
import pytest

import granpack as gp
from granpack.cli import main

SCENE = gp.PackScene.preset("4.2").replace(seed=5, stream=3, base=(0.1,), height=0.05).fast()


def test_the_function_and_the_command_write_the_same_packs(tmp_path, capsys):
    report = gp.generate_ensemble(
        SCENE, tmp_path / "lib", packs=2, seed=9, name="tiny", figures=False, workers=1
    )
    said = capsys.readouterr()
    assert report == tmp_path / "lib" / "report.md" and report.exists()
    # the scene's own stream is replaced by the ensemble's numbering, and a note says so
    assert "stream = 3 is not used" in said.err
    assert "granpack generate: 2 pack(s) of tiny" in said.out and "phi = " in said.out
    written = gp.PackScene.from_toml(tmp_path / "lib" / "scene.toml")
    assert written.seed == 9 and written.stream == 0

    scene_file = tmp_path / "tiny.toml"
    scene_file.write_text(SCENE.to_toml())
    argv = ["generate", str(scene_file), "--packs", "2", "--seed", "9", "--no-figures"]
    assert main([*argv, "--workers", "1", "--out", str(tmp_path / "cli")]) == 0
    for k in range(2):
        lib = gp.load_pack(next((tmp_path / "lib" / "packs").glob(f"*{k}.npz")))
        cli = gp.load_pack(next((tmp_path / "cli" / "packs").glob(f"*{k}.npz")))
        np.testing.assert_array_equal(lib.positions, cli.positions)
        assert lib.scene.stream == k


def test_a_bad_ensemble_size_is_refused_by_name(tmp_path):
    with pytest.raises(gp.InvalidParameterError) as err:
        gp.generate_ensemble(SCENE, tmp_path, packs=0)
    assert err.value.parameter == "packs"
    with pytest.raises(gp.InvalidParameterError) as err:
        gp.generate_ensemble("4.2", tmp_path)
    assert err.value.parameter == "scene"
