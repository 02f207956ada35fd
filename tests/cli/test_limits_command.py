"""`granpack limits`: it never writes over its own scene file, a scene whose packs cannot
be measured is a typed error (no NaN, no traceback), and it does not warn about deposits
it brings to rest itself."""

from __future__ import annotations

import dataclasses
import os
import warnings

import pytest

import granpack as gp
from granpack.cli import main
from granpack.density import MU_DEP_MAX, _deposit_at

#: A deposit lower than twice the analysis' core margin: no core window, phi_core NaN.
FLAT = gp.PackScene.preset("4.1").replace(base=(0.15,), height=0.08, seed=1).fast()


@pytest.mark.parametrize("spelling", ["same", "dot", "link"])
def test_limits_refuses_json_over_its_scene_file(tmp_path, monkeypatch, capsys, spelling):
    scene = tmp_path / "lim.toml"
    text = FLAT.to_toml()
    scene.write_text(text)
    monkeypatch.chdir(tmp_path)
    out = {"same": "lim.toml", "dot": "./sub/../lim.toml", "link": "alias.toml"}[spelling]
    (tmp_path / "sub").mkdir()
    if spelling == "link":
        os.symlink(scene, tmp_path / "alias.toml")
    rc = main(["limits", "lim.toml", "--packs", "1", "--json", out])
    assert rc == 2
    err = capsys.readouterr().err
    assert "--json" in err and "would be overwritten" in err
    # nothing generated, the scene intact
    assert scene.read_text() == text


@pytest.mark.parametrize("packs", ["1", "2"])
def test_limits_of_a_scene_without_a_core_window_is_a_typed_error(tmp_path, capsys, packs):
    scene = tmp_path / "flat.toml"
    scene.write_text(FLAT.to_toml())
    out = tmp_path / "lim.json"
    rc = main(["limits", str(scene), "--packs", packs, "--json", str(out)])
    assert rc == 2
    captured = capsys.readouterr()
    assert "no core window" in captured.err and "scene" in captured.err
    assert "Traceback" not in captured.err and "nan" not in captured.out.lower()
    assert not out.exists()
    with warnings.catch_warnings(), pytest.raises(gp.InvalidParameterError) as info:
        # the frictionless deposit is not settled, and says so: not this test's point
        warnings.simplefilter("ignore", gp.UnsettledPackWarning)
        gp.void_ratio_limits(FLAT, packs=int(packs))
    assert "no core window" in str(info.value)
    assert info.value.parameter == "scene"


def test_limits_does_not_warn_for_deposits_it_brings_to_rest():
    scene = gp.PackScene.preset("4.2").replace(base=(0.2,), height=0.08, settle_time=0.5, seed=11)
    jammed = scene.replace(material=dataclasses.replace(scene.material, friction=MU_DEP_MAX))
    # the oracle: this deposit, jammed at the loosest deposition friction, is still
    # moving at the end of its layer loop
    with pytest.warns(gp.UnsettledPackWarning):
        gp.generate(jammed)
    # the window's pack at that friction is settled right after: no warning for it
    with warnings.catch_warnings():
        warnings.simplefilter("error", gp.UnsettledPackWarning)
        pack = _deposit_at(scene, MU_DEP_MAX)
    assert pack.record("rest") is not None and pack.record("rest").table()["unbalanced"] <= 1e-4
    # a consolidating scene's packs are all brought to equilibrium by the servo
    with warnings.catch_warnings():
        warnings.simplefilter("error", gp.UnsettledPackWarning)
        w = gp.void_ratio_limits(scene.replace(consolidate={"stress": 1e4}), packs=1)
    assert w.e_min <= w.e_max
