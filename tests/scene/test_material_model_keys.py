"""The scene's [material] table takes the contact-model keys: it writes them to TOML and
reads them back, leaves them out at their defaults, and names a bad one
``material.<key>``."""

from __future__ import annotations

import tomllib

import pytest

import granpack as gp
from granpack.errors import InvalidParameterError

ROLLING = gp.Material(
    friction=0.3,
    rolling="epsd",
    rolling_friction=0.15,
    rolling_stiffness=250.0,
    rolling_damping=0.002,
)
LINEAR = gp.Material(
    contact_law="linear",
    normal_stiffness=2e5,
    tangential_stiffness=1.5e5,
    rolling="epsd",
    rolling_friction=0.1,
)


@pytest.mark.parametrize("material", [ROLLING, LINEAR], ids=["rolling", "linear_rolling"])
def test_a_scene_with_a_contact_model_reads_back_from_its_toml(material):
    scene = gp.PackScene.preset("4.1").replace(material=material)
    text = scene.to_toml()
    table = tomllib.loads(text)["material"]
    # every key the material sets is written, none at its default
    assert table == material.to_dict()
    assert table["rolling"] == "epsd"
    back = gp.PackScene.from_toml_string(text)
    assert back == scene
    assert back.material == material


def test_a_toml_file_gives_the_linear_law_over_a_preset(tmp_path):
    path = tmp_path / "scene.toml"
    path.write_text(
        'preset = "4.1"\n[material]\ncontact_law = "linear"\nnormal_stiffness = 1e4\n'
        'rolling = "epsd"\nrolling_friction = 0.2\n'
    )
    mat = gp.PackScene.from_toml(path).material
    assert (mat.contact_law, mat.normal_stiffness) == ("linear", 1e4)
    # the default k_t, k_n 2 (1 - nu) / (2 - nu) at the preset's nu = 0.25
    assert mat.tangential_stiffness_or_default == pytest.approx(1e4 * 1.5 / 1.75, rel=1e-15)
    assert (mat.rolling, mat.rolling_friction, mat.rolling_stiffness) == ("epsd", 0.2, None)
    # the preset's other constants stay
    assert (mat.friction, mat.young) == (0.2, 1e8)


def test_a_default_material_writes_no_model_key():
    table = tomllib.loads(gp.PackScene.preset("4.1").to_toml())["material"]
    assert set(table) == {"density", "young", "poisson", "damping", "friction"}


@pytest.mark.parametrize(
    ("lines", "key", "start"),
    [
        ('rolling = "sds"', "rolling", "invalid material.rolling = 'sds'"),
        ('contact_law = "hooke"', "contact_law", "invalid material.contact_law = 'hooke'"),
        ('rolling = "epsd"', "rolling_friction", "missing material.rolling_friction"),
        ("rolling_friction = 0.1", "rolling_friction", "invalid material.rolling_friction"),
        (
            'rolling = "epsd"\nrolling_friction = -0.1',
            "rolling_friction",
            "invalid material.rolling_friction = -0.1",
        ),
        (
            'rolling = "epsd"\nrolling_friction = 0.1\nrolling_stiffness = 0.0',
            "rolling_stiffness",
            "invalid material.rolling_stiffness = 0.0",
        ),
        (
            'rolling = "epsd"\nrolling_friction = 0.1\nrolling_damping = -1.0',
            "rolling_damping",
            "invalid material.rolling_damping = -1.0",
        ),
        ('contact_law = "linear"', "normal_stiffness", "missing material.normal_stiffness"),
        ("normal_stiffness = 1e4", "normal_stiffness", "invalid material.normal_stiffness"),
        (
            'contact_law = "linear"\nnormal_stiffness = 1e4\ntangential_stiffness = -5.0',
            "tangential_stiffness",
            "invalid material.tangential_stiffness = -5.0",
        ),
        ("rolling_fricton = 0.1", "rolling_fricton", "unknown material key 'rolling_fricton'"),
    ],
)
def test_a_bad_model_key_is_named_as_the_scene_writes_it(lines, key, start):
    with pytest.raises(InvalidParameterError) as info:
        gp.PackScene.from_toml_string(f'preset = "4.1"\n[material]\n{lines}\n')
    assert info.value.parameter == f"material.{key}"
    assert str(info.value).startswith(start)
