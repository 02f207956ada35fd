"""The triaxial test along its path: the identities every row must meet (the walls'
stresses against Love-Weber, the strains against the walls' travel and volume), the
confinement the servo holds, the record in the pack file, determinism, and the
refusals. The physics (peaks, dilatancy, critical state) is in test_triaxial_physics.py."""

from __future__ import annotations

import math
import os
import subprocess
import sys

import numpy as np
import pytest

import granpack as gp
from granpack.analysis.stress import contact_forces, love_weber

SMALL = gp.PackScene.preset("4.3").replace(seed=3, base=(0.3, 0.3), height=0.2)


@pytest.fixture(scope="module")
def deposit() -> gp.Pack:
    return gp.generate(SMALL.fast())


@pytest.fixture(scope="module")
def sample(deposit) -> gp.Pack:
    return gp.consolidate(deposit, 1e5, "isotropic", gravity=False)


@pytest.fixture(scope="module")
def sheared(sample) -> gp.Pack:
    return gp.triaxial(sample, axial_strain=0.1, checks=21)


def test_each_row_has_the_walls_stress_equal_to_love_weber(sheared):
    """Smooth walls and no gravity: the boundary stress is the walls' (F/A), and it equals
    the particles' Love-Weber stress but for the virial of the net forces, which a
    quasi-static path (I = 1e-3, unbalanced ratio ~1e-3) keeps within 2 % of p."""
    t = gp.element_table(sheared)
    assert t.height == 21
    p = t["p"].to_numpy()
    assert np.all(np.abs(t["lw_p"].to_numpy() - p) <= 0.02 * p)
    assert np.all(np.abs(t["lw_q"].to_numpy() - t["q"].to_numpy()) <= 0.02 * p)
    assert t["unbalanced"].max() < 0.05


def test_at_the_end_the_walls_stress_is_love_weber_less_the_net_forces_virial(sheared):
    """The exact identity on the final sample's contact table: the sum over wall contacts
    of x_c f_c over V equals Love-Weber less (1/V) sum_i x_i F_i (the net forces'
    virial), to rounding."""
    c, x, d = sheared.contacts, sheared.positions, sheared.dim
    volume = float(np.prod(sheared.scene.base)) * sheared.height
    f = contact_forces(c.normal, c.force_normal, c.force_tangential)
    lw = love_weber(f, c.branch, volume)
    wall = c.j < 0
    boundary = np.einsum("ma,mb->ab", x[c.i[wall]] + c.branch[wall], f[wall]) / volume
    net = np.zeros((len(sheared), d))
    np.add.at(net, c.i, -f)
    np.add.at(net, c.j[~wall], f[~wall])
    virial = np.einsum("na,nb->ab", x, net) / volume
    boundary, virial = 0.5 * (boundary + boundary.T), 0.5 * (virial + virial.T)
    scale = float(np.max(np.abs(boundary)))
    assert np.max(np.abs(boundary - (lw - virial))) < 1e-9 * scale
    # and the walls' stresses are their contacts' forces over their areas (smooth walls:
    # no shear on them); the boundary sum above differs from them by the contact points'
    # offset from the wall planes, O(overlap / H)
    t = gp.element_table(sheared)
    lx, ly = sheared.scene.base
    h = sheared.height
    on = {w: f[c.j == w].sum(axis=0) for w in np.unique(c.j[wall])}
    lid = gp.contacts.LID_ID
    assert on[lid][2] / (lx * ly) == pytest.approx(t["sigma_1"][-1], rel=1e-12)
    sides = [abs(on[-2][0]) / (ly * h), abs(on[-3][0]) / (ly * h)]
    sides += [abs(on[-4][1]) / (lx * h), abs(on[-5][1]) / (lx * h)]
    assert float(np.mean(sides)) == pytest.approx(t["sigma_3"][-1], rel=1e-12)
    assert all(np.max(np.abs(f[c.j == w][:, k])) == 0.0 for w, k in ((-2, 1), (-3, 2), (lid, 0)))


def test_the_strains_are_the_walls_travel_and_volume(sheared):
    """eps_a grows by exactly the lid's constant speed; eps_v is the change of the volume
    between the walls, which the final pack's box gives exactly."""
    rec = sheared.record("triaxial")
    t = gp.element_table(sheared)
    s, rep = rec.settings, rec.report
    h0, v0 = rep["start_height"], rep["start_volume"]
    want = t["step"].to_numpy() * s["lid_speed"] * s["dt"] / h0
    assert np.allclose(t["eps_a"].to_numpy(), want, rtol=0, atol=1e-12)
    assert t["eps_a"][-1] == pytest.approx(0.1, abs=s["lid_speed"] * s["dt"] / h0)
    volume = float(np.prod(sheared.scene.base)) * sheared.height
    assert t["eps_v"][-1] == pytest.approx(1.0 - volume / v0, rel=0, abs=1e-12)
    assert t["eps_a"][-1] == pytest.approx(1.0 - sheared.height / h0, rel=0, abs=1e-12)
    phi = t["phi"].to_numpy()
    assert np.allclose(t["e"].to_numpy(), 1.0 / phi - 1.0, rtol=1e-12)


