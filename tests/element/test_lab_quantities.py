"""The lab quantities of an element test's table, on synthetic tables made from closed
forms: a hyperbolic q(eps_a) gives its E50, a Mohr-Coulomb path its friction angle, a
linear volume change its dilatancy angle, an e-log10(sigma) line its Cc and Cs."""

from __future__ import annotations

import json
import math

import numpy as np
import polars as pl
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from granpack.element.lab import (
    CS_SHARE,
    DILATANCY_WINDOW,
    PEAK_MARGIN,
    compression_report,
    eps_v_at,
    triaxial_report,
)
from granpack.errors import InvalidParameterError


def triaxial_table(eps_a, s1, s3, eps_v=None, dim=3) -> pl.DataFrame:
    """A triaxial table with the columns of the element-test contract, p and q from the
    wall stresses."""
    eps_a = np.asarray(eps_a, dtype=float)
    s1 = np.broadcast_to(np.asarray(s1, dtype=float), eps_a.shape)
    s3 = np.broadcast_to(np.asarray(s3, dtype=float), eps_a.shape)
    eps_v = np.zeros_like(eps_a) if eps_v is None else np.asarray(eps_v, dtype=float)
    p = (s1 + 2 * s3) / 3 if dim == 3 else (s1 + s3) / 2
    q = s1 - s3
    return pl.DataFrame(
        {
            "step": np.arange(eps_a.size) * 100,
            "eps_a": eps_a,
            "eps_v": eps_v,
            "sigma_1": s1,
            "sigma_3": s3,
            "p": p,
            "q": q,
            "eta": q / p,
        }
    )


def n_phi(phi_deg: float) -> float:
    """s1/s3 on the Mohr-Coulomb line through the origin: (1 + sin phi)/(1 - sin phi)."""
    s = math.sin(math.radians(phi_deg))
    return (1 + s) / (1 - s)


def assert_json_safe(report: dict) -> None:
    json.dumps(report, allow_nan=False)


# --- E50 ---------------------------------------------------------------------------------


@pytest.mark.parametrize("q0, eps0", [(0.0, 0.0), (2e4, 0.003)])
def test_e50_of_a_hyperbola_is_its_closed_form(q0, eps0):
    # q - q0 = x / (1/E0 + x/q_ult), x = eps_a - eps0: half of dq_max = q_ult x_m/(...)
    # is reached at x = (h/E0) / (1 - h/q_ult), so E50 = h / x = E0 (1 - h/q_ult)
    e0, q_ult, s3 = 5e7, 4e5, 1e5
    x = np.linspace(0.0, 0.2, 4001)
    dq = x / (1 / e0 + x / q_ult)
    table = triaxial_table(x + eps0, s3 + q0 + dq, s3)
    h = 0.5 * dq[-1]
    rep = triaxial_report(table, 3)
    assert rep["E_50"] == pytest.approx(e0 * (1 - h / q_ult), rel=1e-4)
    assert rep["eps_a_50"] == pytest.approx(eps0 + (h / e0) / (1 - h / q_ult), rel=1e-4)
    assert_json_safe(rep)


def test_e50_of_a_straight_line_is_its_slope_exactly():
    # linear interpolation is exact on a line, between rows too
    eps = np.array([0.0, 0.004, 0.011, 0.02, 0.05])
    rep = triaxial_report(triaxial_table(eps, 1e5 + 3e7 * eps, 1e5), 3)
    assert rep["E_50"] == pytest.approx(3e7, rel=1e-12)
    assert rep["eps_a_50"] == pytest.approx(0.025, rel=1e-12)


def test_e50_takes_half_the_peak_deviator_not_the_last():
    # stiff to 0.2 %, softer to the peak 3e5 at 2.4 %, then softening to 1e5: half the
    # peak, 1.5e5, is reached at 0.9 % (E50 = 1.5e5 / 0.009); half the last q would be
    # reached at 0.125 %, on the stiff part
    eps = np.linspace(0.0, 0.1, 1001)
    q = np.interp(eps, [0.0, 0.002, 0.024, 0.1], [0.0, 8e4, 3e5, 1e5])
    rep = triaxial_report(triaxial_table(eps, 1e5 + q, 1e5), 3)
    assert rep["E_50"] == pytest.approx(1.5e5 / 0.009, rel=1e-9)
    assert rep["eps_a_50"] == pytest.approx(0.009, rel=1e-9)


