"""PackScene.trim: the flat top at H_d. The same scene and seed with and without it: the
trimmed pack keeps exactly the particles whose top was at most H_d, ends at or below H_d,
keeps every particle in the container through the relax, and records what it did."""

from __future__ import annotations

import math

import numpy as np
import pytest

import granpack as gp
from granpack.report import ensemble_report


def _scene(dim: int) -> gp.PackScene:
    if dim == 2:
        return gp.PackScene.preset("4.2").replace(
            base=(0.2,), height=0.08, settle_time=0.5, seed=11
        )
    return gp.PackScene.preset("4.4").replace(base=(0.2, 0.2), height=0.1, settle_time=0.5, seed=11)


SCENES = {
    "2d": _scene(2),
    "3d": _scene(3),
    # freezing: the cut also thaws the frozen bed before the relax
    "3d fast": _scene(3).fast(),
    "3d cylinder": _scene(3).replace(container="cylinder"),
    "2d periodic": _scene(2).replace(container="periodic"),
}


def _inside(pack: gp.Pack) -> bool:
    """Every centre inside the container: within the walls, the cylinder or the cell."""
    s = pack.scene
    x, v = pack.positions, s.vertical
    if np.any(x[:, v] < 0.0):
        return False
    if s.container == "cylinder":
        big = s.cylinder_radius
        return bool(np.all(np.hypot(x[:, 0] - big, x[:, 1] - big) <= big))
    lateral = [x[:, k] for k in range(s.dim - 1)]
    if s.container == "periodic":
        return all(np.all((c >= 0.0) & (c < b)) for c, b in zip(lateral, s.base, strict=True))
    return all(np.all((c >= 0.0) & (c <= b)) for c, b in zip(lateral, s.base, strict=True))


@pytest.mark.parametrize("name", list(SCENES))
def test_trim_cuts_at_the_desired_height(name):
    scene = SCENES[name]
    full = gp.generate(scene)
    cut = gp.generate(scene.replace(trim=True))
    v = scene.vertical
    hd = scene.height
    top_full = full.positions[:, v] + full.radii
    assert full.height > hd  # the scene overshoots H_d, so the cut removes some
    kept = top_full <= hd
    # the particles kept are those of the same pack whose top was at most H_d
    assert len(cut) == int(kept.sum())
    np.testing.assert_array_equal(np.sort(cut.radii), np.sort(full.radii[kept]))
    np.testing.assert_array_equal(np.sort(cut.layer), np.sort(full.layer[kept]))
    # the top is flat at H_d: at most H_d after the relax
    assert cut.height <= hd and cut.height == float(np.max(cut.positions[:, v] + cut.radii))
    # nothing left the container while relaxing
    assert _inside(cut) and _inside(full)
    # what was done, recorded
    t = cut.record("trim").table()
    assert t is not None and full.record("trim") is None
    assert t["removed"] == len(full) - len(cut) and t["top"] == cut.height and t["steps"] > 0
    vol = np.pi * cut.radii**2 if scene.dim == 2 else 4 / 3 * np.pi * cut.radii**3
    assert t["phi_hd"] == pytest.approx(vol.sum() / (scene.base_area * hd), rel=1e-12)
    assert t["phi_hd"] < cut.phi  # the void up to H_d counts


def test_trim_is_saved_with_the_pack_and_reported(tmp_path):
    scene = SCENES["2d"].replace(trim=True)
    pack = gp.generate(scene)
    path = pack.save(tmp_path / "p.npz")
    again = gp.load_pack(path)
    assert again.record("trim").table() == pack.record("trim").table() and again.scene.trim is True
    assert gp.PackScene.from_toml_string(scene.to_toml()) == scene
    rec = {
        "pack": 0,
        "n_particles": len(pack),
        "height": pack.height,
        "phi": pack.phi,
        "trim_removed": pack.record("trim").table()["removed"],
        "trim_top": pack.record("trim").table()["top"],
        "phi_hd": pack.record("trim").table()["phi_hd"],
    }
    report = ensemble_report(
        tmp_path,
        scene_name="t",
        scene=scene,
        records=[rec],
        table_files=[],
        figures=[],
        wall_time=1.0,
    ).read_text()
    assert "Flat top (trim)" in report and f"{pack.record('trim').table()['phi_hd']:.4f}" in report


def test_trim_must_be_a_bool():
    with pytest.raises(gp.InvalidParameterError, match="trim"):
        SCENES["2d"].replace(trim="yes")


def test_trim_keeps_the_contacts_consistent():
    # after the cut the engine's contacts index the remaining particles only
    pack = gp.generate(SCENES["3d fast"].replace(trim=True))
    c = pack.contacts
    assert c.i.max() < len(pack) and c.j.max() < len(pack)
    m = gp.microstructure(pack, core_margin=0.02)
    assert m.n_particles == len(pack) and math.isfinite(m.z)


def test_generate_trim_flag_cuts_every_pack(tmp_path, capsys):
    from granpack.cli import main

    toml = tmp_path / "s.toml"
    toml.write_text(SCENES["2d"].to_toml())
    out = tmp_path / "out"
    argv = ["generate", str(toml), "--packs", "2", "--trim", "--no-figures", "-q", "--out"]
    assert main([*argv, str(out)]) == 0
    assert "trim = true" in (out / "scene.toml").read_text()
    assert "Flat top (trim)" in (out / "report.md").read_text()
    for k in range(2):
        pack = gp.load_pack(out / "packs" / f"pack_{k:03d}.npz")
        assert pack.record("trim") is not None and pack.height <= SCENES["2d"].height
