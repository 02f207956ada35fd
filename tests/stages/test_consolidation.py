"""Consolidation: servo walls drive a pack to its target stress, in static equilibrium.

The closed forms (one sphere and a simple-cubic lattice under the lid: Hertz's overlap
to 1e-6) are the engine's tests (src/pipeline/consolidate.rs). These check the stage on
real packs: the targets and the equilibrium reached, the virial identity between the
particles' Love-Weber stress and the walls' boundary stress, the monotone response to
the stress, the record in the pack file, determinism, and the refusals."""

from __future__ import annotations

import math
import os
import subprocess
import sys

import numpy as np
import pytest

import granpack as gp
from granpack.consolidation import hertz_overlap

SMALL = {
    "box": gp.PackScene.preset("4.3").replace(seed=3, base=(0.3, 0.3), height=0.2),
    "cylinder": gp.PackScene.preset("4.3").replace(
        seed=3, base=(0.3, 0.3), height=0.2, container="cylinder", cylinder_radius=0.15
    ),
    "periodic": gp.PackScene.preset("4.3").replace(
        seed=3, base=(0.3, 0.3), height=0.2, container="periodic"
    ),
    "2d": gp.PackScene.preset("4.1").replace(seed=3, base=(0.4,), height=0.3),
}


@pytest.fixture(scope="module")
def deposits() -> dict[str, gp.Pack]:
    return {name: gp.generate(sc.fast()) for name, sc in SMALL.items()}


def _residual(pack: gp.Pack) -> np.ndarray:
    """(1/V) sum_i x_i (x) F_i, the virial of the particles' net forces (from the contact
    table, gravity included where the stage had it): the part by which Love-Weber and
    the boundary stress differ away from equilibrium."""
    c, rec, d = pack.contacts, pack.record("consolidate").table(), pack.dim
    f = c.force_normal[:, None] * c.normal + c.force_tangential  # on j (or the wall)
    net = np.zeros((len(pack), d))
    np.add.at(net, c.i, -f)
    pair = c.j >= 0
    np.add.at(net, c.j[pair], f[pair])
    x = pack.positions
    if rec["gravity"]:
        r = pack.radii
        vol = np.pi * r**2 if d == 2 and pack.scene.inertia_2d == "disc" else 4 / 3 * np.pi * r**3
        net[:, -1] -= pack.scene.material.density * vol * pack.scene.gravity
    volume = pack.scene.base_area * rec["height"]
    # branch vectors of seam pairs are minimum images: x_j - x_i differs from them by a
    # period, laterally; the vertical row holds everywhere
    res = np.einsum("na,nb->ab", x, net) / volume
    return 0.5 * (res + res.T)


