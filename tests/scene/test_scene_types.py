"""A scene key of the wrong type is an InvalidParameterError naming that key, whatever the
other keys are (a periodic cell, a cylinder, another radius law) and however the scene is
given (PackScene, replace, a TOML document, or the engine reading a scene by attribute),
never a TypeError from a check that combines keys."""

from __future__ import annotations

import dataclasses
import datetime
import types

import pytest
import tomli_w
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import granpack as gp
from granpack import _core
from granpack.scene import _KEY_TYPES

KEYS = [f.name for f in dataclasses.fields(gp.PackScene)]

#: Scenes that differ in what the checks combine: the box, a periodic cell (its period
#: depends on skin_ratio and r_max), a cylinder (its radius on base), a law with lists.
CONTEXTS = {
    "box": {},
    "periodic": {"container": "periodic"},
    "cylinder": {"dim": 3, "base": (0.4, 0.4), "container": "cylinder", "r_mean": 0.02},
    "discrete": {"radius_law": "discrete", "radii": (0.01, 0.012), "fractions": (0.5, 0.5)},
    "sieve": {
        "radius_law": "sieve",
        "sieve_sizes": (0.016, 0.02, 0.024),
        "sieve_passing": (0.0, 0.5, 1.0),
    },
    "trim": {"trim": True},
}

_text = st.text(max_size=5)
_real_text = st.sampled_from(["0.2", "1e-4", "0.5", "nan", "2"])
_containers = st.lists(st.integers(-2, 2), max_size=2) | st.dictionaries(_text, st.integers())


def wrong_values(kind: str) -> st.SearchStrategy:
    """Values of a type that a key of `kind` does not take."""
    if kind in ("real", "real?"):
        return st.one_of(
            _real_text, _text, st.booleans(), _containers, st.complex_numbers(max_magnitude=1)
        ) | (st.none() if kind == "real" else st.nothing())
    if kind == "int":
        return st.one_of(
            st.floats(allow_nan=True), _real_text, st.booleans(), _containers, st.none()
        )
    if kind == "bool":
        return st.one_of(st.integers(0, 1), st.floats(), _text, st.none(), _containers)
    if kind == "text":
        return st.one_of(st.integers(), st.floats(), st.booleans(), st.none(), _containers)
    if kind in ("reals", "reals?"):
        bad_item = st.one_of(_real_text, st.none(), st.booleans(), st.lists(st.floats(0, 1)))
        return st.one_of(
            _real_text,
            st.floats(0.01, 1.0),
            st.integers(1, 3),
            st.dictionaries(_text, st.floats(0, 1), min_size=1),
            st.lists(bad_item, min_size=1, max_size=3),
            st.lists(st.floats(0.01, 1), max_size=1).map(lambda a: [*a, "0.1"]),
        ) | (st.none() if kind == "reals" else st.nothing())
    if kind in ("consolidate?", "element?"):
        return st.one_of(st.floats(), _text, st.lists(st.floats(), max_size=2), st.booleans())
    assert kind == "material"
    return st.one_of(st.floats(), _text, st.lists(st.floats(), max_size=2), st.booleans())


def names_the_key(err: gp.InvalidParameterError, key: str) -> bool:
    p = err.parameter or ""
    return p == key or p.startswith(key + ".")


def test_every_scene_key_has_a_type():
    assert sorted(_KEY_TYPES) == sorted(KEYS)


@settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    key=st.sampled_from(KEYS),
    context=st.sampled_from(sorted(CONTEXTS)),
    data=st.data(),
)
def test_a_key_of_the_wrong_type_is_named(key, context, data):
    value = data.draw(wrong_values(_KEY_TYPES[key]), label="value")
    kwargs = {**CONTEXTS[context], key: value}
    with pytest.raises(gp.InvalidParameterError) as info:
        gp.PackScene(**kwargs)
    assert names_the_key(info.value, key), (key, value, str(info.value))
    assert key in str(info.value)


@pytest.mark.parametrize("context", sorted(CONTEXTS))
def test_the_reported_case_and_its_kin(context):
    # skin_ratio as text in a periodic cell used to fail inside the period check
    for key in ("skin_ratio", "r_mean", "r_max", "cylinder_radius", "base", "dt", "height"):
        value = "0.2" if key != "base" else ["1.0", "1.0"]
        with pytest.raises(gp.InvalidParameterError) as info:
            gp.PackScene(**{**CONTEXTS[context], key: value})
        assert names_the_key(info.value, key)


