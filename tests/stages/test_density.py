"""Density targets: a pack at the packing fraction, void ratio or relative density the
user asks for, and the model's own e_min and e_max.

The targets are placed across the window each scene reaches (near loose, middle, near
dense), measured on the same seed, so that each test asks for what the scene can give and
checks it within density_tol; the window's ends are checked against the refusals, the
ordering of e_min, the recipe's e and e_max, and frictionless random close packing."""

from __future__ import annotations

import dataclasses
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import granpack as gp
from granpack.density import MU_DEP_GRID, MU_DEP_MAX, sample_phi

LEVELS = (0.2, 0.5, 0.8)  # where in the window the targets lie, loosest to densest

#: Deposits measured in the core window: a 3D periodic cell and a 2D box.
P3 = (
    gp.PackScene.preset("4.3")
    .replace(seed=3, base=(0.4, 0.4), height=0.4, container="periodic")
    .fast()
)
B2 = gp.PackScene.preset("4.2").replace(seed=3, base=(0.5,), height=0.4).fast()


@pytest.fixture(scope="module")
def window3() -> gp.VoidRatioLimits:
    return gp.void_ratio_limits(P3, packs=1)


@pytest.fixture(scope="module")
def window2() -> gp.VoidRatioLimits:
    return gp.void_ratio_limits(B2, packs=1)


def _level(w: gp.VoidRatioLimits, f: float) -> float:
    return w.phi_min + f * (w.phi_max - w.phi_min)


@pytest.mark.slow
@pytest.mark.parametrize("level", LEVELS)
def test_deposition_friction_reaches_targets_in_the_periodic_cell(window3, level):
    target = round(_level(window3, level), 4)
    pack = gp.generate(P3.replace(target_phi=target))
    d = pack.record("density").table()
    assert d["method"] == "deposition" and d["measure"] == "core"
    assert abs(d["phi"] - target) <= 0.002
    # the record's phi is the pack's own core phi, with the material's friction back
    assert d["phi"] == gp.microstructure(pack).phi_core
    assert pack.scene.material.friction == P3.material.friction
    assert pack.scene.target_phi == target
    assert 0.0 <= d["friction"] <= MU_DEP_MAX
    assert d["generations"] <= 8


@pytest.mark.slow
@pytest.mark.parametrize("level", LEVELS)
def test_deposition_friction_reaches_void_ratio_targets_in_the_2d_box(window2, level):
    e = round(1.0 / _level(window2, level) - 1.0, 4)
    pack = gp.generate(B2.replace(target_void_ratio=e))
    d = pack.record("density").table()
    tol = 0.002 * (1.0 + e) ** 2  # 0.002 in phi, as e
    assert abs(d["void_ratio"] - e) <= tol
    assert d["density_tol"] == pytest.approx(tol)


def test_the_window_is_ordered_over_the_measured_grid(window3, window2):
    for w in (window3, window2):
        assert w.e_min < w.e_max
        assert w.measure == "core" and w.packs == 1 and w.e_min_sd == 0.0
        # a deposit's packs: one per grid friction and the recipe's, no servo
        assert {mu for _, mech, mu, _ in w.points if mech == "deposition"} == {
            *MU_DEP_GRID,
            P3.material.friction,
        }
        assert all(mech == "deposition" for _, mech, _, _ in w.points)


def test_relative_density_uses_the_windows_ends(window3):
    pack = gp.generate(P3.replace(target_relative_density=0.5))
    d = pack.record("density").table()
    # the same seed's ends are e_min and e_max, bit for bit
    assert d["e_min"] == window3.e_min and d["e_max"] == window3.e_max
    e_t = window3.e_max - 0.5 * (window3.e_max - window3.e_min)
    assert abs(d["void_ratio"] - e_t) <= 0.002 * (1 + e_t) ** 2
    assert d["relative_density"] == pytest.approx(window3.relative_density(d["void_ratio"]))
    assert abs(d["relative_density"] - 0.5) <= d["density_tol"]


