"""The element tests' settings as the scene checks them (`granpack.element_settings`)
are the functions' own: the same keys, in the same order, with the same defaults."""

from __future__ import annotations

import inspect

import pytest

import granpack as gp
from granpack.element_settings import PATH_DEFAULTS, TRIAXIAL_DEFAULTS, keys_of


@pytest.mark.parametrize(
    ("function", "defaults", "test"),
    [
        (gp.triaxial, TRIAXIAL_DEFAULTS, "triaxial"),
        (gp.oedometer, PATH_DEFAULTS, "oedometer"),
        (gp.isotropic_compression, PATH_DEFAULTS, "isotropic"),
    ],
)
def test_the_scene_tables_keys_and_defaults_are_the_functions(function, defaults, test):
    params = list(inspect.signature(function).parameters.values())[1:]
    assert [p.name for p in params] == list(defaults) == list(keys_of(test))
    for p in params:
        if p.default is inspect.Parameter.empty:
            assert defaults[p.name] is None, p.name  # stresses: required
        else:
            assert p.default == defaults[p.name], p.name
