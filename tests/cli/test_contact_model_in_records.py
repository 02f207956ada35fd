"""Every pack's record (``micro/pack_k.json``) and the ensemble's ``report.md`` name the
contact model and its constants; a default material's record names Hertz-Mindlin
without rolling."""

from __future__ import annotations

import dataclasses
import json
import warnings

import pytest
from scenes import tiny_periodic_2d

import granpack as gp
from granpack._outputs import micro_record
from granpack.analysis import MicrostructureWarning, microstructure
from granpack.report import ensemble_report

MATERIALS = {
    "default": (gp.Material(), {"contact_law": "hertz_mindlin", "rolling": "none"}),
    "rolling": (
        gp.Material(rolling="epsd", rolling_friction=0.3, rolling_stiffness=12.0),
        {
            "contact_law": "hertz_mindlin",
            "rolling": "epsd",
            "rolling_friction": 0.3,
            "rolling_stiffness": 12.0,
            "rolling_damping": 0.0,
        },
    ),
    "linear": (
        gp.Material(contact_law="linear", normal_stiffness=5e3, tangential_stiffness=4e3),
        {
            "contact_law": "linear",
            "rolling": "none",
            "normal_stiffness": 5e3,
            "tangential_stiffness": 4e3,
        },
    ),
}
LINES = {
    "default": "Contact model: Hertz-Mindlin (E = 1e+08 Pa, nu = 0.25, damping ratio 0.1, "
    "mu = 0.2), no rolling resistance.",
    "rolling": "Contact model: Hertz-Mindlin (E = 1e+08 Pa, nu = 0.25, damping ratio 0.1, "
    "mu = 0.2), rolling resistance epsd (Ai et al. 2011 type C; LAMMPS rolling sds): "
    "mu_r = 0.3, k_r = 12 N/m, gamma_r = 0 N s/m.",
    "linear": "Contact model: linear (k_n = 5000 N/m, k_t = 4000 N/m, damping ratio 0.1, "
    "mu = 0.2), no rolling resistance.",
}


@pytest.fixture(scope="module")
def tiny_pack() -> gp.Pack:
    return gp.generate(tiny_periodic_2d())


@pytest.mark.parametrize("name", MATERIALS)
def test_the_record_and_the_report_name_the_model(tiny_pack, tmp_path, name):
    material, keys = MATERIALS[name]
    pack = dataclasses.replace(tiny_pack, scene=tiny_pack.scene.replace(material=material))
    with warnings.catch_warnings():
        # a pack this small has no core window: not what is under test
        warnings.simplefilter("ignore", MicrostructureWarning)
        m = microstructure(pack)
    rec = micro_record(pack, m, 0)
    assert {k: rec[k] for k in keys} == keys
    # the keys of the other models are absent, not null
    others = {"normal_stiffness", "rolling_friction"} - set(keys)
    assert not others & set(rec)
    json.dumps(rec)  # a JSON record
    report = ensemble_report(
        tmp_path,
        scene_name="tiny",
        scene=pack.scene,
        records=[rec],
        table_files=[],
        figures=[],
        wall_time=1.0,
    )
    lines = report.read_text().splitlines()
    assert LINES[name] in lines
