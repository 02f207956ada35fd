"""Every export carries the material's contact model (`granpack.Material`: the linear law,
its stiffnesses, rolling resistance "epsd") where the format has a place for it, with the
values the material implies; a default material's files are what they always were.

The packs are made once (a small 3D pack, the stored 2D packs of tests/data) and given
each material with `dataclasses.replace`: the exports read the material from the scene,
so no engine run is needed for the field checks. The peers' checks run the written
inputs in LAMMPS 29Sep2021, LIGGGHTS 3.8 and YADE 2023.02a (Debian packages) and
Kratos 10.4.4.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import re
import subprocess
from pathlib import Path

import numpy as np
import pytest
from peer_runs import run
from scenes import small_scene

import granpack as gp
from granpack.io import export
from granpack.io.kratos import read_kratos
from granpack.io.lammps_input import tsuji_alpha

DATA = Path(__file__).parents[1] / "data" / "packs_0_1_0"

LINEAR = gp.Material(contact_law="linear", normal_stiffness=2e4)
LINEAR_ROLLING = gp.Material(
    contact_law="linear",
    normal_stiffness=2e4,
    tangential_stiffness=1.5e4,
    rolling="epsd",
    rolling_friction=0.3,
    rolling_stiffness=5e3,
    rolling_damping=0.01,
)
HERTZ_ROLLING = gp.Material(rolling="epsd", rolling_friction=0.2)
MATERIALS = {"linear": LINEAR, "linear-rolling": LINEAR_ROLLING, "hertz-rolling": HERTZ_ROLLING}


@pytest.fixture(scope="module")
def pack3d() -> gp.Pack:
    return gp.generate(small_scene(3).fast())


@pytest.fixture(scope="module")
def pack2d() -> gp.Pack:
    return gp.load_pack(DATA / "density.npz")


def with_material(pack: gp.Pack, material: gp.Material) -> gp.Pack:
    return dataclasses.replace(pack, scene=pack.scene.replace(material=material))


def mean_pair(pack: gp.Pack) -> tuple[float, float, float]:
    """The means of R*, the overlap and m* over the particle-particle contacts, from the
    contact table by hand."""
    r = pack.radii
    rho = pack.scene.material.density
    disc = pack.dim == 2 and pack.scene.inertia_2d == "disc"
    m = rho * math.pi * r**2 if disc else rho * 4.0 / 3.0 * math.pi * r**3
    rs, ds, ms = [], [], []
    for i, j, d in zip(pack.contacts.i, pack.contacts.j, pack.contacts.overlap, strict=True):
        if j < 0:
            continue
        rs.append(r[i] * r[j] / (r[i] + r[j]))
        ds.append(d)
        ms.append(m[i] * m[j] / (m[i] + m[j]))
    return float(np.mean(rs)), float(np.mean(ds)), float(np.mean(ms))


def exported(pack: gp.Pack, folder: Path, fmt: str) -> dict[str, str]:
    """The text of every file the export writes, by file name."""
    suffix = {"pfc": "p3dat" if pack.dim == 3 else "p2dat"}.get(fmt, "out")
    written = export(pack, folder / f"pack.{suffix}", fmt)
    return {p.name: p.read_text() for p in written}


def lammps_law(text: str, prefix: str) -> list[str]:
    """The words of the law on the first line that starts with `prefix`."""
    line = next(ln for ln in text.splitlines() if ln.startswith(prefix))
    return line.split()


def after(words: list[str], key: str, n: int) -> list[float]:
    at = words.index(key)
    return [float(w) for w in words[at + 1 : at + 1 + n]]


# -- a default material --------------------------------------------------------------------
MODEL_MARKS = (
    "rolling",
    "hooke",
    "contact model:",
    "contact cmat",
    "yade:",
    "MaterialsDEM.json, the material relation",
    "epsd",
    "linear",
)
FORMATS = ("lammps-data", "liggghts", "pfc", "yade", "kratos", "mercurydpm", "demengine")


@pytest.mark.parametrize("fmt", FORMATS)
def test_a_default_material_writes_no_model_lines(fmt, pack3d, tmp_path):
    a = exported(pack3d, tmp_path, fmt)
    # an equal material given explicitly, and the model keys at their defaults
    explicit = gp.Material(contact_law="hertz_mindlin", rolling="none")
    (tmp_path / "b").mkdir()
    b = exported(with_material(pack3d, explicit), tmp_path / "b", fmt)
    assert a == b
    for name, text in a.items():
        low = text.lower()
        for mark in MODEL_MARKS:
            assert mark.lower() not in low, (name, mark)


# -- LAMMPS ----------------------------------------------------------------------------------
def test_lammps_linear_law_has_the_stiffnesses_and_the_damping_of_xi(pack3d, tmp_path):
    m = LINEAR
    text = exported(with_material(pack3d, m), tmp_path, "lammps-data")["in.granpack"]
    k_t = 2e4 * 2.0 * (1.0 - m.poisson) / (2.0 - m.poisson)
    for prefix in ("pair_coeff", "fix             floor", "fix             wall_x"):
        w = lammps_law(text, prefix)
        k_n, e = after(w, "hooke", 2)
        assert k_n == 2e4
        # LAMMPS 29Sep2021: eta_n = alpha(e) sqrt(m* k_n) = 2 xi sqrt(m* k_n)
        assert tsuji_alpha(e) == pytest.approx(2.0 * m.damping, rel=1e-12)
        kt, x_t, mu = after(w, "linear_history", 3)
        assert kt == pytest.approx(k_t, rel=1e-15)
        assert x_t == pytest.approx(math.sqrt(k_t / 2e4), rel=1e-15)
        assert mu == m.friction
        assert w[w.index("damping") + 1] == "tsuji" and "limit_damping" in w
        assert "rolling" not in w and "hertz/material" not in w


def test_lammps_rolling_sds_takes_the_given_stiffness_and_damping(pack3d, tmp_path):
    text = exported(with_material(pack3d, LINEAR_ROLLING), tmp_path, "lammps-data")
    laws = [ln.split() for ln in text["in.granpack"].splitlines() if " hooke " in ln]
    assert len(laws) == 4  # pair_coeff, floor, x and y walls
    for w in laws:
        assert after(w, "sds", 3) == [5e3, 0.01, 0.3]
        assert after(w, "linear_history", 1) == [1.5e4]


def test_lammps_derived_rolling_stiffness_is_at_the_mean_contact(pack3d, tmp_path):
    m = HERTZ_ROLLING
    text = exported(with_material(pack3d, m), tmp_path, "lammps-data")["in.granpack"]
    r_star, d, _ = mean_pair(pack3d)
    k_n = 2.0 * m.young / (2.0 * (1.0 - m.poisson**2)) * math.sqrt(r_star * d)
    for prefix in ("pair_coeff", "fix             floor"):
        w = lammps_law(text, prefix)
        k_r, gamma_r, mu_r = after(w, "sds", 3)
        assert k_r == pytest.approx(2.25 * 0.2**2 * k_n, rel=1e-12)
        assert (gamma_r, mu_r) == (0.0, 0.2)
        assert "hertz/material" in w  # the Hertz law as before
    assert "k_roll: 2.25 mu_r^2 k_n with k_n = 2 E* sqrt(R* d) at the pack's mean contact" in text


def test_a_consolidated_2d_pack_gives_its_lid_the_linear_law_and_rolling(tmp_path):
    pack = gp.load_pack(DATA / "consolidation_tiled.npz")
    # (a k_n that carries the stage's 10 kPa at a small overlap: the scene refuses one
    # whose mean contact would need more than max_overlap_ratio)
    m = gp.Material(
        contact_law="linear", normal_stiffness=1e5, rolling="epsd", rolling_friction=0.1
    )
    text = exported(with_material(pack, m), tmp_path, "lammps-data")["in.granpack"]
    lid = lammps_law(text, "fix             lid")
    assert after(lid, "hooke", 1) == [1e5]
    # linear law: k_roll = 2.25 mu_r^2 k_n exactly
    assert after(lid, "sds", 3) == pytest.approx([2.25 * 0.01 * 1e5, 0.0, 0.1], rel=1e-15)
    assert "hertz" not in text  # no Hertz wall notes for a linear pack
    # the servo's gain is the inverse of the lid contacts' stiffness, k_n each
    gain = float(re.search(r"lid_gain equal (\S+)", text).group(1))
    lid_at = float(re.search(r"lid all wall/gran granular .* yplane NULL (\S+)", text).group(1))
    top = pack.positions[:, -1] + pack.radii - lid_at
    assert gain == pytest.approx(1.0 / (1e5 * max(int((top > 0).sum()), 1)), rel=1e-5)


def test_lammps_refuses_a_linear_damping_beyond_tsuji(pack3d, tmp_path):
    m = gp.Material(contact_law="linear", normal_stiffness=2e4, damping=0.7)
    with pytest.raises(gp.InvalidParameterError, match="Tsuji damping reaches at most 0.636"):
        export(with_material(pack3d, m), tmp_path / "p.data", "lammps-data")
    assert not (tmp_path / "p.data").exists()


# -- LIGGGHTS --------------------------------------------------------------------------------
def liggghts_property(text: str, name: str) -> float:
    found = re.search(
        rf"property/global {name} (?:peratomtypepair 1|peratomtype|scalar) (\S+)", text
    )
    assert found is not None, name
    return float(found.group(1))


def test_liggghts_linear_law_is_hooke_stiffness_damped_at_the_mean_reduced_mass(pack3d, tmp_path):
    m = LINEAR_ROLLING
    text = exported(with_material(pack3d, m), tmp_path, "liggghts")["in.granpack"]
    _, _, m_star = mean_pair(pack3d)
    assert liggghts_property(text, "kn") == 2e4
    assert liggghts_property(text, "kt") == 1.5e4
    assert liggghts_property(text, "gamman") == pytest.approx(
        2.0 * m.damping * math.sqrt(2e4 / m_star), rel=1e-12
    )
    assert liggghts_property(text, "gammat") == pytest.approx(
        2.0 * m.damping * math.sqrt(1.5e4 / m_star), rel=1e-12
    )
    assert liggghts_property(text, "coefficientFriction") == m.friction
    assert "youngsModulus" not in text
    assert (
        "pair_style      gran model hooke/stiffness tangential history rolling_friction epsd3"
        in text
    )
    walls = [ln for ln in text.splitlines() if "wall/gran" in ln and not ln.startswith("#")]
    assert walls and all(
        "hooke/stiffness tangential history rolling_friction epsd3" in w for w in walls
    )
    # epsd3: k_r = rollingStiffness k_n mu_r^2 (times R*^2 on the rotation), k_n LIGGGHTS'
    assert liggghts_property(text, "coefficientRollingFriction") == 0.3
    assert liggghts_property(text, "rollingStiffness") * 0.3**2 * 2e4 == pytest.approx(
        5e3, rel=1e-12
    )


def test_liggghts_rolling_stiffness_of_a_hertz_pack_is_granpacks_on_every_contact(pack3d, tmp_path):
    text = exported(with_material(pack3d, HERTZ_ROLLING), tmp_path, "liggghts")["in.granpack"]
    # LIGGGHTS' Hertz k_n is the secant 4/3 E* sqrt(R* d), 2/3 of granpack's 2 E* sqrt(R* d)
    assert liggghts_property(text, "rollingStiffness") * 4.0 / 3.0 == pytest.approx(2.25 * 2.0)
    assert liggghts_property(text, "coefficientRollingViscousDamping") == 0.0
    assert liggghts_property(text, "youngsModulus") == HERTZ_ROLLING.young
    assert "pair_style      gran model hertz tangential history rolling_friction epsd3" in text


def test_liggghts_refuses_a_rolling_stiffness_below_its_bound(pack3d, tmp_path):
    m = gp.Material(
        contact_law="linear",
        normal_stiffness=2e4,
        rolling="epsd",
        rolling_friction=0.3,
        rolling_stiffness=100.0,  # k_r / (mu_r^2 k_n) = 0.56 < 1
    )
    with pytest.raises(gp.InvalidParameterError, match="rollingStiffness") as info:
        export(with_material(pack3d, m), tmp_path / "p.data", "liggghts")
    assert info.value.parameter == "rolling_stiffness"
    assert not (tmp_path / "p.data").exists()


# -- PFC -----------------------------------------------------------------------------------
def pfc_contact_line(text: str) -> dict[str, float] | None:
    lines = [ln for ln in text.splitlines() if ln.startswith("contact cmat default model")]
    if not lines:
        return None
    (line,) = lines
    words = line.split()
    props = words[words.index("property") + 1 :]
    return {
        "model": words[4],
        **{k: float(v) for k, v in zip(props[::2], props[1::2], strict=True)},
    }


def test_pfc_sets_linear_and_rrlinear_with_the_materials_values(pack3d, pack2d, tmp_path):
    for pack in (pack3d, pack2d):
        (text,) = exported(with_material(pack, LINEAR), tmp_path, "pfc").values()
        assert pfc_contact_line(text) == {
            "model": "linear",
            "kn": 2e4,
            "ks": LINEAR.tangential_stiffness_or_default,
            "fric": 0.2,
            "dp_nratio": 0.1,
            "dp_sratio": 0.1,
        }
        (text,) = exported(with_material(pack, LINEAR_ROLLING), tmp_path, "pfc").values()
        got = pfc_contact_line(text)
        assert got is not None and got["model"] == "rrlinear"
        assert (got["kn"], got["ks"], got["rr_fric"]) == (2e4, 1.5e4, 0.3)
        # the contact command comes before the balls
        assert text.index("contact cmat") < text.index("ball create")


def test_pfc_sets_no_model_for_hertz_with_rolling(pack3d, tmp_path):
    (text,) = exported(with_material(pack3d, HERTZ_ROLLING), tmp_path, "pfc").values()
    assert pfc_contact_line(text) is None
    assert "; contact model: rolling=epsd rolling_friction=0.2" in text
    assert "PFC's hertz model has no rolling resistance" in text


# -- YADE ----------------------------------------------------------------------------------
def yade_lines(text: str) -> str:
    return "\n".join(ln[len("# yade: ") :] for ln in text.splitlines() if ln.startswith("# yade: "))


def test_yade_lines_name_the_materials_law(pack3d, tmp_path):
    (text,) = exported(with_material(pack3d, LINEAR), tmp_path, "yade").values()
    code = yade_lines(text)
    k_t = LINEAR.tangential_stiffness_or_default
    assert f"kn=MatchMaker(algo='val', val={2e4!r})" in code
    assert f"ks=MatchMaker(algo='val', val={k_t!r})" in code
    assert "Law2_ScGeom_FrictPhys_CundallStrack()" in code
    assert f"frictionAngle={math.atan(0.2)!r}" in code
    (text,) = exported(with_material(pack3d, LINEAR_ROLLING), tmp_path, "yade").values()
    code = yade_lines(text)
    r_star, _, _ = mean_pair(pack3d)
    young = float(re.search(r"young=(\S+?),", code).group(1))
    assert 2.0 * young * r_star == pytest.approx(2e4, rel=1e-12)  # YADE's k_n = 2 E R*
    assert float(re.search(r"alphaKr=(\S+?),", code).group(1)) == 5e3 / (4.0 * 1.5e4)
    assert float(re.search(r"etaRoll=(\S+?)\)", code).group(1)) == 0.15
    assert float(re.search(r"poisson=(\S+?),", code).group(1)) == 0.75
    assert "useIncrementalForm=True" in code and "Ig2_Sphere_Sphere_ScGeom6D()" in code
    (text,) = exported(with_material(pack3d, HERTZ_ROLLING), tmp_path, "yade").values()
    code = yade_lines(text)
    r_star, d, _ = mean_pair(pack3d)
    k_n = 2.0 * HERTZ_ROLLING.e_star * math.sqrt(r_star * d)
    krot = float(re.search(r"krot=(\S+?),", code).group(1))
    assert krot == pytest.approx(2.25 * 0.04 * k_n * r_star**2, rel=1e-12)
    assert "eta=0.1)" in code and "betan=0.1, betas=0.1" in code
    assert "includeMoment=True" in code


def test_yade_file_with_model_lines_reads_back_the_same(pack3d, tmp_path):
    pack = with_material(pack3d, LINEAR_ROLLING)
    path = export(pack, tmp_path / "p.txt", "yade")[0]
    back = gp.read_particles(path)
    np.testing.assert_array_equal(back.positions, pack.positions)
    np.testing.assert_array_equal(back.radii, pack.radii)
    assert back.container == pack.scene.container


# -- Kratos, DEM-Engine -----------------------------------------------------------------------
def kratos_relation(text: str) -> dict:
    line = next(ln for ln in text.splitlines() if "the material relation's Variables" in ln)
    return json.loads(line.split("Variables: ", 1)[1])


def test_kratos_comment_gives_the_material_relation(pack3d, tmp_path):
    pack = with_material(pack3d, LINEAR_ROLLING)
    (text,) = exported(pack, tmp_path, "kratos").values()
    rel = kratos_relation(text)
    e = rel.pop("COEFFICIENT_OF_RESTITUTION")
    # Kratos' linear damping 2 gamma sqrt(m* k_n), gamma = -ln e / sqrt(pi^2 + ln^2 e) = xi
    assert -math.log(e) / math.sqrt(math.pi**2 + math.log(e) ** 2) == pytest.approx(0.1, rel=1e-12)
    assert rel == {
        "DEM_DISCONTINUUM_CONSTITUTIVE_LAW_NAME": "DEM_D_Linear_Custom_Constants",
        "K_NORMAL": 2e4,
        "K_TANGENTIAL": 1.5e4,
        "STATIC_FRICTION": 0.2,
        "DYNAMIC_FRICTION": 0.2,
        "DEM_ROLLING_FRICTION_MODEL_NAME": "DEMRollingFrictionModelConstantTorque",
        "ROLLING_FRICTION": 0.3,
        "ROLLING_FRICTION_WITH_WALLS": 0.3,
    }
    back = read_kratos(tmp_path / "pack.out")
    np.testing.assert_array_equal(back.radii, pack.radii)


def test_demengine_templates_record_the_model(pack3d, tmp_path):
    texts = exported(with_material(pack3d, HERTZ_ROLLING), tmp_path, "demengine")
    assert "# contact model: rolling=epsd rolling_friction=0.2\n" in texts["pack.templates.csv"]


# -- the peers run the written inputs ---------------------------------------------------------
STEP0 = 'print "CONTACTS $(c_contacts)"\n'


def _contacts(log: str) -> float:
    return float(re.findall(r"^CONTACTS (\S+)", log, re.MULTILINE)[-1])


@pytest.mark.parametrize("name", list(MATERIALS))
def test_lammps_and_liggghts_run_the_model_lines(name, lmp, liggghts, pack3d, pack2d, tmp_path):
    pairs3 = 2 * int((pack3d.contacts.j >= 0).sum())
    pack = with_material(pack3d, MATERIALS[name])
    for program, fmt in ((lmp, "lammps-data"), (liggghts, "liggghts")):
        export(pack, tmp_path / "pack.data", fmt)
        log = run(program, tmp_path, "include in.granpack\n" + STEP0)
        assert _contacts(log) == pairs3
        run(program, tmp_path, "variable steps index 20\ninclude in.granpack\n")
    pack = with_material(pack2d, MATERIALS[name])
    export(pack, tmp_path / "pack.data", "lammps-data")
    log = run(lmp, tmp_path, "include in.granpack\n" + STEP0)
    assert _contacts(log) == 2 * int((pack2d.contacts.j >= 0).sum())
    run(lmp, tmp_path, "variable steps index 20\ninclude in.granpack\n")


def _law_line(text: str, prefix: str) -> str:
    return next(ln for ln in text.splitlines() if ln.startswith(prefix))


def restitution_of_the_linear_law(xi: float) -> float:
    """The restitution of granpack's linear law, m* x'' = -max(0, k x + c x') with
    c = 2 xi sqrt(m* k), integrated in its own time unit (m* = k = 1) by velocity Verlet
    at 1e-5 of the period: the clamped total force makes it differ from the undamped
    oscillator's exp(-pi xi / sqrt(1 - xi^2))."""
    x, v, dt = 0.0, 1.0, 2.0 * math.pi * 1e-5
    c = 2.0 * xi
    f = 0.0
    while True:
        v += 0.5 * dt * f
        x += dt * v
        if x <= 0.0:
            return -v
        f = -max(0.0, x + c * v)
        v += 0.5 * dt * f


