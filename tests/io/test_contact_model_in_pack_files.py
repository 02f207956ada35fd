"""A pack file names its contact model through its scene: files written before the model
keys existed (granpack 0.1.0, and files of the current format with a default material)
load as Hertz-Mindlin without rolling resistance, and a file whose scene has a rolling
model and the linear law gives them back whole."""

from __future__ import annotations

import dataclasses
import zipfile
from pathlib import Path

import numpy as np
import pytest
from scenes import tiny_periodic_2d

import granpack as gp
from granpack._contact_model import model_record
from granpack.pack import FORMAT_VERSION

OLD_FILES = sorted((Path(__file__).parents[1] / "data" / "packs_0_1_0").glob("*.npz"))
DEFAULT_MODEL = {"contact_law": "hertz_mindlin", "rolling": "none"}


def _scene_text(path: Path) -> str:
    with zipfile.ZipFile(path) as z, z.open("scene.toml.npy") as f:
        return np.lib.format.read_array(f).tobytes().decode()


@pytest.fixture(scope="module")
def tiny_pack() -> gp.Pack:
    return gp.generate(tiny_periodic_2d())


def test_there_are_old_files_to_read():
    assert len(OLD_FILES) >= 3


@pytest.mark.parametrize("path", OLD_FILES, ids=lambda p: p.stem)
def test_an_old_pack_file_loads_as_hertz_mindlin_without_rolling(path):
    text = _scene_text(path)
    # the file predates the keys: its scene names none of them
    assert "contact_law" not in text and "rolling" not in text
    mat = gp.load_pack(path).scene.material
    assert (mat.contact_law, mat.rolling) == ("hertz_mindlin", "none")
    assert mat.normal_stiffness is mat.rolling_friction is None
    assert model_record(mat) == DEFAULT_MODEL


def test_a_current_file_of_a_default_material_has_no_model_key_and_loads_as_hertz(
    tiny_pack, tmp_path
):
    path = tiny_pack.save(tmp_path / "p.npz")
    text = _scene_text(path)
    assert "contact_law" not in text and "rolling" not in text
    back = gp.load_pack(path)
    assert back.scene.material == gp.Material()
    assert model_record(back.scene.material) == DEFAULT_MODEL
    assert FORMAT_VERSION >= 2


def test_a_file_keeps_the_rolling_model_and_the_linear_law(tiny_pack, tmp_path):
    mat = gp.Material(
        contact_law="linear",
        normal_stiffness=3e4,
        rolling="epsd",
        rolling_friction=0.25,
        rolling_damping=0.01,
    )
    pack = dataclasses.replace(tiny_pack, scene=tiny_pack.scene.replace(material=mat))
    back = gp.load_pack(pack.save(tmp_path / "p.npz"))
    assert back.scene.material == mat
    assert model_record(back.scene.material) == {
        "contact_law": "linear",
        "rolling": "epsd",
        "normal_stiffness": 3e4,
        # k_n 2 (1 - nu) / (2 - nu) at nu = 0.25
        "tangential_stiffness": pytest.approx(3e4 * 1.5 / 1.75, rel=1e-15),
        "rolling_friction": 0.25,
        "rolling_stiffness": None,
        "rolling_damping": 0.01,
    }
