"""How often a scene is validated, and that a bad scene gets the same typed error, naming
the same parameter, from every door: `PackScene`, the engine's `LayerPacker` (which reads
any object with the scene's fields) and the command line."""

from __future__ import annotations

import collections

import pytest

import granpack as gp
from granpack import _core
from granpack.cli import main


@pytest.fixture
def counted(monkeypatch):
    """Counts the scene's validations: `validate_scene` (once per PackScene built) and
    the engine's own (once per LayerPacker, that is per pack)."""
    calls: collections.Counter = collections.Counter()
    validate, packer = _core.validate_scene, _core.LayerPacker

    def counting_validate(scene):
        calls["scene"] += 1
        return validate(scene)

    def counting_packer(scene, *args, **kwargs):
        calls["engine"] += 1
        return packer(scene, *args, **kwargs)

    monkeypatch.setattr(_core, "validate_scene", counting_validate)
    monkeypatch.setattr(_core, "LayerPacker", counting_packer)
    return calls


def test_generate_validates_the_scene_a_counted_number_of_times(counted, tmp_path):
    packs = 3
    argv = ["generate", "4.1", "--packs", str(packs), "--workers", "1", "--fast", "-q"]
    argv += ["--scale", "0.2", "--settle-time", "0.2", "--no-figures", "--out", str(tmp_path)]
    assert main(argv) == 0
    # the preset, the development options' scaled scene and --fast's: three scenes
    # built; each pack's seed and stream are checked alone; each pack read back for its
    # analysis is a scene read from a file, validated
    assert counted["scene"] == 3 + packs
    assert counted["engine"] == packs


def test_a_new_seed_or_stream_checks_those_alone(counted):
    scene = gp.PackScene.preset("4.1")
    assert counted["scene"] == 1
    other = scene.replace(seed=7, stream=2)
    assert counted["scene"] == 1
    assert (other.seed, other.stream) == (7, 2)
    with pytest.raises(gp.InvalidParameterError) as err:
        scene.replace(stream=-1)
    assert err.value.parameter == "stream"
    scene.replace(rotations=False)
    assert counted["scene"] == 2