def test_the_rate_is_the_inertial_number_asked_for(sheared, sample):
    rec = sheared.record("triaxial")
    s = rec.settings
    d_mean = 2.0 * float(np.mean(sample.radii))
    rho = sample.scene.material.density
    assert s["strain_rate"] == pytest.approx(1e-3 / (d_mean * math.sqrt(rho / 1e5)), rel=1e-12)
    t = gp.element_table(sheared)
    assert t["inertial"][0] == pytest.approx(1e-3, rel=1e-3)
    # I falls as p rises: eps_dot d sqrt(rho / p)
    i = t["inertial"].to_numpy()
    assert np.allclose(i, s["strain_rate"] * d_mean * np.sqrt(rho / t["p"].to_numpy()))


def test_the_side_walls_hold_the_confining_stress(sheared):
    t = gp.element_table(sheared)
    assert np.all(np.abs(t["sigma_3"].to_numpy() - 1e5) <= 0.02e5)
    # the lid carries more as the sample is compressed
    assert t["sigma_1"][-1] > 1.3e5


def test_constant_p_holds_the_mean_stress(sample):
    out = gp.triaxial(sample, axial_strain=0.05, checks=11, constant_p=True)
    t = gp.element_table(out)
    p0 = out.record("triaxial").settings["mean_stress"]
    assert p0 == pytest.approx(1e5, rel=1e-2)
    assert np.all(np.abs(t["p"].to_numpy() - p0) <= 0.02 * p0)
    assert t["q"][-1] > 0.2e5
    assert t["sigma_3"][-1] < 0.95e5  # the sides unload as the lid loads


def test_the_record_survives_the_pack_file(sheared, tmp_path):
    path = tmp_path / "sheared.npz"
    sheared.save(path)
    back = gp.load_pack(path)
    assert back.record("triaxial").report == sheared.record("triaxial").report
    assert gp.element_table(back).equals(gp.element_table(sheared))
    assert [r.stage for r in back.history][-2:] == ["consolidate", "triaxial"]


def test_a_second_test_starts_from_the_first_ones_end(sheared):
    """The sheared sample's walls are where the triaxial left them, and an oedometer on it
    starts from the stresses the triaxial ended at: its first row is the triaxial's last
    (but for the springs' history, which a pack does not keep)."""
    out = gp.oedometer(sheared, [1.5e5])
    start = out.record("oedometer").report["start_height"]
    assert start == pytest.approx(sheared.height, rel=5e-3)
    first = gp.element_table(out).row(0, named=True)
    last = gp.element_table(sheared).row(-1, named=True)
    assert first["sigma_1"] == pytest.approx(last["sigma_1"], rel=2e-3)
    assert first["e"] == pytest.approx(last["e"], rel=2e-2)


def test_cylinder_and_2d_biaxial(deposit):
    cyl_scene = SMALL.replace(container="cylinder", cylinder_radius=0.15)
    cyl = gp.consolidate(gp.generate(cyl_scene.fast()), 5e4, "isotropic", gravity=False)
    out = gp.triaxial(cyl, axial_strain=0.04, checks=5)
    t = gp.element_table(out)
    assert np.all(np.abs(t["sigma_3"].to_numpy() - 5e4) <= 0.02 * 5e4)
    radius = out.record("triaxial").report["walls"]["cylinder"]
    assert out.scene.cylinder_radius == pytest.approx(radius)
    sc2 = gp.PackScene.preset("4.1").replace(seed=3, base=(0.4,), height=0.3)
    two = gp.consolidate(gp.generate(sc2.fast()), 2e3, "isotropic", gravity=False)
    out2 = gp.triaxial(two, axial_strain=0.04, checks=5)
    t2 = gp.element_table(out2)
    # in 2D p = (s1 + s3) / 2
    assert np.allclose(t2["p"].to_numpy(), 0.5 * (t2["sigma_1"] + t2["sigma_3"]).to_numpy())
    assert t2["q"][-1] > 0