@pytest.mark.parametrize("name", list(SMALL))
def test_stage_reaches_its_target_in_equilibrium(deposits, name):
    dep = deposits[name]
    stress = 1e3 if name == "2d" else 1e4
    pack = gp.consolidate(dep, stress, gravity=False)
    rec = pack.record("consolidate").table()
    assert abs(rec["wall_stress"]["lid"] - stress) <= 1e-3 * stress
    assert rec["unbalanced"] <= 1e-4
    assert rec["max_ratio"] >= rec["unbalanced"]
    # phi and e over the sample between the floor and the lid
    r = pack.radii
    solid = np.sum(np.pi * r**2) if pack.dim == 2 else np.sum(4 / 3 * np.pi * r**3)
    assert rec["phi"] == pytest.approx(solid / (pack.scene.base_area * rec["height"]), rel=1e-12)
    assert rec["void_ratio"] == pytest.approx(1 / rec["phi"] - 1, rel=1e-12)
    assert pack.height == rec["height"] and pack.phi == pytest.approx(rec["phi"], rel=1e-12)
    # the sample is denser than the deposit and lower
    assert rec["phi"] > gp.microstructure(dep, core_margin=0.02).phi
    assert rec["height"] < dep.height
    # the lid's contacts are wall -6 in every container, and the analysis takes them
    assert np.any(pack.contacts.j == -6)
    m = gp.microstructure(pack, core_margin=0.02)
    assert m.phi == pytest.approx(rec["phi"], rel=1e-12)
    # the analysis' force balance, from the contact table, is the engine's
    assert m.unbalanced == pytest.approx(rec["unbalanced"], rel=1e-9)
    assert m.unbalanced_max == pytest.approx(rec["max_ratio"], rel=1e-9)
    # Love-Weber (particles, wall contacts included) equals the walls' boundary stress
    # up to the virial of the residual net forces: an identity of static equilibrium
    lw = np.array(rec["love_weber"])
    bd = np.array(rec["boundary_stress"])
    res = _residual(pack)
    rows = slice(-1, None) if pack.scene.container == "periodic" else slice(None)
    np.testing.assert_allclose((lw - bd)[rows, -1], res[rows, -1], atol=1e-9 * stress)
    assert np.max(np.abs(lw - bd)[rows, -1]) <= 2e-3 * stress
    if pack.scene.container == "periodic":
        # no side walls: the particles carry the lid's stress alone
        assert lw[-1, -1] == pytest.approx(rec["wall_stress"]["lid"], rel=3e-3)
    else:
        # side walls' friction carries part of the load: Love-Weber sigma_zz lies
        # between the floor's stress and the lid's
        assert rec["wall_stress"]["floor"] < lw[-1, -1] < rec["wall_stress"]["lid"]


def test_isotropic_box_holds_every_wall(deposits):
    pack = gp.consolidate(deposits["box"], 1e4, "isotropic", gravity=False)
    rec = pack.record("consolidate").table()
    for n in ("x_lo", "x_hi", "y_lo", "y_hi", "lid"):
        assert abs(rec["wall_stress"][n] - 1e4) <= 1e-3 * 1e4
    assert rec["k0"] == pytest.approx(1.0, abs=2e-3)
    # the box moved in: the new scene's base is the space between the side walls, with
    # every centre inside it
    base = np.array(pack.scene.base)
    assert np.all(base < 0.3)
    assert np.all(pack.positions[:, :2] > 0) and np.all(pack.positions[:, :2] < base)
    gp.microstructure(pack, core_margin=0.02)  # the contacts touch the moved walls


def test_anisotropic_cylinder_and_box(deposits):
    cyl = gp.consolidate(deposits["cylinder"], 2e4, "anisotropic", lateral=1e4, gravity=False)
    ws = cyl.record("consolidate").table()["wall_stress"]
    assert ws["lid"] == pytest.approx(2e4, rel=1e-3)
    assert ws["cylinder"] == pytest.approx(1e4, rel=1e-3)
    assert cyl.record("consolidate").table()["k0"] == pytest.approx(0.5, rel=2e-3)
    box = gp.consolidate(deposits["box"], 2e4, "anisotropic", lateral=(1e4, 1.5e4), gravity=False)
    ws = box.record("consolidate").table()["wall_stress"]
    assert ws["x_hi"] == pytest.approx(1e4, rel=1e-3)
    assert ws["y_lo"] == pytest.approx(1.5e4, rel=1e-3)


