"""Edge cases of the analysis that once gave a silent NaN, a crash or two answers: g(r) at
a vanishing r_max, the grading of radii near the ends of the float range, Z_m of a pack
whose every particle is a rattler (one convention in microstructure and the profiles),
and the rdf default the docstring states."""

from __future__ import annotations

import math

import numpy as np
import pytest

import granpack as gp


def _cube(n: int = 4, spacing: float = 2.0, r: float = 1.0):
    g = np.stack(np.meshgrid(*[np.arange(n)] * 3, indexing="ij"), -1).reshape(-1, 3)
    return g * spacing + r, np.full(len(g), r)


# -- rdf --------------------------------------------------------------------------------
@pytest.mark.parametrize("r_max", [1e-300, 1e-30, 0.009, 0.0])
def test_rdf_refuses_an_r_max_below_a_hundredth_of_the_smallest_radius(r_max):
    x, r = _cube()
    with pytest.raises(gp.InvalidParameterError, match=r"r_max.*must lie in \[0\.01, ") as info:
        gp.rdf(x, r, r_max=r_max, margin=0.0)
    assert info.value.parameter == "r_max"


@pytest.mark.parametrize("scale", [1e-95, 1.0, 1e95])
@pytest.mark.parametrize("bins", [1, 100, 100_000])
def test_rdf_is_finite_and_scale_free_from_the_smallest_r_max(scale, bins):
    x, r = _cube()
    _, g_floor = gp.rdf(x * scale, r * scale, r_max=0.01 * scale, bins=bins, margin=0.0)
    assert np.all(np.isfinite(g_floor)) and np.all(g_floor == 0.0)
    rs, g = gp.rdf(x * scale, r * scale, r_max=2.3 * scale, bins=bins, margin=0.0)
    _, g1 = gp.rdf(x, r, r_max=2.3, bins=bins, margin=0.0)
    assert np.all(np.isfinite(g))
    np.testing.assert_allclose(g, g1, rtol=1e-9)
    assert rs[-1] == pytest.approx(2.3 * scale * (1 - 0.5 / bins))


def test_rdf_default_r_max_is_three_mean_diameters():
    x, r = _cube(6)
    rs, _ = gp.rdf(x, r, bins=10, margin=0.0)
    # bin centres of 10 equal bins up to r_max = 3 mean diameters = 6 m
    assert rs[-1] == pytest.approx(6.0 * 0.95)
    assert "3 mean diameters" in gp.rdf.__doc__


# -- grading ----------------------------------------------------------------------------
@pytest.mark.parametrize("scale", [1e-300, 1e-200, 1.0, 1e200, 1e300])
def test_realised_grading_is_scale_free(scale):
    r = np.random.default_rng(3).uniform(1.0, 3.0, 400)
    g1 = gp.realised_grading(r)
    g = gp.realised_grading(r * scale)
    for key, v in g.to_dict().items():
        if key.startswith(("cu", "cc")):
            assert v == pytest.approx(getattr(g1, key), rel=1e-12), key
        else:
            assert v == pytest.approx(getattr(g1, key) * scale, rel=1e-12), key


def test_realised_grading_refuses_radii_whose_diameter_overflows():
    with pytest.raises(gp.InvalidParameterError, match=r"0 < r <= 8\.98") as info:
        gp.realised_grading(np.array([1.0, 1e308]))
    assert info.value.parameter == "radii"


# -- Z_m where every particle is a rattler ----------------------------------------------
@pytest.mark.filterwarnings("ignore::granpack.analysis.MicrostructureWarning")
def test_z_mech_of_a_pack_without_a_mechanical_network_is_nan_in_both_paths():
    # three pairs of touching spheres far apart: every particle has one contact
    x = np.array([[0.0, 0, 1], [1.9, 0, 1], [10, 0, 1], [11.9, 0, 1], [20, 0, 1], [21.9, 0, 1]])
    r = np.ones(6)
    box = ([-1.0, -1.0, 0.0], [23.0, 1.0, 10.0])
    m = gp.microstructure(positions=x, radii=r, box=box, core_margin=0.0)
    assert m.z == pytest.approx(1.0)
    assert math.isnan(m.z_mech) and math.isnan(m.z_mech_iterative)
    assert math.isnan(m.z_mech_frictional)
    assert m.n_rattlers_iterative == 6
    df = gp.profiles(positions=x, radii=r, box=box, slices=1)
    assert df["n_particles"][0] == 6 and df["Z"][0] == pytest.approx(1.0)
    assert math.isnan(df["Z_m"][0])
    row = m.to_dict()
    assert math.isnan(row["z_mech"]) and math.isnan(row["z_mech_iterative"])


def test_z_mech_of_a_jammed_slice_agrees_between_the_paths():
    # one slice holding the whole pack: profiles' Z_m is the pack's
    x, r = _cube(4, spacing=1.98)
    m = gp.microstructure(positions=x, radii=r, core_margin=0.0)
    df = gp.profiles(positions=x, radii=r, slices=1)
    assert df["Z_m"][0] == pytest.approx(m.z_mech, rel=1e-12)


def test_rattler_docs_say_how_the_count_differs_from_lammps():
    from granpack.analysis.coordination import rattlers_iterative

    doc = rattlers_iterative.__doc__
    assert "LAMMPS" in doc and "wall/gran" in doc and "factor of 2" in doc


def test_rattlers_without_the_wall_rows_give_the_pair_only_count():
    # four spheres on the floor, each touching the three others: D + 1 = 4 contacts each
    # with the floor, three without it
    from granpack.analysis.coordination import rattlers_iterative

    i = np.array([0, 0, 0, 1, 1, 2, 0, 1, 2, 3])
    j = np.array([1, 2, 3, 2, 3, 3, -1, -1, -1, -1])
    walls, left = rattlers_iterative(i, j, 4, 3)
    pairs, _ = rattlers_iterative(i[j >= 0], j[j >= 0], 4, 3)
    assert not walls.any() and left == 6
    assert pairs.all()


@pytest.mark.parametrize("lo_y", [-1.0, 0.0])
def test_a_box_far_too_small_for_its_particles_is_refused_not_phi_inf(lo_y):
    box = (np.array([0.0, lo_y]), np.array([1e-320, 1e-320]))
    with pytest.raises(gp.InvalidParameterError, match="phi = inf") as info:
        gp.microstructure(positions=np.array([[0.0, 0.0]]), radii=np.array([0.1]), box=box)
    assert info.value.parameter == "box"
