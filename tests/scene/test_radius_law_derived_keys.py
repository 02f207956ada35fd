"""A radius key that the law derives (r_mean and r_std of the uniform, discrete and sieve
laws; r_min and r_max of the discrete and sieve laws; r_std, r_min, r_max of the constant
one) is refused by name when given with another value, instead of being replaced
silently; its default and the derived value itself (a scene written and read back, or
copied) are taken."""

from __future__ import annotations

import pytest

import granpack as gp
from granpack.scene import _DERIVED_KEYS, RADIUS_LAWS

LAWS = {
    "constant": {"r_mean": 0.01},
    "uniform": {"r_min": 0.008, "r_max": 0.012},
    "discrete": {"radii": (0.008, 0.012), "fractions": (0.5, 0.5)},
    "sieve": {"sieve_sizes": (0.016, 0.02, 0.024), "sieve_passing": (0.0, 0.5, 1.0)},
    "gaussian": {"r_mean": 0.01, "r_std": 0.001},
    "lognormal": {"r_mean": 0.01, "r_std": 0.001},
}


def _scene(law: str, **extra) -> gp.PackScene:
    return gp.PackScene(radius_law=law, **LAWS[law], dt=5e-5, **extra)


def test_every_law_is_listed():
    assert set(_DERIVED_KEYS) == set(RADIUS_LAWS) == set(LAWS)


@pytest.mark.parametrize(
    ("law", "key"), [(law, key) for law, keys in _DERIVED_KEYS.items() for key in keys]
)
def test_a_derived_key_given_another_value_is_refused_by_name(law, key):
    derived = getattr(_scene(law), key)
    wrong = 0.5 if key != "r_std" else derived + 0.003
    with pytest.raises(gp.InvalidParameterError) as err:
        _scene(law, **{key: wrong})
    assert err.value.parameter == key
    assert f"radius_law = {law!r} derives {key}" in str(err.value)
    # the derived value itself is taken, and gives the same scene
    assert _scene(law, **{key: derived}) == _scene(law)


def test_the_user_s_r_mean_of_a_uniform_law_is_not_replaced_silently():
    with pytest.raises(gp.InvalidParameterError, match="r_mean") as err:
        gp.PackScene(radius_law="uniform", r_min=0.008, r_max=0.012, r_mean=0.5)
    assert err.value.parameter == "r_mean"
    with pytest.raises(gp.InvalidParameterError, match="r_mean"):
        gp.PackScene.from_toml_string(
            'radius_law = "uniform"\nr_min = 0.008\nr_max = 0.012\nr_mean = 0.5\n'
        )


@pytest.mark.parametrize("law", list(LAWS))
def test_written_read_back_and_copied_scenes_keep_their_derived_values(law):
    sc = _scene(law)
    assert gp.PackScene.from_toml_string(sc.to_toml()) == sc
    assert gp.PackScene.from_dict(sc.to_dict()) == sc
    assert sc.replace(seed=7).r_mean == sc.r_mean
    assert sc.replace(height=0.3).r_mean == sc.r_mean


def test_replace_derives_again_what_the_new_inputs_give():
    sc = _scene("uniform")
    wider = sc.replace(r_max=0.016)
    assert wider.r_mean == pytest.approx(0.012, rel=1e-12)
    assert wider.r_std == pytest.approx(0.008 / 12**0.5, rel=1e-12)
    # a Gaussian scene made constant: its r_std and truncation are the constant law's
    const = gp.PackScene.preset("4.2").replace(radius_law="constant")
    assert (const.r_std, const.r_min, const.r_max) == (0.0, 0.01, 0.01)


def test_a_preset_s_radius_gives_way_to_the_file_s_own_law():
    t = gp.PackScene.from_toml_string(
        'preset = "4.3"\nradius_law = "uniform"\nr_min = 0.01\nr_max = 0.03\n'
    )
    assert t.r_mean == pytest.approx(0.02, rel=1e-12) and t.r_std > 0.0
    with pytest.raises(gp.InvalidParameterError, match="r_mean"):
        gp.PackScene.from_toml_string(
            'preset = "4.3"\nradius_law = "uniform"\nr_min = 0.01\nr_max = 0.03\nr_mean = 0.5\n'
        )
