"""A flat top that would remove every particle is refused, naming the trim height and the
heights that keep particles, from the scene, from generate, from the engine and from the
command line; an empty pack is never saved, and a rerun is never stuck on one."""

from __future__ import annotations

import numpy as np
import pytest

import granpack as gp
from granpack import _core
from granpack.cli import main
from granpack.ensemble import pack_path
from granpack.pack import Pack

#: A bed of 1 cm discs (26 of them, one layer) whose law also allows 6 mm ones (1 %),
#: so that 2 r_min = 0.012 m passes the scene's check; seed 0 draws none of the small
#: ones, so a flat top at 0.0121 m lies below every particle's top.
LOW = gp.PackScene(
    base=(0.2,),
    height=0.0121,
    radius_law="discrete",
    radii=(0.006, 0.01),
    fractions=(0.01, 0.99),
    settle_time=0.5,
    seed=0,
)


def _tops(pack: Pack) -> np.ndarray:
    return pack.positions[:, pack.scene.vertical] + pack.radii


def test_a_flat_top_below_any_particle_on_the_floor_is_refused_by_the_scene():
    for name in ("4.1", "4.2", "4.3", "4.4"):
        scene = gp.PackScene.preset(name)
        low = 1.9 * scene.r_min
        with pytest.raises(gp.InvalidParameterError, match=r"2 r_min") as e:
            scene.replace(trim=True, height=low)
        assert e.value.parameter == "height" and e.value.value == low
        assert f"{2 * scene.r_min:g}" in e.value.expected
        # without the flat top the same height is a pack of one layer
        scene.replace(height=low)


def test_generate_refuses_a_flat_top_that_would_empty_the_pack():
    full = gp.generate(LOW)
    lowest = float(_tops(full).min())
    assert lowest > LOW.height  # the case: no particle's top at or below the trim height
    with pytest.raises(gp.InvalidParameterError, match="empty pack") as e:
        gp.generate(LOW.replace(trim=True))
    err = e.value
    assert err.parameter == "height" and err.value == LOW.height
    assert f">= {lowest!r} m" in err.expected and f"height >= {lowest!r}" in str(err)
    # the height it names keeps particles
    kept = gp.generate(LOW.replace(trim=True, height=lowest))
    assert len(kept) >= 1 and kept.record("trim").table()["removed"] == len(full) - len(kept)


def test_the_engine_refuses_the_same_and_stays_usable():
    packer = _core.LayerPacker(LOW)
    while not packer.done:
        packer.next_layer()
    with pytest.raises(gp.InvalidParameterError, match="keeps no particle") as e:
        packer.trim(LOW.height)
    assert e.value.parameter == "height"
    n = len(packer.state()["radii"])
    done = packer.trim(10.0)  # above every top: nothing removed
    assert done["removed"] == 0 and len(packer.state()["radii"]) == n


def test_the_command_line_saves_no_empty_pack_and_a_rerun_recovers(tmp_path, capsys):
    scene_file = tmp_path / "low.toml"
    scene_file.write_text(LOW.to_toml())
    out = tmp_path / "out"
    for _ in range(2):  # the rerun fails the same way, with the same words
        assert main(["generate", str(scene_file), "--trim", "--out", str(out), "-q"]) == 2
        err = capsys.readouterr().err
        assert "invalid height = 0.0121 m with trim = true" in err and err.count("\n") == 1
        assert not pack_path(out / "packs", 0).exists()
    # the scene mended (a height that keeps particles): the same folder, no hand work
    scene_file.write_text(LOW.replace(height=0.03).to_toml())
    argv = ["generate", str(scene_file), "--trim", "--out", str(out), "-q", "--no-figures"]
    assert main(argv) == 0
    assert len(gp.load_pack(pack_path(out / "packs", 0))) > 0


def test_an_empty_pack_left_by_an_older_version_is_made_again(tmp_path, capsys):
    scene_file = tmp_path / "s.toml"
    scene_file.write_text(LOW.replace(height=0.03).to_toml())
    out = tmp_path / "out"
    argv = ["generate", str(scene_file), "--out", str(out), "-q", "--no-figures"]
    assert main(argv) == 0
    path = pack_path(out / "packs", 0)
    made = gp.load_pack(path)
    empty = Pack(
        scene=made.scene,
        positions=np.zeros((0, 2)),
        radii=np.zeros(0),
        velocities=np.zeros((0, 2)),
        spins=np.zeros(0),
        layer=np.zeros(0, dtype=np.int64),
        contacts=gp.load_pack(path).contacts.__class__.from_dict(
            {
                "i": np.zeros(0, np.int64),
                "j": np.zeros(0, np.int64),
                "normal": np.zeros((0, 2)),
                "overlap": np.zeros(0),
                "force_normal": np.zeros(0),
                "force_tangential": np.zeros((0, 2)),
                "branch": np.zeros((0, 2)),
            }
        ),
        height=0.0,
    )
    empty.save(path)
    assert len(gp.load_pack(path)) == 0
    assert main(argv) == 0
    assert len(gp.load_pack(path)) == len(made)