def test_e50_is_none_where_q_never_rises():
    eps = np.linspace(0, 0.1, 11)
    rep = triaxial_report(triaxial_table(eps, 2e5 - 1e5 * eps, 1e5), 3)
    assert rep["E_50"] is None and rep["eps_a_50"] is None
    assert_json_safe(rep)


# --- friction angles ----------------------------------------------------------------------


@pytest.mark.parametrize("dim", [2, 3])
def test_a_mohr_coulomb_path_gives_its_friction_angles(dim):
    # s1/s3 rises to N(40 deg) at eps_a = 3 % and falls to N(30 deg), held from 15 % on
    phi, phi_cs, s3 = 40.0, 30.0, 1e5
    eps = np.linspace(0.0, 0.25, 251)
    ratio = np.interp(eps, [0.0, 0.03, 0.15, 0.25], [1.0, n_phi(phi), n_phi(phi_cs), n_phi(phi_cs)])
    rep = triaxial_report(triaxial_table(eps, s3 * ratio, s3, dim=dim), dim)
    assert rep["phi_peak"] == pytest.approx(phi, abs=1e-12)
    assert rep["eps_a_peak"] == pytest.approx(0.03, abs=1e-15)
    assert rep["phi_cs"] == pytest.approx(phi_cs, abs=1e-12)
    # eta of a friction angle: 3D (axisymmetric) 6 sin / (3 - sin); 2D (biaxial) 2 sin
    sp, sc = math.sin(math.radians(phi)), math.sin(math.radians(phi_cs))
    eta = (lambda s: 6 * s / (3 - s)) if dim == 3 else (lambda s: 2 * s)
    assert rep["eta_peak"] == pytest.approx(eta(sp), rel=1e-12)
    assert rep["eta_cs"] == pytest.approx(eta(sc), rel=1e-12)
    assert rep["q_peak"] == pytest.approx(s3 * (n_phi(phi) - 1), rel=1e-12)
    assert rep["q_cs"] == pytest.approx(s3 * (n_phi(phi_cs) - 1), rel=1e-12)
    assert rep["peak"] is True
    assert_json_safe(rep)


def test_the_critical_state_window_takes_the_last_fifth_of_the_axial_strain():
    # rows at eps_a = i/64 (exact in binary): the window starts at 0.8 * 40/64 = 32/64, so
    # rows 32..40 (the boundary row included) are in it, row 31 is not
    eps = np.arange(41) / 64
    sin_phi = np.full(41, 0.2)
    sin_phi[31] = 0.9  # the peak, just outside the window
    sin_phi[32:] = np.linspace(0.4, 0.6, 9)  # inside: their mean is 0.5
    s3 = 1e5
    rep = triaxial_report(triaxial_table(eps, s3 * (1 + sin_phi) / (1 - sin_phi), s3), 3)
    assert CS_SHARE == 0.2
    assert rep["cs_rows"] == 9
    assert rep["phi_cs"] == pytest.approx(math.degrees(math.asin(0.5)), abs=1e-12)
    s1 = s3 * (1 + sin_phi[32:]) / (1 - sin_phi[32:])
    assert rep["eta_cs"] == pytest.approx(np.mean((s1 - s3) / ((s1 + 2 * s3) / 3)), rel=1e-12)
    assert rep["eps_a_peak"] == 31 / 64
    # the window is a share of the path's own range: shifted strains pick the same rows
    shifted = triaxial_report(
        triaxial_table(eps + 0.125, s3 * (1 + sin_phi) / (1 - sin_phi), s3), 3
    )
    assert shifted["cs_rows"] == 9
    assert shifted["phi_cs"] == pytest.approx(rep["phi_cs"], abs=1e-12)


