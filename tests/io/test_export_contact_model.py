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
    m = gp.Material(
        contact_law="linear", normal_stiffness=3e4, rolling="epsd", rolling_friction=0.1
    )
    text = exported(with_material(pack, m), tmp_path, "lammps-data")["in.granpack"]
    lid = lammps_law(text, "fix             lid")
    assert after(lid, "hooke", 1) == [3e4]
    # linear law: k_roll = 2.25 mu_r^2 k_n exactly
    assert after(lid, "sds", 3) == pytest.approx([2.25 * 0.01 * 3e4, 0.0, 0.1], rel=1e-15)
    assert "hertz" not in text  # no Hertz wall notes for a linear pack
    # the servo's gain is the inverse of the lid contacts' stiffness, k_n each
    gain = float(re.search(r"lid_gain equal (\S+)", text).group(1))
    lid_at = float(re.search(r"lid all wall/gran granular .* yplane NULL (\S+)", text).group(1))
    top = pack.positions[:, -1] + pack.radii - lid_at
    assert gain == pytest.approx(1.0 / (3e4 * max(int((top > 0).sum()), 1)), rel=1e-5)


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