_DIGEST = """
import sys, hashlib, numpy as np, granpack as gp
pack = gp.load_pack(sys.argv[1])
out = gp.triaxial(pack, axial_strain=0.02, checks=3)
t = gp.element_table(out)
h = hashlib.sha256(out.positions.tobytes())
for c in t.columns:
    h.update(t[c].to_numpy().astype(np.float64).tobytes())
print(h.hexdigest())
"""


def test_bit_identical_on_any_thread_count_and_cpu_level(sample, tmp_path):
    path = tmp_path / "sample.npz"
    sample.save(path)
    runs = [{"RAYON_NUM_THREADS": "1"}, {"RAYON_NUM_THREADS": "2"}]
    runs += [{"RAYON_NUM_THREADS": "1", "GRANPACK_CPU_LEVEL": lv} for lv in gp.cpu_levels()]
    outs = [
        subprocess.run(
            [sys.executable, "-c", _DIGEST, str(path)],
            env={**os.environ, **extra},
            capture_output=True,
            text=True,
            check=True,
        ).stdout
        for extra in runs
    ]
    assert outs[0] and all(o == outs[0] for o in outs), outs


@pytest.mark.parametrize(
    ("kwargs", "parameter"),
    [
        ({"confining": -1.0}, "confining"),
        ({"confining": 0.0}, "confining"),
        ({"confining": math.nan}, "confining"),
        ({"confining": "1e5"}, "confining"),
        ({"axial_strain": 1.0}, "axial_strain"),
        ({"axial_strain": 0.0}, "axial_strain"),
        ({"inertial_number": 0.2}, "inertial_number"),
        ({"inertial_number": -1e-3}, "inertial_number"),
        ({"inertial_number": math.inf}, "inertial_number"),
        ({"checks": 1}, "checks"),
        ({"checks": 2.5}, "checks"),
        ({"constant_p": 1}, "constant_p"),
        ({"wall_friction": -0.1}, "wall_friction"),
        ({"local_damping": 1.0}, "local_damping"),
        ({"gain": 0.0}, "gain"),
        ({"dt": -1e-5}, "dt"),
    ],
)
def test_bad_settings_are_refused_naming_them(sample, kwargs, parameter):
    with pytest.raises(gp.InvalidParameterError) as exc:
        gp.triaxial(sample, **kwargs)
    assert exc.value.parameter == parameter
    assert parameter in str(exc.value)


def test_an_unconsolidated_pack_is_refused(deposit):
    with pytest.raises(gp.InvalidParameterError, match="consolidate") as exc:
        gp.triaxial(deposit, 1e5)
    assert exc.value.parameter == "pack"
    with pytest.raises(gp.InvalidParameterError) as exc:
        gp.triaxial("sample.npz", 1e5)  # type: ignore[arg-type]
    assert exc.value.parameter == "pack"


def test_a_periodic_cell_is_refused_for_the_triaxial():
    sc = SMALL.replace(container="periodic")
    pack = gp.consolidate(gp.generate(sc.fast()), 1e5, gravity=False)
    with pytest.raises(gp.InvalidParameterError, match="no side walls") as exc:
        gp.triaxial(pack, 1e5)
    assert exc.value.parameter == "container"


def test_an_oedometric_sample_needs_its_confining_stress(deposit):
    oed = gp.consolidate(deposit, 1e5, gravity=False)
    with pytest.raises(gp.InvalidParameterError, match="no lateral target") as exc:
        gp.triaxial(oed)
    assert exc.value.parameter == "confining"
    out = gp.triaxial(oed, 5e4, axial_strain=0.01, checks=2)
    assert gp.element_table(out)["sigma_3"][-1] == pytest.approx(5e4, rel=0.02)


def test_a_tested_pack_exports_where_the_test_left_it(sheared, tmp_path):
    """The exports and the analysis read the walls of the last stage that moved them:
    the LAMMPS input's lid is the triaxial's final one, and the analysis' phi is the
    table's last."""
    from granpack.io.lammps_input import lid_force, lid_height

    assert lid_height(sheared) == pytest.approx(sheared.height, rel=1e-12)
    t = gp.element_table(sheared)
    area = float(np.prod(sheared.scene.base))
    assert lid_force(sheared) == pytest.approx(t["sigma_1"][-1] * area, rel=1e-9)
    gp.write(sheared, tmp_path / "sheared.data", format="lammps-data")
    text = (tmp_path / "in.granpack").read_text()
    assert f"lid z = {sheared.height!r}" in text or f"lid z = {sheared.height:.17g}" in text
    with pytest.warns(Warning):  # the small sample has no core beyond the walls' margin
        m = gp.microstructure(sheared)
    assert m.phi == pytest.approx(t["phi"][-1], rel=1e-9)