def test_denser_and_more_connected_as_the_stress_rises(deposits):
    """phi and Z rise with the stress, and the overlaps follow Hertz: the mean overlap
    scales as the mean contact force to the 2/3, and that force as the stress over the
    number of contacts that carry it (sigma V / M), within 20 % between stresses a
    decade apart."""
    dep = deposits["box"]
    rows = []
    for stress in (1e4, 1e5, 1e6):
        pack = gp.consolidate(dep, stress, gravity=False)
        pair = pack.contacts.j >= 0
        volume = pack.scene.base_area * pack.record("consolidate").table()["height"]
        rows.append(
            (
                pack.record("consolidate").table()["phi"],
                gp.microstructure(pack, core_margin=0.02).z,
                float(np.mean(pack.contacts.overlap[pair])),
                stress * volume / np.count_nonzero(pair),
            )
        )
    phi, z, overlap, load = (np.array(c) for c in zip(*rows, strict=True))
    assert np.all(np.diff(phi) > 0) and np.all(np.diff(z) > 0)
    for k in range(len(rows) - 1):
        hertz = (load[k + 1] / load[k]) ** (2 / 3)
        assert overlap[k + 1] / overlap[k] == pytest.approx(hertz, rel=0.2)
    # and the overlap is Hertz's for that mean force, within a factor 2
    mat = dep.scene.material
    e_star = mat.young / (2 * (1 - mat.poisson**2))
    r = float(np.mean(dep.radii))
    want = hertz_overlap(load[1] / (2 * r), r / 2, e_star)
    assert 0.5 < overlap[1] / want < 2.0


def test_record_round_trips_and_deposits_have_none(deposits, tmp_path):
    dep = deposits["box"]
    assert dep.record("consolidate") is None
    dep.save(tmp_path / "dep.npz")
    assert gp.load_pack(tmp_path / "dep.npz").record("consolidate") is None
    pack = gp.consolidate(dep, 1e4, gravity=False)
    pack.save(tmp_path / "c.npz")
    back = gp.load_pack(tmp_path / "c.npz")
    assert back.record("consolidate").table() == pack.record("consolidate").table()
    np.testing.assert_array_equal(back.positions, pack.positions)
    assert back.height == pack.height
    hist = back.record("consolidate").table()["history"]
    assert len(hist["step"]) == pack.record("consolidate").table()["steps"] // 100
    assert hist["stress_error"][-1] <= 1e-3


def test_gravity_default_follows_the_weight_stress(deposits):
    dep = deposits["box"]
    r = dep.radii
    weight = np.sum(4 / 3 * np.pi * r**3) * dep.scene.material.density * dep.scene.gravity
    weight /= dep.scene.base_area
    low = gp.consolidate(dep, 50 * weight)
    assert low.record("consolidate").table()["gravity"] is True
    high = gp.consolidate(dep, 200 * weight)
    assert high.record("consolidate").table()["gravity"] is False


_DIGEST = """
import hashlib, sys, granpack as gp
dep = gp.load_pack(sys.argv[1])
for mode in ("oedometric", "isotropic", "anisotropic"):
    lateral = 5e3 if mode == "anisotropic" else None
    p = gp.consolidate(dep, 1e4, mode, lateral=lateral, gravity=False)
    h = hashlib.sha256()
    for a in (p.positions, p.velocities, p.spins, p.contacts.force_normal):
        h.update(a.tobytes())
    print(mode, p.record("consolidate").table()["steps"], h.hexdigest())
"""


@pytest.mark.parametrize("name", ["box", "periodic", "2d"])
def test_bit_identical_on_any_thread_count_and_cpu_level(deposits, tmp_path, name):
    path = tmp_path / "dep.npz"
    deposits[name].save(path)
    script = (
        _DIGEST
        if name == "box"
        else _DIGEST.replace('("oedometric", "isotropic", "anisotropic")', '("oedometric",)')
    )
    outs = []
    # one and two threads at the CPU's own level, and one thread at every level it runs
    runs = [{"RAYON_NUM_THREADS": "1"}, {"RAYON_NUM_THREADS": "2"}]
    runs += [{"RAYON_NUM_THREADS": "1", "GRANPACK_CPU_LEVEL": lv} for lv in gp.cpu_levels()]
    for extra in runs:
        env = {**os.environ, **extra}
        outs.append(
            subprocess.run(
                [sys.executable, "-c", script, str(path)],
                env=env,
                capture_output=True,
                text=True,
                check=True,
            ).stdout
        )
    assert outs[0] and all(o == outs[0] for o in outs), outs