@pytest.mark.parametrize("excess, marked", [(0.099, False), (0.101, True)])
def test_a_marked_peak_exceeds_the_critical_state_deviator_by_the_margin(excess, marked):
    eps = np.linspace(0, 0.2, 201)
    q_cs = 2e5
    q = np.interp(eps, [0, 0.02, 0.1, 0.2], [0, q_cs * (1 + excess), q_cs, q_cs])
    rep = triaxial_report(triaxial_table(eps, 1e5 + q, 1e5), 3)
    assert PEAK_MARGIN == 0.10
    assert rep["q_cs"] == pytest.approx(q_cs, rel=1e-12)
    assert rep["peak"] is marked


# --- dilatancy ----------------------------------------------------------------------------


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("rate", [0.6, 0.0, -0.4])
def test_a_linear_volume_change_gives_its_dilatancy_angle(dim, rate):
    # eps_v = -rate eps_a: sin psi = -d eps_v / (2 d eps_a - d eps_v) = rate / (2 + rate)
    eps = np.linspace(0.0, 0.1, 301)
    rep = triaxial_report(triaxial_table(eps, 3e5, 1e5, eps_v=-rate * eps, dim=dim), dim)
    assert rep["psi_max"] == pytest.approx(math.degrees(math.asin(rate / (2 + rate))), abs=1e-9)
    assert rep["dilatancy_max"] == pytest.approx(rate, abs=1e-9)


def test_the_largest_dilatancy_lies_where_the_sample_dilates_fastest():
    # contracts (slope +0.3) to 2 %, then dilates at 0.5 to 10 %, then at 0.2
    eps = np.linspace(0.0, 0.2, 801)
    ev = np.interp(eps, [0, 0.02, 0.1, 0.2], [0.0, 0.006, -0.034, -0.054])
    rep = triaxial_report(triaxial_table(eps, 3e5, 1e5, eps_v=ev), 3)
    assert DILATANCY_WINDOW == 0.02
    assert rep["psi_max"] == pytest.approx(math.degrees(math.asin(0.5 / 2.5)), abs=1e-9)
    # a centre whose whole window (+-1 %) lies in the fast dilation, 2 % to 10 %
    assert 0.03 - 1e-9 <= rep["eps_a_psi_max"] <= 0.09 + 1e-9


def test_a_one_row_spike_does_not_make_a_spurious_dilatancy_maximum():
    # rows every 0.01 % axial strain; a jump of 1e-4 in eps_v at one row would give
    # row-to-row -d eps_v / d eps_a = 1 (psi 19.5 deg); over the 2 % window it moves the
    # rate by at most 1e-4 / 0.02 = 0.005
    eps = np.linspace(0.0, 0.1, 1001)
    ev = -0.2 * eps
    ev[500] -= 1e-4
    rep = triaxial_report(triaxial_table(eps, 3e5, 1e5, eps_v=ev), 3)
    assert rep["dilatancy_max"] == pytest.approx(0.2, abs=0.0051)
    assert rep["psi_max"] == pytest.approx(math.degrees(math.asin(0.2 / 2.2)), abs=0.15)
    raw = np.max(-np.diff(ev) / np.diff(eps))
    assert raw > 0.9  # the spike the window smooths out


def test_a_path_shorter_than_the_dilatancy_window_has_no_dilatancy_angle():
    eps = np.linspace(0.0, 0.015, 16)
    rep = triaxial_report(triaxial_table(eps, 3e5, 1e5, eps_v=-0.1 * eps), 3)
    assert rep["psi_max"] is None
    assert rep["eps_a_psi_max"] is None and rep["dilatancy_max"] is None
    assert_json_safe(rep)
    # a narrower window measures it
    narrow = triaxial_report(
        triaxial_table(eps, 3e5, 1e5, eps_v=-0.1 * eps), 3, dilatancy_window=0.005
    )
    assert narrow["dilatancy_max"] == pytest.approx(0.1, abs=1e-12)