HEAD_ON = """units           si
atom_style      sphere
atom_modify     map array
dimension       3
boundary        f f f
region          box block -0.2 0.2 -0.1 0.1 -0.1 0.1 units box
create_box      1 box
create_atoms    1 single {x1} 0.0 0.0 units box
create_atoms    1 single {x2} 0.0 0.0 units box
set             atom 1 diameter {d1} density 1000.0
set             atom 2 diameter {d2} density 1000.0
velocity        all set 0.0 0.0 0.0
set             atom 1 vx 0.5
set             atom 2 vx -0.5
comm_modify     vel yes
neighbor        0.005 bin
pair_style      granular
{pair_coeff}
fix             integrate all nve/sphere
timestep        1e-6
run             20000
print           "V $(vx[1]) $(vx[2])"
"""


def test_lammps_linear_law_gives_granpacks_restitution_for_any_reduced_mass(lmp, pack3d, tmp_path):
    """Two spheres meet head-on at 1 m/s under the exported pair law: they come apart
    with the restitution of granpack's law for damping ratio 0.1 and 0.3, for equal and
    for unequal spheres (m* differs 4-fold): the damping is 2 xi sqrt(m* k_n) on every
    contact."""
    for xi in (0.1, 0.3):
        m = dataclasses.replace(LINEAR, damping=xi)
        text = exported(with_material(pack3d, m), tmp_path, "lammps-data")["in.granpack"]
        want = restitution_of_the_linear_law(xi)
        for r1, r2 in ((0.02, 0.02), (0.01, 0.03)):
            gap = 1e-4
            script = HEAD_ON.format(
                x1=-r1 - gap / 2,
                x2=r2 + gap / 2,
                d1=2 * r1,
                d2=2 * r2,
                pair_coeff=_law_line(text, "pair_coeff"),
            )
            log = run(lmp, tmp_path, script)
            v1, v2 = (float(v) for v in re.findall(r"^V (\S+) (\S+)", log, re.MULTILINE)[-1])
            assert (v2 - v1) / 1.0 == pytest.approx(want, abs=1e-3), (xi, r1, r2)


