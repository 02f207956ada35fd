"""The error classes: each failure raises its own subclass of GranpackError, whose
attributes hold the values (so scripts read them instead of parsing messages), and
which survives pickling (errors raised in ensemble workers)."""

from __future__ import annotations

import math
import pickle

import numpy as np
import pytest

import granpack as gp
from granpack import _core


def test_every_class_is_a_granpack_error_and_a_value_error():
    for cls in (
        gp.InvalidParameterError,
        gp.UnstableTimeStepError,
        gp.BlowUpError,
        gp.SaturationError,
        gp.FileFormatError,
    ):
        assert issubclass(cls, gp.GranpackError) and issubclass(cls, ValueError)
    assert issubclass(gp.UnstableTimeStepError, gp.InvalidParameterError)


def test_invalid_parameter_from_the_engine_names_it():
    with pytest.raises(gp.InvalidParameterError) as e:
        _core.rayleigh_time_step(1000.0, 1e7, 0.3, -0.01)
    assert e.value.parameter == "r_min"
    assert e.value.value == "-0.01"
    assert e.value.expected == "must lie in (0, inf)"
    assert str(e.value) == "invalid r_min = -0.01: must lie in (0, inf)"


def test_invalid_parameter_from_python_names_it():
    with pytest.raises(gp.InvalidParameterError) as e:
        gp.PackScene.preset("4.1").replace(phi_layer=1.5)
    assert e.value.parameter == "phi_layer"
    with pytest.raises(gp.InvalidParameterError) as e:
        gp.Material(young=-1.0)
    assert e.value.parameter == "young"


def test_unstable_time_step_carries_the_estimate():
    mat = gp.Material()
    r = 0.01
    critical = mat.critical_time_step(r)
    sim = gp.Simulation(dim=3, material=mat, dt=1.5 * critical, gravity=[0.0, 0.0, 0.0])
    sim.add_particles([[0.0, 0.0, 0.0]], [r])
    with pytest.raises(gp.UnstableTimeStepError) as e:
        sim.step(1)
    err = e.value
    assert (err.parameter, err.dt, err.r_min) == ("dt", 1.5 * critical, r)
    # the estimate is the Rayleigh step of the material and the smallest radius
    g = mat.young / (2 * (1 + mat.poisson))
    rayleigh = math.pi * r * math.sqrt(mat.density / g) / (0.1631 * mat.poisson + 0.8766)
    assert err.critical == pytest.approx(rayleigh, rel=1e-12)
    assert isinstance(err, gp.InvalidParameterError)


def test_blow_up_on_a_deep_overlap_names_step_time_particle_and_kind():
    sim = gp.Simulation(dim=3, dt=1e-6, gravity=[0.0, 0.0, 0.0])
    # centres 0.8 r apart: an overlap of 1.2 r, beyond max_overlap_ratio = 0.5
    sim.add_particles([[0.0, 0.0, 0.0], [0.008, 0.0, 0.0]], [0.01, 0.01])
    with pytest.raises(gp.BlowUpError) as e:
        sim.step(5)
    err = e.value
    assert (err.kind, err.step, err.time, err.particle) == ("overlap", 0, 0.0, 0)
    assert err.kind in gp.errors.BLOWUP_KINDS


def test_blow_up_on_a_tunnelling_speed():
    sim = gp.Simulation(dim=2, dt=1e-4, gravity=[0.0, 0.0])
    # 1000 m/s moves a 1 cm disc 0.1 m a step: ten radii
    sim.add_particles([[0.0, 0.0]], [0.01], velocities=[[1000.0, 0.0]])
    with pytest.raises(gp.BlowUpError) as e:
        sim.step(3)
    assert e.value.kind == "speed" and e.value.particle == 0
    assert e.value.step <= 1


def test_saturation_carries_layer_and_fraction():
    scene = gp.PackScene.preset("4.1").replace(
        base=(0.1,), phi_layer=0.54, max_attempts=2000, settle_time=0.0
    )
    with pytest.raises(gp.SaturationError) as e:
        gp.generate(scene)
    err = e.value
    assert err.layer == 0
    assert err.target == 0.54
    assert err.attempts == 2000
    # RSA of discs saturates near 0.547 only with unbounded attempts; 2000 stop lower
    assert 0.3 < err.reached < err.target


def test_file_format_error_carries_the_path(tmp_path):
    p = tmp_path / "not_a_pack.npz"
    p.write_bytes(b"PK\x03\x04 this is no zip archive")
    with pytest.raises(gp.FileFormatError) as e:
        gp.load_pack(p)
    assert e.value.path == p
    assert "corrupt or truncated" in e.value.reason


@pytest.mark.parametrize(
    "err",
    [
        gp.BlowUpError("b", step=3, time=0.5, particle=7, kind="energy"),
        gp.SaturationError("s", layer=2, reached=0.3, target=0.4, attempts=9),
        gp.UnstableTimeStepError("u", dt=2e-4, critical=1e-4, r_min=0.01),
        gp.InvalidParameterError("invalid h_layer = -1: must be > 0"),
        gp.FileFormatError("f", path="a.npz", reason="r"),
    ],
)
def test_errors_pickle_whole_and_take_a_prefix(err):
    back = pickle.loads(pickle.dumps(err))
    assert type(back) is type(err) and str(back) == str(err)
    assert back.__dict__ == err.__dict__
    pre = err.with_prefix("#3: ")
    assert type(pre) is type(err) and str(pre) == "#3: " + str(err)
    assert pre.__dict__ == err.__dict__


def test_parameter_is_read_from_the_message_when_not_given():
    assert gp.InvalidParameterError("invalid material.young = -1: ...").parameter == (
        "material.young"
    )
    assert gp.InvalidParameterError("something else").parameter is None


def test_an_ensemble_worker_error_keeps_its_class(tmp_path):
    from granpack.ensemble import run_ensemble

    bad = gp.PackScene.preset("4.1").replace(
        base=(0.1,), phi_layer=0.54, max_attempts=2000, settle_time=0.0
    )
    with pytest.raises(gp.SaturationError, match=r"^#\d: ") as e:
        run_ensemble(bad, 2, 0, tmp_path, workers=2, progress=False)
    assert e.value.layer == 0 and e.value.attempts == 2000
    assert np.isfinite(e.value.reached)