@pytest.mark.slow
@pytest.mark.parametrize("side", ["loose", "dense"])
def test_a_target_outside_the_window_is_refused_with_the_window(window3, side):
    target = window3.phi_min - 0.01 if side == "loose" else window3.phi_max + 0.01
    with pytest.raises(gp.DensityTargetError) as info:
        gp.generate(P3.replace(target_phi=round(target, 4)))
    e = info.value
    assert e.parameter == "target_phi"
    # the window holds void_ratio_limits' packs (same seed and stream), and the
    # search's own packs can only widen it
    assert e.phi_min <= window3.phi_min + 1e-12 and e.phi_max >= window3.phi_max - 1e-12
    assert e.phi_min < e.phi_max
    assert f"[{e.phi_min:.4f}, {e.phi_max:.4f}]" in str(e)


@pytest.mark.slow
@pytest.mark.parametrize(
    "scene",
    [
        P3,
        gp.PackScene.preset("4.3")
        .replace(
            seed=3,
            base=(0.4, 0.4),
            height=0.4,
            container="periodic",
            radius_law="sieve",
            sieve_sizes=(0.03, 0.04, 0.05),
            sieve_passing=(0.0, 0.5, 1.0),
        )
        .fast(),
    ],
    ids=["monodisperse", "sieve"],
)
def test_the_recipe_lies_between_e_min_and_e_max(scene):
    w = gp.void_ratio_limits(scene, packs=1)
    phi, measure = sample_phi(gp.generate(scene))
    assert measure == "core"
    assert w.e_min < 1.0 / phi - 1.0 < w.e_max


@pytest.mark.slow
def test_frictionless_jamming_gives_random_close_packing():
    # >= 5000 monodisperse spheres in the periodic cell, every layer jammed at mu = 0:
    # random close packing is phi = 0.64 (Scott & Kilgour 1969; O'Hern et al. 2003)
    base = gp.PackScene.preset("4.3").replace(
        seed=5, base=(0.7, 0.7), height=0.7, container="periodic"
    )
    scene = base.replace(material=dataclasses.replace(base.material, friction=0.0)).fast()
    pack = gp.generate(scene)
    assert len(pack) >= 5000
    phi = gp.microstructure(pack).phi_core
    assert 0.62 <= phi <= 0.65


# -- the servo: friction lowered while the lid holds the stress ------------------------


@pytest.fixture(scope="module")
def servo_deposits():
    box = gp.PackScene.preset("4.3").replace(seed=4, base=(0.4, 0.4), height=0.3).fast()
    cell = gp.PackScene.preset("4.2").replace(seed=4, base=(0.6,), height=0.4, container="periodic")
    return {"box": gp.generate(box), "periodic_2d": gp.generate(cell.fast())}


def _servo_window(pack, stress):
    lo = gp.consolidate(pack, stress).record("consolidate").table()["phi"]
    with pytest.raises(gp.DensityTargetError) as info:
        gp.consolidate(pack, stress, target_phi=0.95)
    assert info.value.phi_min == lo  # the same first equilibrium, bit for bit
    return lo, info.value.phi_max


@pytest.mark.slow
@pytest.mark.parametrize("name,stress", [("box", 1e4), ("periodic_2d", 1e3)])
def test_lowering_friction_under_the_servo_reaches_targets(servo_deposits, name, stress):
    pack = servo_deposits[name]
    lo, hi = _servo_window(pack, stress)
    assert hi > lo + 0.01
    for level in LEVELS:
        target = round(lo + level * (hi - lo), 4)
        sample = gp.consolidate(pack, stress, target_phi=target)
        rec = sample.record("consolidate").table()
        assert abs(rec["phi"] - target) <= 0.002
        d = rec["density"]
        assert d["phi"] == rec["phi"]
        # the last phase runs at the material's friction again, in equilibrium
        assert d["phases"][-1]["friction"] == pack.scene.material.friction
        assert rec["unbalanced"] <= 1e-4
        assert abs(rec["wall_stress"]["lid"] / stress - 1) <= 1e-3
        assert min(p["friction"] for p in d["phases"]) < pack.scene.material.friction