ROLLING_LAMMPS = """units           si
atom_style      sphere
atom_modify     map array
dimension       3
boundary        f f f
region          box block -1.0 1.0 -0.1 0.1 -0.1 0.2 units box
create_box      1 box
create_atoms    1 single 0.0 0.0 {z} units box
set             atom 1 diameter {d} density 1000.0
velocity        all set {v} 0.0 0.0
set             atom 1 omega 0.0 {w} 0.0
comm_modify     vel yes
neighbor        0.005 bin
{floor}
fix             gravity all gravity 2.0 vector 0 0 -1
fix             integrate all nve/sphere
timestep        1e-6
run             20000
print           "V $(vx[1])"
run             50000
print           "V $(vx[1])"
"""


def test_a_sphere_rolls_on_the_lammps_floor_with_granpacks_plastic_deceleration(
    lmp, pack3d, tmp_path
):
    """A sphere rolling on the exported floor (rolling sds on fix wall/gran) in the
    plastic regime decelerates at 5/7 mu_r g (torque mu_r r m g, R* = r on a wall)."""
    # friction enough to keep it rolling: the contact's friction force is 2/7 of m g... times mu_r
    m = dataclasses.replace(LINEAR_ROLLING, friction=0.8)
    text = exported(with_material(pack3d, m), tmp_path, "lammps-data")
    floor = _law_line(text["in.granpack"], "fix             floor")
    r, g, v = 0.02, 2.0, 0.2
    mass = 1000.0 * 4.0 / 3.0 * math.pi * r**3
    script = ROLLING_LAMMPS.format(z=r - mass * g / 2e4, d=2 * r, v=v, w=v / r, floor=floor)
    log = run(lmp, tmp_path, script)
    v1, v2 = (float(x) for x in re.findall(r"^V (\S+)", log, re.MULTILINE)[-2:])
    assert (v2 - v1) / 0.05 == pytest.approx(-5.0 / 7.0 * 0.3 * g, rel=0.01)