def test_eps_v_at_an_axial_strain_is_interpolated_between_rows():
    eps = np.array([0.0, 0.05, 0.12, 0.2])
    ev = np.array([0.0, 0.01, -0.004, -0.02])
    table = triaxial_table(eps, 3e5, 1e5, eps_v=ev)
    assert eps_v_at(table, 0.10) == pytest.approx(0.01 + (0.05 / 0.07) * (-0.014), abs=1e-15)
    assert eps_v_at(table, 0.05) == 0.01
    assert eps_v_at(table, 0.2) == -0.02
    assert eps_v_at(table, 0.25) is None  # the test stopped before 25 %
    assert eps_v_at(table, -0.01) is None


# --- Cc, Cs, K0 ---------------------------------------------------------------------------


def compression_table(stress, e, *, k0=None, sigma_3=None, isotropic=False) -> pl.DataFrame:
    stress = np.asarray(stress, dtype=float)
    cols = {"target": stress, "e": np.asarray(e, dtype=float)}
    if isotropic:
        cols |= {"sigma_1": stress, "sigma_3": stress, "p": stress}
    else:
        s3 = 0.5 * stress if sigma_3 is None else np.asarray(sigma_3, dtype=float)
        cols |= {"sigma_1": stress, "sigma_3": s3, "p": (stress + 2 * s3) / 3}
        if k0 is not None:
            cols["k0"] = np.asarray(k0, dtype=float)
    return pl.DataFrame(cols)


CC, CS = 0.21, 0.035
LOAD = np.array([5e4, 1e5, 2e5, 4e5, 8e5, 1.6e6])
UNLOAD = np.array([8e5, 4e5, 1e5])


def e_log_line():
    # the first row lies off the virgin line (the sample as consolidated: recompression)
    e_load = 0.80 - CC * np.log10(LOAD / 1e5)
    e_load[0] = e_load[1] + 0.01
    e_top = e_load[-1]
    e_unload = e_top + CS * np.log10(LOAD[-1] / UNLOAD)
    return np.r_[LOAD, UNLOAD], np.r_[e_load, e_unload]


@pytest.mark.parametrize("isotropic", [False, True])
def test_an_e_log_stress_line_gives_its_cc_and_cs(isotropic):
    s, e = e_log_line()
    k0 = np.linspace(0.45, 0.7, s.size)
    table = compression_table(s, e, k0=None if isotropic else k0, isotropic=isotropic)
    rep = compression_report(table)
    assert rep["test"] == ("isotropic" if isotropic else "oedometer")
    assert rep["stress"] == ("p" if isotropic else "sigma_1")
    assert rep["Cc"] == pytest.approx(CC, rel=1e-12)
    assert rep["Cs"] == pytest.approx(CS, rel=1e-12)
    assert rep["lambda_ln"] == pytest.approx(CC / math.log(10), rel=1e-12)
    assert rep["kappa_ln"] == pytest.approx(CS / math.log(10), rel=1e-12)
    assert rep["loading_rows"] == [0, 1, 2, 3, 4, 5]
    assert rep["virgin_rows"] == [1, 2, 3, 4, 5]
    assert rep["unloading_rows"] == [5, 6, 7, 8]
    assert rep["stress_max"] == 1.6e6
    assert rep["e_at_max"] == e[5]
    if isotropic:
        assert rep["k0"] is None and rep["k0_virgin"] is None
    else:
        assert rep["k0"] == pytest.approx(list(k0), rel=1e-15)
        assert rep["k0_virgin"] == pytest.approx(np.mean(k0[1:6]), rel=1e-12)
    assert_json_safe(rep)


def test_oedometer_k0_without_its_column_is_sigma_3_over_sigma_1():
    s, e = e_log_line()
    table = compression_table(s, e, sigma_3=0.4 * s).drop("p")
    rep = compression_report(table, "oedometer")
    assert rep["k0"] == pytest.approx([0.4] * s.size, rel=1e-15)


def test_loading_only_has_no_swelling_index():
    s = LOAD[1:]
    rep = compression_report(compression_table(s, 0.8 - CC * np.log10(s / 1e5), k0=0.5 + 0 * s))
    assert rep["Cc"] == pytest.approx(CC, rel=1e-12)
    assert rep["Cs"] is None and rep["kappa_ln"] is None
    assert rep["unloading_rows"] == []
    assert_json_safe(rep)