def test_the_servo_only_densifies(servo_deposits):
    pack = servo_deposits["box"]
    phi0 = gp.consolidate(pack, 1e4).record("consolidate").table()["phi"]
    with pytest.raises(gp.DensityTargetError, match="only densifies") as info:
        gp.consolidate(pack, 1e4, target_phi=round(phi0 - 0.01, 4))
    assert info.value.phi_min == phi0


def test_auto_lowers_friction_under_the_servo_in_one_generation(servo_deposits):
    pack = servo_deposits["box"]
    lo, hi = _servo_window(pack, 1e4)
    target = round(0.5 * (lo + hi), 4)
    scene = pack.scene.replace(consolidate={"stress": 1e4}, target_phi=target)
    sample = gp.generate(scene)
    d = sample.record("density").table()
    assert d["method"] == "servo" and d["generations"] == 1 and d["measure"] == "sample"
    assert abs(d["phi"] - target) <= 0.002
    # the same bits as consolidating the recipe's deposit to the target by hand
    by_hand = gp.consolidate(pack, 1e4, target_phi=target)
    np.testing.assert_array_equal(sample.positions, by_hand.positions)


def test_a_copy_of_the_engine_steps_to_the_same_bits(servo_deposits):
    pack = servo_deposits["box"]
    from granpack.consolidation import _simulation

    sim = _simulation(pack, 1e-5, True, 0.0)
    sim.step(50)
    copy = gp.Simulation.__new__(gp.Simulation)
    copy.__dict__.update(sim.__dict__)
    copy._sim = sim._sim.clone()
    sim._sim.set_friction(0.05)
    copy._sim.set_friction(0.05)
    sim.step(200)
    copy.step(200)
    np.testing.assert_array_equal(sim.positions, copy.positions)
    np.testing.assert_array_equal(sim.spins, copy.spins)
    with pytest.raises(gp.InvalidParameterError, match="friction"):
        sim._sim.set_friction(-0.1)
    with pytest.raises(gp.InvalidParameterError, match="friction"):
        sim._sim.set_friction(float("nan"))


# -- records, determinism, bad input ------------------------------------------------------


def test_the_record_survives_the_pack_file(tmp_path, window2):
    target = round(_level(window2, 0.5), 4)
    pack = gp.generate(B2.replace(target_phi=target))
    pack.save(tmp_path / "p.npz")
    back = gp.load_pack(tmp_path / "p.npz")
    assert back.record("density").table() == pack.record("density").table()
    assert back.scene == pack.scene


_DETERMINISM = textwrap.dedent(
    """
    import hashlib, warnings, numpy as np, granpack as gp
    warnings.simplefilter("ignore")
    sc = gp.PackScene.preset("4.2").replace(seed=4, base=(0.6,), height=0.4,
                                            container="periodic").fast()
    h = hashlib.sha256()
    p = gp.generate(sc.replace(target_relative_density=0.5))
    h.update(np.ascontiguousarray(p.positions).tobytes())
    # the search's packs, without their wall-clock seconds
    search = p.record("density").report["history"]
    h.update(repr([(g["friction"], g["phi"]) for g in search]).encode())
    deposit = gp.generate(sc)
    phi0 = gp.consolidate(deposit, 1e3).record("consolidate").table()["phi"]
    try:
        s = gp.consolidate(deposit, 1e3, target_phi=round(phi0 + 0.006, 4))
        h.update(np.ascontiguousarray(s.positions).tobytes())
        h.update(repr(s.record("consolidate").table()["density"]).encode())
        h.update(repr(s.record("consolidate").table()["phi"]).encode())
    except gp.DensityTargetError as e:  # a step of phi beyond the tolerance: same bits
        h.update(str(e).encode())
    print(h.hexdigest())
    """
)


