"""The triaxial test's physics, as every reviewer checks it, on samples of about a
thousand spheres of example 4.3's radii (0.4 m boxes, 100 kPa, axial strain 0.4):

- a dense sample shows a peak and dilates; a loose one contracts first and shows no
  marked peak;
- both end at the same critical-state stress ratio;
- the peak angle rises with the density and with the friction, and the critical-state
  ratio with rolling resistance.

The dense and the loose sample are of one material with rolling resistance (mu 0.5,
mu_r 0.3): loose, consolidated at the material's friction (phi 0.550); dense, its friction
lowered under the servo to phi 0.605 (`target_phi`). Spheres without rolling resistance
make no loose sample: at mu 0.5 the loosest is phi 0.575, near its critical state, and it
may show a small peak. The critical-state figures are means over the last 20 % of the
path (`granpack.element.lab`)."""

from __future__ import annotations

import dataclasses

import pytest

import granpack as gp

BASE = gp.PackScene.preset("4.3")


def _sheared(mu: float, target_phi: float | None = None, **rolling) -> dict:
    mat = dataclasses.replace(BASE.material, friction=mu, **rolling)
    sc = BASE.replace(seed=5, base=(0.4, 0.4), height=0.4, material=mat).fast()
    extra = {} if target_phi is None else {"target_phi": target_phi}
    sample = gp.consolidate(gp.generate(sc), 1e5, "isotropic", gravity=False, **extra)
    out = gp.triaxial(sample, axial_strain=0.4, checks=81)
    return {
        "phi": sample.record("consolidate").report["phi"],
        "lab": out.record("triaxial").report["lab"],
        "table": gp.element_table(out),
    }


@pytest.fixture(scope="module")
def runs() -> dict[str, dict]:
    return {
        "loose": _sheared(0.5, rolling="epsd", rolling_friction=0.3),
        "dense": _sheared(0.5, target_phi=0.605, rolling="epsd", rolling_friction=0.3),
        "no_rolling": _sheared(0.5),
        "low_friction": _sheared(0.2),
    }


def test_the_dense_sample_peaks_and_dilates(runs):
    d = runs["dense"]
    lab, t = d["lab"], d["table"]
    assert d["phi"] > runs["loose"]["phi"] + 0.02
    assert lab["peak"] is True
    assert lab["phi_peak"] - lab["phi_cs"] > 3.0
    assert lab["eps_a_peak"] < 0.15
    # it contracts a little, then dilates past its start
    assert lab["eps_v_end"] < -0.04
    assert lab["psi_max"] > 10.0
    assert float(t["eps_v"].max()) < float(runs["loose"]["table"]["eps_v"].max())


def test_the_loose_sample_contracts_without_a_marked_peak(runs):
    lab, t = runs["loose"]["lab"], runs["loose"]["table"]
    assert lab["peak"] is False
    assert float(t["eps_v"].max()) > 0.02
    assert lab["eps_v_end"] > runs["dense"]["lab"]["eps_v_end"] + 0.04


def test_dense_and_loose_reach_the_same_critical_state_ratio(runs):
    assert abs(runs["loose"]["lab"]["eta_cs"] - runs["dense"]["lab"]["eta_cs"]) <= 0.05


def test_the_peak_angle_rises_with_density_and_friction(runs):
    assert runs["dense"]["lab"]["phi_peak"] > runs["loose"]["lab"]["phi_peak"] + 3.0
    assert runs["no_rolling"]["lab"]["phi_peak"] > runs["low_friction"]["lab"]["phi_peak"] + 1.0


def test_rolling_resistance_raises_the_critical_state_ratio(runs):
    """Spheres roll where grains of sand interlock: without rolling resistance the
    critical-state angle stays near 20 degrees whatever the friction; mu_r = 0.3 brings it
    to about 30 (the peers' stand-in for angularity)."""
    assert runs["loose"]["lab"]["eta_cs"] > runs["no_rolling"]["lab"]["eta_cs"] + 0.2
    assert runs["no_rolling"]["lab"]["phi_cs"] < 25.0 < runs["loose"]["lab"]["phi_cs"]