def test_two_loading_rows_give_the_secant_index():
    s = np.array([1e5, 3e5])
    e = np.array([0.8, 0.8 - CC * math.log10(3)])
    rep = compression_report(compression_table(s, e, isotropic=True))
    assert rep["virgin_rows"] == [0, 1]
    assert rep["Cc"] == pytest.approx(CC, rel=1e-12)


def test_a_reloading_after_the_unloading_is_left_out_of_cs():
    s, e = e_log_line()
    s = np.r_[s, 4e5, 1.6e6]
    e = np.r_[e, e[-1] - 0.1, e[-1] - 0.3]  # far off the swelling line
    rep = compression_report(compression_table(s, e, isotropic=True))
    assert rep["unloading_rows"] == [5, 6, 7, 8]
    assert rep["Cs"] == pytest.approx(CS, rel=1e-12)


# --- properties ---------------------------------------------------------------------------

positive = st.floats(1e3, 1e7, allow_nan=False)


@st.composite
def stress_paths(draw, min_rows=2):
    n = draw(st.integers(min_rows, 40))
    steps = draw(st.lists(st.floats(1e-4, 1e-2), min_size=n - 1, max_size=n - 1))
    eps = np.r_[0.0, np.cumsum(steps)]
    s3 = np.array(draw(st.lists(positive, min_size=n, max_size=n)))
    k = np.array(draw(st.lists(st.floats(0.2, 6.0), min_size=n, max_size=n)))
    ev = np.array(draw(st.lists(st.floats(-0.05, 0.05), min_size=n, max_size=n)))
    return eps, s3 * k, s3, ev


@settings(max_examples=60)
@given(s1=positive, s3=positive)
def test_in_3d_the_friction_angle_is_asin_of_3_eta_over_6_plus_eta(s1, s3):
    # p = (s1 + 2 s3)/3, q = s1 - s3: 3 eta/(6 + eta) = 3q/(6p + q) = (s1 - s3)/(s1 + s3)
    rep = triaxial_report(triaxial_table([0.0, 0.01], [s3, s1], [s3, s3]), 3)
    eta = rep["eta_peak"]
    assert eta == pytest.approx((s1 - s3) / ((s1 + 2 * s3) / 3) if s1 > s3 else 0.0, abs=1e-12)
    assert math.radians(rep["phi_peak"]) == pytest.approx(math.asin(3 * eta / (6 + eta)), abs=1e-12)


@settings(max_examples=60)
@given(s1=positive, s3=positive)
def test_in_2d_the_friction_angle_is_asin_of_half_eta(s1, s3):
    # p = (s1 + s3)/2, q = s1 - s3: q/(2p) = (s1 - s3)/(s1 + s3), sin phi = eta/2
    rep = triaxial_report(triaxial_table([0.0, 0.01], [s3, s1], [s3, s3], dim=2), 2)
    assert math.radians(rep["phi_peak"]) == pytest.approx(math.asin(rep["eta_peak"] / 2), abs=1e-12)


@settings(max_examples=60)
@given(path=stress_paths())
def test_the_peak_angle_is_never_below_the_critical_state_angle(path):
    eps, s1, s3, ev = path
    for dim in (2, 3):
        rep = triaxial_report(triaxial_table(eps, s1, s3, eps_v=ev, dim=dim), dim)
        assert rep["phi_peak"] >= rep["phi_cs"]
        assert rep["eta_peak"] >= rep["eta_cs"] - 1e-12 * abs(rep["eta_cs"])
        assert_json_safe(rep)