def test_replace_names_the_key_too():
    scene = gp.PackScene.preset("4.3").replace(container="periodic")
    for key, value in (("skin_ratio", "0.2"), ("seed", 1.5), ("material", "steel")):
        with pytest.raises(gp.InvalidParameterError) as info:
            scene.replace(**{key: value})
        assert names_the_key(info.value, key)


#: Values a TOML document can hold, of the wrong type for a key of each kind.
TOML_WRONG = {
    "real": ["0.2", True, [1.0], {"a": 1.0}, datetime.date(2026, 1, 1)],
    "int": [1.5, "3", True, [1], {"a": 1}],
    "bool": [1, "true", 0.0, [True]],
    "text": [1, 1.5, True, ["box"], {"a": "b"}],
    "reals": ["1.0", 1.0, [True], ["0.1"], {"a": 1.0}],
    "material": [1.0, "steel", [1.0], {"young": "1e7"}],
    "consolidate": [1e5, "1e5", [1e5], {"stress": "1e5"}, {"stress": 1e5, "hold": 1.5}],
    "element": [1e5, "1e5", [1e5], {"stresses": "1e5"}, {"checks": 1.5}],
}


@pytest.mark.parametrize("key", KEYS)
def test_a_scene_file_with_a_wrong_type_names_the_key(key):
    kind = _KEY_TYPES[key].rstrip("?")
    for value in TOML_WRONG[kind]:
        for context in ({}, {"container": "periodic"}):
            text = tomli_w.dumps({**context, key: value})
            with pytest.raises(gp.InvalidParameterError) as info:
                gp.PackScene.from_toml_string(text)
            assert names_the_key(info.value, key), (key, value, str(info.value))


def _fields(scene: gp.PackScene) -> dict:
    return {f.name: getattr(scene, f.name) for f in dataclasses.fields(scene)}


#: Scene keys the engine reads by attribute (LayerPacker, resolve_scene); the Python
#: layer runs the trim, the settling at rest, the consolidation stage, the density
#: target's search and the element tests.
PYTHON_KEYS = ("trim", "rest_tol", "consolidate", "target_phi", "target_void_ratio")
PYTHON_KEYS += ("target_relative_density", "density_tol", "density_method")
PYTHON_KEYS += ("triaxial", "oedometer", "isotropic")
ENGINE_KEYS = [k for k in KEYS if k not in PYTHON_KEYS]


@pytest.mark.parametrize("key", ENGINE_KEYS)
def test_the_engine_names_a_key_of_the_wrong_type(key):
    """`_core.LayerPacker` reads any object's attributes: a wrong type there is the same
    typed error, not the TypeError of the conversion."""
    fields = _fields(gp.PackScene.preset("4.1"))
    bad = "0.2" if _KEY_TYPES[key] != "text" else 3
    if key == "material":
        bad = types.SimpleNamespace(**{**fields["material"].to_dict(), "young": "1e7"})
    obj = types.SimpleNamespace(**{**fields, key: bad})
    for entry in (_core.resolve_scene, _core.LayerPacker):
        with pytest.raises(gp.InvalidParameterError) as info:
            entry(obj)
        assert names_the_key(info.value, key), (key, str(info.value))


def test_a_preset_given_as_a_number_is_refused_saying_it_is_a_string():
    for text in ("preset = 4.1", "preset = 4.3", "preset = 4"):
        with pytest.raises(gp.InvalidParameterError, match=r"a preset name is a string") as e:
            gp.PackScene.from_toml_string(text)
        assert e.value.parameter == "preset"
    with pytest.raises(gp.InvalidParameterError, match=r'preset = "4.3"'):
        gp.PackScene.from_toml_string("preset = 4.3")
    with pytest.raises(gp.InvalidParameterError, match="a preset name is a string"):
        gp.PackScene.preset(4.1)  # type: ignore[arg-type]
    with pytest.raises(gp.InvalidParameterError, match="unknown preset '4.9'") as e:
        gp.PackScene.from_toml_string('preset = "4.9"')
    assert e.value.parameter == "preset"
    assert gp.PackScene.from_toml_string('preset = "4.3"') == gp.PackScene.preset("4.3")


def test_an_integer_beyond_any_float_is_refused_by_name():
    with pytest.raises(gp.InvalidParameterError, match="must be finite") as info:
        gp.PackScene(height=10**400)
    assert info.value.parameter == "height"