def test_step_budget_reached_is_a_typed_error(deposits):
    with pytest.raises(gp.ConsolidationError) as err:
        gp.consolidate(deposits["box"], 1e4, max_steps=300, gravity=False)
    e = err.value
    assert e.steps == 300
    assert "lid" in e.stress and e.unbalanced > 0 and e.stress_error > 0
    assert "max_steps" in str(e)


@pytest.mark.parametrize(
    ("kwargs", "parameter"),
    [
        ({"stress": 0.0}, "consolidate.stress"),
        ({"stress": -1e4}, "consolidate.stress"),
        ({"stress": math.nan}, "consolidate.stress"),
        ({"stress": math.inf}, "consolidate.stress"),
        (
            {"stress": 1e8},
            "consolidate.stress",
        ),  # overlaps beyond max_overlap_ratio with E = 1e8 Pa
        ({"mode": "triaxial"}, "consolidate.mode"),
        ({"stress_tol": 0.0}, "consolidate.stress_tol"),
        ({"stress_tol": 1e-12}, "consolidate.stress_tol"),
        ({"unbalanced_tol": 0.0}, "consolidate.unbalanced_tol"),
        ({"max_steps": 0}, "consolidate.max_steps"),
        ({"max_steps": 10**11}, "consolidate.max_steps"),
        ({"hold": 0}, "consolidate.hold"),
        ({"gain": 0.0}, "consolidate.gain"),
        ({"local_damping": 1.0}, "consolidate.local_damping"),
        ({"max_wall_speed": -1.0}, "consolidate.max_wall_speed"),
        ({"max_wall_speed": 1e6}, "consolidate.max_wall_speed"),
        ({"lateral": 1e4}, "consolidate.lateral"),  # an oedometric stage has no lateral target
        ({"mode": "anisotropic"}, "consolidate.lateral"),
        ({"mode": "anisotropic", "lateral": (1e4, 1e4, 1e4)}, "consolidate.lateral"),
        ({"gravity": "yes"}, "consolidate.gravity"),
    ],
)
def test_bad_input_is_refused_by_name(deposits, kwargs, parameter):
    args = {"stress": 1e4, **kwargs}
    stress = args.pop("stress")
    with pytest.raises(gp.InvalidParameterError) as err:
        gp.consolidate(deposits["box"], stress, **args)
    assert err.value.parameter == parameter


def test_container_and_pack_refusals(deposits):
    for mode in ("isotropic", "anisotropic"):
        with pytest.raises(gp.InvalidParameterError) as err:
            gp.consolidate(deposits["periodic"], 1e4, mode, lateral=1e4)
        assert err.value.parameter == "consolidate.mode"
    dep = deposits["box"]
    empty = gp.Pack(
        scene=dep.scene,
        positions=np.zeros((0, 3)),
        radii=np.zeros(0),
        velocities=np.zeros((0, 3)),
        spins=np.zeros((0, 3)),
        layer=np.zeros(0, dtype=np.int64),
        contacts=dep.contacts,
        height=0.0,
    )
    with pytest.raises(gp.InvalidParameterError) as err:
        gp.consolidate(empty, 1e4)
    assert err.value.parameter == "pack"
    done = gp.consolidate(dep, 1e4, gravity=False)
    with pytest.raises(gp.InvalidParameterError) as err:
        gp.consolidate(done, 1e4)
    assert err.value.parameter == "pack"
    with pytest.raises(gp.InvalidParameterError):
        gp.consolidate("pack.npz", 1e4)  # type: ignore[arg-type]