ROLLING_LIGGGHTS = """units           si
atom_style      granular
atom_modify     map array
boundary        f f f
newton          off
communicate     single vel yes
read_data       sphere.data
neighbor        0.005 bin
{model}
{floor}
fix             gravity all gravity 2.0 vector 0.0 0.0 -1.0
fix             integrate all nve/sphere
timestep        1e-6
variable        vx equal vx[1]
run             20000
print           "V ${{vx}}"
run             50000
print           "V ${{vx}}"
"""


@pytest.mark.parametrize("name", ["linear-rolling", "hertz-rolling"])
def test_a_sphere_rolls_on_the_liggghts_floor_with_granpacks_plastic_deceleration(
    name, liggghts, pack3d, tmp_path
):
    """The same on LIGGGHTS' floor (rolling_friction epsd3), with the linear law and with
    Hertz: 5/7 mu_r g."""
    m = dataclasses.replace(MATERIALS[name], friction=0.8)
    text = exported(with_material(pack3d, m), tmp_path, "liggghts")["in.granpack"]
    lines = text.splitlines()
    model = "\n".join(
        ln for ln in lines if ln.startswith(("fix             m", "pair_style", "pair_coeff"))
    )
    floor = _law_line(text, "fix             floor")
    r, g, v = 0.02, 2.0, 0.2
    mass = 1000.0 * 4.0 / 3.0 * math.pi * r**3
    if m.contact_law == "linear":
        d = mass * g / 2e4
    else:  # m g = 4/3 E* sqrt(r) d^1.5
        d = (mass * g / (4.0 / 3.0 * m.e_star * math.sqrt(r))) ** (2.0 / 3.0)
    # LIGGGHTS' set takes no omega: the spin comes in the data file's Velocities
    (tmp_path / "sphere.data").write_text(
        "one sphere\n\n1 atoms\n1 atom types\n-1.0 1.0 xlo xhi\n-0.1 0.1 ylo yhi\n"
        f"-0.1 0.2 zlo zhi\n\nAtoms\n\n1 1 {2 * r!r} 1000.0 0.0 0.0 {r - d!r}\n\n"
        f"Velocities\n\n1 {v!r} 0.0 0.0 0.0 {v / r!r} 0.0\n"
    )
    script = ROLLING_LIGGGHTS.format(model=model, floor=floor)
    log = run(liggghts, tmp_path, script)
    v1, v2 = (float(x) for x in re.findall(r"^V (\S+)", log, re.MULTILINE)[-2:])
    mu_r = m.rolling_friction
    assert (v2 - v1) / 0.05 == pytest.approx(-5.0 / 7.0 * mu_r * g, rel=0.01)