@pytest.mark.slow
def test_same_bits_on_one_and_two_threads():
    out = []
    for threads in ("1", "2"):
        env = {**os.environ, "RAYON_NUM_THREADS": threads}
        run = subprocess.run(
            [sys.executable, "-c", _DETERMINISM], env=env, capture_output=True, text=True
        )
        assert run.returncode == 0, run.stderr
        out.append(run.stdout.strip())
    assert out[0] == out[1]


@pytest.mark.parametrize(
    "changes,parameter",
    [
        ({"target_phi": 0.6, "target_void_ratio": 0.6}, "target_void_ratio"),
        ({"target_void_ratio": 0.6, "target_relative_density": 0.5}, "target_relative_density"),
        ({"target_phi": 0.0}, "target_phi"),
        ({"target_phi": 1.0}, "target_phi"),
        ({"target_phi": float("nan")}, "target_phi"),
        ({"target_void_ratio": 0.0}, "target_void_ratio"),
        ({"target_void_ratio": -0.5}, "target_void_ratio"),
        ({"target_relative_density": -0.01}, "target_relative_density"),
        ({"target_relative_density": 1.01}, "target_relative_density"),
        ({"density_tol": 0.0}, "density_tol"),
        ({"density_tol": -1e-3}, "density_tol"),
        ({"density_method": "friction"}, "density_method"),
        ({"target_phi": 0.6, "density_method": "servo"}, "density_method"),
        ({"target_phi": "0.6"}, "target_phi"),
    ],
)
def test_bad_targets_are_refused_by_name(changes, parameter):
    with pytest.raises(gp.InvalidParameterError) as info:
        P3.replace(**changes)
    assert info.value.parameter == parameter
    assert parameter in str(info.value)


def test_bad_stage_targets_are_refused_by_name(servo_deposits):
    pack = servo_deposits["box"]
    for kw, name in (
        ({"target_phi": 1.5}, "target_phi"),
        ({"target_phi": 0.6, "density_tol": 0.0}, "density_tol"),
    ):
        with pytest.raises(gp.InvalidParameterError) as info:
            gp.consolidate(pack, 1e4, **kw)
        assert info.value.parameter == name
    with pytest.raises(gp.InvalidParameterError) as info:
        gp.void_ratio_limits(P3, packs=0)
    assert info.value.parameter == "packs"


def test_targets_read_from_toml(tmp_path):
    text = P3.replace(target_void_ratio=0.6, density_tol=0.01).to_toml()
    path = tmp_path / "scene.toml"
    path.write_text(text)
    back = gp.PackScene.from_toml(path)
    assert back.density_target == ("target_void_ratio", 0.6)
    assert back.density_tol == 0.01


def test_the_command_line_passes_the_target(tmp_path, window2):
    from granpack.cli import main

    target = round(_level(window2, 0.5), 4)
    toml = tmp_path / "b2.toml"
    toml.write_text(B2.to_toml())
    out = tmp_path / "out"
    rc = main(
        ["generate", str(toml), "--target-phi", str(target), "--out", str(out), "--no-figures"]
    )
    assert rc == 0
    pack = gp.load_pack(out / "packs" / "pack_000.npz")
    assert abs(pack.record("density").table()["phi"] - target) <= 0.002
    assert "Density target target_phi" in (out / "report.md").read_text()
    with pytest.raises(SystemExit):
        main(["generate", str(toml), "--target-phi", "0.8", "--target-void-ratio", "0.2"])


def test_the_limits_command(tmp_path, window2, capsys):
    from granpack.cli import main

    toml = tmp_path / "b2.toml"
    toml.write_text(B2.to_toml())
    out = tmp_path / "limits.json"
    assert main(["limits", str(toml), "--packs", "1", "--json", str(out)]) == 0
    import json

    body = json.loads(out.read_text())
    # the same packs as void_ratio_limits' on the same scene, bit for bit
    assert body["e_min"] == window2.e_min and body["e_max"] == window2.e_max
    assert "e_min" in capsys.readouterr().out