@settings(max_examples=60)
@given(path=stress_paths(), power=st.integers(-20, 20), factor=st.floats(1e-3, 1e3))
def test_every_angle_is_invariant_under_a_scaling_of_the_stresses(path, power, factor):
    eps, s1, s3, ev = path
    base = triaxial_report(triaxial_table(eps, s1, s3, eps_v=ev), 3)
    angles = ("phi_peak", "phi_cs", "psi_max", "eta_peak", "eta_cs", "eps_a_peak")
    # a power of two scales every stress exactly: the angles are bit-identical
    two = triaxial_report(triaxial_table(eps, s1 * 2.0**power, s3 * 2.0**power, eps_v=ev), 3)
    for key in angles:
        assert two[key] == base[key]
    if base["E_50"] is not None:
        assert two["E_50"] == base["E_50"] * 2.0**power
    # any other unit: the same up to rounding, E50 scaled
    other = triaxial_report(triaxial_table(eps, s1 * factor, s3 * factor, eps_v=ev), 3)
    for key in ("phi_peak", "phi_cs", "psi_max", "eta_cs"):
        if base[key] is None:
            assert other[key] is None
        else:
            assert other[key] == pytest.approx(base[key], rel=1e-9, abs=1e-9)
    if base["E_50"] is not None:
        assert other["E_50"] == pytest.approx(base["E_50"] * factor, rel=1e-6)


# --- bad input ----------------------------------------------------------------------------


def test_a_table_lacking_a_column_is_refused_naming_table():
    table = triaxial_table([0.0, 0.01, 0.02], 2e5, 1e5).drop("eps_v")
    with pytest.raises(InvalidParameterError, match="eps_v") as info:
        triaxial_report(table, 3)
    assert info.value.parameter == "table"
    s, e = e_log_line()
    with pytest.raises(InvalidParameterError, match="'target'") as info:
        compression_report(compression_table(s, e).drop("target"))
    assert info.value.parameter == "table"
    with pytest.raises(InvalidParameterError, match="'p'") as info:
        compression_report(compression_table(s, e).drop("p"), "isotropic")
    assert info.value.parameter == "table"


def test_a_table_of_one_row_is_refused_naming_table():
    one = triaxial_table([0.0], 2e5, 1e5)
    for call in (
        lambda: triaxial_report(one, 3),
        lambda: eps_v_at(one, 0.0),
        lambda: compression_report(compression_table([1e5], [0.8], k0=[0.5])),
    ):
        with pytest.raises(InvalidParameterError, match="1 row") as info:
            call()
        assert info.value.parameter == "table"


@pytest.mark.parametrize(
    "table, match",
    [
        ({"eps_a": [0.0, 0.1]}, "polars.DataFrame"),
        (triaxial_table([0.0, 0.02, 0.01], 2e5, 1e5), "eps_a decreases at row 2"),
        (triaxial_table([0.01, 0.01], 2e5, 1e5), "does not grow"),
        (triaxial_table([0.0, 0.01], [2e5, math.nan], 1e5), "non-finite value at row 1"),
        (triaxial_table([0.0, 0.01], [2e5, -3e5], 1e5), "sigma_1 \\+ sigma_3"),
    ],
)
def test_a_triaxial_table_off_the_contract_is_refused(table, match):
    with pytest.raises(InvalidParameterError, match=match) as info:
        triaxial_report(table, 3)
    assert info.value.parameter == "table"


def test_settings_out_of_range_are_refused_naming_them():
    table = triaxial_table([0.0, 0.01], 2e5, 1e5)
    for kwargs, name in [
        ({"dim": 4}, "dim"),
        ({"dim": 3, "cs_share": 0.0}, "cs_share"),
        ({"dim": 3, "dilatancy_window": -0.01}, "dilatancy_window"),
        ({"dim": 3, "peak_margin": -1.0}, "peak_margin"),
    ]:
        with pytest.raises(InvalidParameterError) as info:
            triaxial_report(table, **kwargs)
        assert info.value.parameter == name
    with pytest.raises(InvalidParameterError) as info:
        compression_report(compression_table([1e5, 2e5], [0.8, 0.7]), "triaxial")
    assert info.value.parameter == "test"
    with pytest.raises(InvalidParameterError, match="<= 0 at row 0") as info:
        compression_report(compression_table([0.0, 2e5], [0.8, 0.7], isotropic=True))
    assert info.value.parameter == "table"
