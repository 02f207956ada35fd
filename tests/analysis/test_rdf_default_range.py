"""g(r)'s default range: where the core window is too small for r_max to reach the
contact distance (g would be 0 in every bin), rdf refuses by name instead of returning
zeros; wherever it answers, its range reaches the first shell."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

import granpack as gp


def _cubic(n: int, k: int) -> np.ndarray:
    """Touching spheres of radius 0.5 on a simple cubic lattice, n x n x k."""
    return np.array(list(itertools.product(range(n), range(n), range(k))), float) + 0.5


@pytest.mark.parametrize("margin", [0.6, 0.9])
def test_a_window_thinner_than_two_contacts_is_refused_naming_margin(margin):
    x = _cubic(8, 3)  # 3 m high: the window is 3 - 2 margin high
    with pytest.raises(gp.InvalidParameterError) as err:
        gp.rdf(x, np.full(len(x), 0.5), margin=margin)
    assert err.value.parameter == "margin"
    assert "contact distance 2 r_min = 1 m" in str(err.value)


@pytest.mark.parametrize("margin", [0.0, 0.2, 0.4, 0.6, 0.9])
@pytest.mark.parametrize("layers", [3, 4, 6])
def test_the_default_range_reaches_the_first_shell_or_is_refused(layers, margin):
    x = _cubic(6, layers)
    r = np.full(len(x), 0.5)
    try:
        rr, g = gp.rdf(x, r, margin=margin)
    except gp.InvalidParameterError as exc:
        assert exc.parameter == "margin"
        # refused only where half the window's height is below the contact distance
        assert (layers - 2 * margin) / 2 < 1.0
        return
    assert (layers - 2 * margin) / 2 >= 1.0
    assert rr[-1] >= 1.0 - (rr[1] - rr[0])  # the last bin reaches the contact
    assert np.max(g) > 0.0


def test_an_explicit_r_max_below_the_contact_is_the_user_s_choice():
    x = _cubic(6, 6)
    rr, g = gp.rdf(x, np.full(len(x), 0.5), r_max=0.8, margin=0.0)
    assert rr[-1] < 0.8 and np.all(g == 0.0)  # no centres closer than 1 m