def test_command_line(deposits, tmp_path):
    src = tmp_path / "dep.npz"
    deposits["box"].save(src)
    out = tmp_path / "c.npz"
    cmd = [sys.executable, "-m", "granpack.cli", "consolidate", str(src), "--stress", "1e4"]
    done = subprocess.run([*cmd, "--out", str(out)], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    rec = gp.load_pack(out).record("consolidate").table()
    assert rec["mode"] == "oedometric" and rec["targets"] == {"lid": 1e4}
    assert "K0" in done.stdout
    bad = subprocess.run(
        [*cmd[:-1], "-5", "--out", str(tmp_path / "x.npz")], capture_output=True, text=True
    )
    assert bad.returncode == 2 and "stress" in bad.stderr
    # never over its own input
    same = subprocess.run([*cmd, "--out", str(src)], capture_output=True, text=True)
    assert same.returncode == 2


def test_scene_table_consolidates_each_generated_pack():
    sc = SMALL["box"].replace(consolidate={"stress": 1e4, "gravity": False}).fast()
    assert gp.PackScene.from_toml_string(sc.to_toml()) == sc
    pack = gp.generate(sc)
    rec = pack.record("consolidate").table()
    assert rec["targets"] == {"lid": 1e4} and rec["gravity"] is False
    assert rec["wall_stress"]["lid"] == pytest.approx(1e4, rel=1e-3)
    # the same as consolidating the deposit afterwards, bit for bit
    again = gp.consolidate(gp.generate(sc.replace(consolidate=None)), 1e4, gravity=False)
    np.testing.assert_array_equal(pack.positions, again.positions)


@pytest.mark.parametrize(
    ("table", "parameter"),
    [
        ({"mode": "isotropic"}, "consolidate.stress"),
        ({"stress": 0}, "consolidate.stress"),
        ({"stress": 1e4, "hold": 0}, "consolidate.hold"),
        ({"stress": 1e4, "speed": 1.0}, "consolidate.speed"),
        ({"stress": 1e4, "mode": "isotropic", "lateral": 1e3}, "consolidate.lateral"),
        ("1e4", "consolidate"),
    ],
)
def test_scene_table_is_checked_by_key(table, parameter):
    with pytest.raises(gp.InvalidParameterError) as err:
        SMALL["box"].replace(consolidate=table)
    assert err.value.parameter == parameter
    with pytest.raises(gp.InvalidParameterError) as err:
        SMALL["periodic"].replace(consolidate={"stress": 1e4, "mode": "isotropic"})
    assert err.value.parameter == "consolidate.mode"


def test_settle_brings_a_deposit_to_rest(deposits):
    dep = deposits["box"]
    before = gp.microstructure(dep, core_margin=0.02)
    rested = gp.settle(dep, 1e-4)
    rec = rested.record("rest").table()
    assert rec["unbalanced"] <= 1e-4 and rec["steps"] % 100 == 0
    after = gp.microstructure(rested, core_margin=0.02)
    # the analysis counts no drag; at rest the drag is nothing
    assert after.unbalanced == pytest.approx(rec["unbalanced"], rel=0.05)
    assert after.unbalanced < before.unbalanced
    # the deposit's structure barely moves (a fast() deposit of 272 spheres, whose top
    # particles still settle: phi to H_top moves by their settling)
    assert abs(after.phi - before.phi) < 1e-2
    assert after.z == pytest.approx(before.z, abs=0.2)
    with pytest.raises(gp.InvalidParameterError) as err:
        gp.settle(dep, 0.0)
    assert err.value.parameter == "unbalanced_tol"
    with pytest.raises(gp.InvalidParameterError) as err:
        gp.settle(gp.consolidate(dep, 1e4, gravity=False))
    assert err.value.parameter == "pack"


def test_scene_rest_tol_settles_each_generated_pack(tmp_path):
    sc = SMALL["box"].replace(rest_tol=1e-4).fast()
    pack = gp.generate(sc)
    assert pack.record("rest") is not None and pack.record("rest").table()["unbalanced"] <= 1e-4
    pack.save(tmp_path / "p.npz")
    assert gp.load_pack(tmp_path / "p.npz").record("rest").table() == pack.record("rest").table()
    with pytest.raises(gp.InvalidParameterError) as err:
        SMALL["box"].replace(rest_tol=0.0)
    assert err.value.parameter == "rest_tol"