YADE_SCRIPT = """\
import json
import sys

from yade import ymport

path, out = sys.argv[1:3]
code = [ln[len("# yade: "):] for ln in open(path) if ln.startswith("# yade: ")]
exec("\\n".join(code))
O.bodies.append(ymport.text(path))
O.engines = [
    ForceResetter(),
    InsertionSortCollider([Bo1_Sphere_Aabb()], verletDist=0),
    InteractionLoop([ig2], [ip2], [law2]),
    NewtonIntegrator(gravity=(0, 0, -2)),
]
O.dt = 1e-6
O.run(5, True)
rows = []
for I in O.interactions:
    if I.isReal:
        p = I.phys
        row = {k: getattr(p, k) for k in ("kn", "ks", "kr", "maxRollPl", "maxBendPl", "betan")
               if hasattr(p, k)}
        row["radii"] = [O.bodies[I.id1].shape.radius, O.bodies[I.id2].shape.radius]
        rows.append(row)
json.dump({"material": type(O.materials[-1]).__name__, "rows": rows}, open(out, "w"))
"""


def run_yade(yade: str, pack: gp.Pack, folder: Path) -> dict:
    path = export(pack, folder / "pack.txt", "yade")[0]
    (folder / "run.py").write_text(YADE_SCRIPT)
    env = {k: v for k, v in os.environ.items() if k != "VIRTUAL_ENV"}
    env["OMP_NUM_THREADS"] = "1"
    out = folder / "yade.json"
    res = subprocess.run(
        [yade, "-n", "-x", "run.py", str(path), str(out)],
        cwd=folder,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert res.returncode == 0 and out.exists(), res.stdout[-3000:] + res.stderr[-3000:]
    return json.loads(out.read_text())


def test_yade_runs_the_model_lines_with_the_mapped_stiffnesses(yade, pack3d, tmp_path):
    """YADE runs the export's ``# yade:`` lines and ymport.text's spheres for 5 steps; its
    interactions carry the mapped values: the linear law's k_n and k_t exactly; with
    rolling (CohFrictMat), k_n = 2 E R*, and the rolling stiffness and moment cap
    granpack's k_r R*^2 and mu_r R* F_n for equal radii, off by (r1 + r2)^2 / (4 r1 r2)
    and (r1 + r2) / (2 max(r1, r2)) for others; Hertz with rolling (MindlinPhys): the
    torque stiffness k_r R*^2 of the mean contact, the cap mu_r R* for equal radii."""
    got = run_yade(yade, with_material(pack3d, LINEAR), tmp_path)
    assert got["material"] == "FrictMat" and got["rows"]
    k_t = LINEAR.tangential_stiffness_or_default
    for row in got["rows"]:
        assert (row["kn"], row["ks"]) == (2e4, k_t)

    got = run_yade(yade, with_material(pack3d, LINEAR_ROLLING), tmp_path)
    assert got["material"] == "CohFrictMat" and got["rows"]
    r_mean, _, _ = mean_pair(pack3d)
    for row in got["rows"]:
        r1, r2 = row["radii"]
        rs = r1 * r2 / (r1 + r2)
        assert row["kn"] == pytest.approx(2e4 * rs / r_mean, rel=1e-12)
        assert row["ks"] == pytest.approx(0.75 * row["kn"], rel=1e-12)
        assert row["kr"] / (5e3 * rs**2) == pytest.approx(
            (row["ks"] / 1.5e4) * (r1 + r2) ** 2 / (4 * r1 * r2), rel=1e-12
        )
        assert row["maxRollPl"] / (0.3 * rs) == pytest.approx(
            (r1 + r2) / (2 * max(r1, r2)), rel=1e-12
        )

    got = run_yade(yade, with_material(pack3d, HERTZ_ROLLING), tmp_path)
    r_mean, d, _ = mean_pair(pack3d)
    krot = 2.25 * 0.04 * 2.0 * HERTZ_ROLLING.e_star * math.sqrt(r_mean * d) * r_mean**2
    for row in got["rows"]:
        r1, r2 = row["radii"]
        rs = r1 * r2 / (r1 + r2)
        assert row["kr"] == pytest.approx(krot, rel=1e-12)
        assert row["betan"] == 0.1
        assert row["maxBendPl"] / (0.2 * rs) == pytest.approx(
            (r1 + r2) ** 2 / (4 * r1 * r2), rel=1e-12
        )


def _kratos_after(pack: gp.Pack, folder: Path, relation: dict) -> np.ndarray:
    """Kratos' positions after 10 steps of 1e-5 s from the exported model part, with
    `relation` as MaterialsDEM.json's material relation."""
    from test_io_dem_codes import _KRATOS_RUN, _run_kratos

    folder.mkdir()
    export(pack, folder / "granpackDEM.mdpa", "kratos")
    m = pack.scene.material
    params = {
        "Dimension": 3,
        "BoundingBoxOption": False,
        "dem_inlet_option": False,
        "GravityX": 0.0,
        "GravityY": 0.0,
        "GravityZ": -2.0,
        "RotationOption": True,
        "CleanIndentationsOption": False,
        "solver_settings": {
            "strategy": "sphere_strategy",
            "RemoveBallsInitiallyTouchingWalls": False,
            "material_import_settings": {"materials_filename": "MaterialsDEM.json"},
        },
        "TranslationalIntegrationScheme": "Symplectic_Euler",
        "RotationalIntegrationScheme": "Direct_Integration",
        "AutomaticTimestep": False,
        "MaxTimeStep": 1e-5,
        "FinalTime": 1e-4,
        "NeighbourSearchFrequency": 1,
        "OutputTimeStep": 1.0,
        "post_gid_option": False,
        "post_vtk_option": False,
        "problem_name": "granpack",
    }
    materials = {
        "materials": [
            {
                "material_name": "granpack",
                "material_id": 1,
                "Variables": {
                    "PARTICLE_DENSITY": m.density,
                    "YOUNG_MODULUS": m.young,
                    "POISSON_RATIO": m.poisson,
                },
            }
        ],
        "material_relations": [
            {
                "material_names_list": ["granpack", "granpack"],
                "material_ids_list": [1, 1],
                "Variables": relation,
            }
        ],
        "material_assignation_table": [["SpheresPart.DEMParts_Body", "granpack"]],
    }
    (folder / "ProjectParametersDEM.json").write_text(json.dumps(params))
    (folder / "MaterialsDEM.json").write_text(json.dumps(materials))
    got = _run_kratos(_KRATOS_RUN, cwd=folder)
    assert got["time"] == pytest.approx(1e-4, rel=1e-12)
    assert got["elements"] == len(pack)
    return np.array([a[1:4] for a in sorted(got["after"])])


@pytest.mark.peers
def test_kratos_runs_the_material_relation_and_takes_its_normal_stiffness(pack3d, tmp_path):
    """Kratos' DEM stage runs 10 steps from the model part with the material relation of
    its comment line (linear law with constant stiffnesses, constant-torque rolling
    friction); the same run with K_NORMAL 100 times larger moves the spheres otherwise:
    Kratos takes the file's k_n, not one from Young's modulus."""
    from test_io_dem_codes import _kratos_or_skip

    _kratos_or_skip()
    pack = with_material(pack3d, LINEAR_ROLLING)
    (text,) = exported(pack, tmp_path, "kratos").values()
    relation = kratos_relation(text)
    a = _kratos_after(pack, tmp_path / "a", relation)
    b = _kratos_after(pack, tmp_path / "b", relation)
    np.testing.assert_array_equal(a, b)  # the run is repeatable
    stiff = _kratos_after(pack, tmp_path / "c", {**relation, "K_NORMAL": 2e6})
    assert np.max(np.abs(stiff - a)) > 1e-9


HEAD_ON_LIGGGHTS = """units           si
atom_style      granular
atom_modify     map array
boundary        f f f
newton          off
communicate     single vel yes
read_data       pair.data
neighbor        0.005 bin
{model}
fix             integrate all nve/sphere
timestep        1e-6
variable        v1 equal vx[1]
variable        v2 equal vx[2]
run             20000
print           "V ${{v1}} ${{v2}}"
"""


def test_liggghts_linear_damping_scales_with_the_reduced_mass_as_documented(
    liggghts, pack3d, tmp_path
):
    """Two spheres meet head-on at 1 m/s under the exported hooke/stiffness law: they part
    with the restitution of granpack's law at the damping ratio xi sqrt(m* / mean m*)
    (LIGGGHTS damps with gamma m*), the mean m* that of the input's gamman."""
    m = dataclasses.replace(LINEAR, damping=0.2)
    text = exported(with_material(pack3d, m), tmp_path, "liggghts")["in.granpack"]
    model = "\n".join(
        ln
        for ln in text.splitlines()
        if ln.startswith(("fix             m", "pair_style", "pair_coeff"))
    )
    gamman = liggghts_property(text, "gamman")
    mean_m_star = (2.0 * 0.2) ** 2 * 2e4 / gamman**2
    for r1, r2 in ((0.02, 0.02), (0.01, 0.03)):
        gap = 1e-4
        (tmp_path / "pair.data").write_text(
            "two spheres\n\n2 atoms\n1 atom types\n-0.2 0.2 xlo xhi\n-0.1 0.1 ylo yhi\n"
            "-0.1 0.1 zlo zhi\n\nAtoms\n\n"
            f"1 1 {2 * r1!r} 1000.0 {-r1 - gap / 2!r} 0.0 0.0\n"
            f"2 1 {2 * r2!r} 1000.0 {r2 + gap / 2!r} 0.0 0.0\n\n"
            "Velocities\n\n1 0.5 0.0 0.0 0.0 0.0 0.0\n2 -0.5 0.0 0.0 0.0 0.0 0.0\n"
        )
        log = run(liggghts, tmp_path, HEAD_ON_LIGGGHTS.format(model=model))
        v1, v2 = (float(v) for v in re.findall(r"^V (\S+) (\S+)", log, re.MULTILINE)[-1])
        m1, m2 = (1000.0 * 4.0 / 3.0 * math.pi * r**3 for r in (r1, r2))
        m_star = m1 * m2 / (m1 + m2)
        xi = 0.2 * math.sqrt(m_star / mean_m_star)
        assert v2 - v1 == pytest.approx(restitution_of_the_linear_law(xi), abs=1e-3), (r1, r2)


# -- packs the engine made with the model, continued by granpack and by the peers ------------
ENGINE_MATERIALS = {
    "linear-rolling": gp.Material(
        contact_law="linear", normal_stiffness=1e4, rolling="epsd", rolling_friction=0.2
    ),
    "hertz-rolling": HERTZ_ROLLING,
}
STEPS = 500


def continued_by_granpack(pack: gp.Pack, steps: int) -> np.ndarray:
    """The pack's positions after `steps` steps of granpack's engine from its end state,
    in its box, with its material, gravity, drag and step (the contacts start afresh,
    as in the peers)."""
    sc = pack.scene
    sim = gp.Simulation(
        pack.dim,
        sc.material,
        sc.dt,
        gravity=[0.0, 0.0, -float(sc.gravity)],
        drag=sc.drag,
        box=([0.0] * pack.dim, [*sc.base, math.inf]),
        rotations=sc.rotations,
        skin_ratio=sc.skin_ratio,
        max_overlap_ratio=sc.max_overlap_ratio,
        container=sc.container,
    )
    sim.add_particles(pack.positions, pack.radii, pack.velocities, pack.spins)
    sim.step(steps)
    return sim.positions


def continued_by(program: str, folder: Path, text: str, steps: int, fmt: str) -> np.ndarray:
    """The positions after `steps` steps of `program` on the input `text`."""
    run(
        program,
        folder,
        f"variable steps index {steps}\n"
        + text
        + f"write_dump all custom state.dump id x y z modify format {fmt} sort id\n",
    )
    return np.loadtxt(folder / "state.dump", skiprows=9)[:, 1:4]


@pytest.mark.parametrize("name", list(ENGINE_MATERIALS))
def test_peers_continue_a_rolling_pack_as_granpack_does(name, lmp, liggghts, tmp_path):
    """A pack the engine made with rolling resistance, continued 500 steps by granpack and
    by LAMMPS and LIGGGHTS from the export: the peers' positions follow granpack's within
    the bounds below, and several times closer than the same inputs without the rolling
    words. The linear pack still moves (by 22 mm), so small differences grow: LAMMPS'
    linear law and rolling sds are granpack's (tests/peers/test_contact_models_lammps.py
    shows it contact by contact), yet the first steps' arms (r against r - d/2) and
    history updates differ, and the packs end 2.8e-4 m apart in LAMMPS and 5.6e-4 in
    LIGGGHTS (4.3e-3 and 4.5e-3 without rolling); Hertz's constant k_roll and LIGGGHTS'
    mean-m* damping and epsd3 are close (1.1e-4 to 2.2e-4 m, against 6e-4 to 7e-4
    without rolling; the default Hertz pack itself ends 1.7e-4 m apart in LAMMPS, 1.8e-4
    in LIGGGHTS)."""
    pack = gp.generate(small_scene(3, material=ENGINE_MATERIALS[name]).fast())
    ours = continued_by_granpack(pack, STEPS)
    assert np.abs(ours - pack.positions).max() > 1e-3  # the pack moves
    bound = {"linear-rolling": (1e-3, 1e-3), "hertz-rolling": (3e-4, 3e-4)}[name]
    for program, fmt, strip, limit in (
        (lmp, "lammps-data", r" rolling sds \S+ \S+ \S+", bound[0]),
        (liggghts, "liggghts", r" rolling_friction epsd3", bound[1]),
    ):
        export(pack, tmp_path / "pack.data", fmt)
        text = (tmp_path / "in.granpack").read_text()
        form = "float %.17g" if program == lmp else '"%d %.17g %.17g %.17g"'
        theirs = continued_by(program, tmp_path, text, STEPS, form)
        apart = np.abs(theirs - ours).max()
        assert apart < limit, (program, apart)
        without = continued_by(program, tmp_path, re.sub(strip, "", text), STEPS, form)
        assert np.abs(without - ours).max() > 2.5 * apart, program
