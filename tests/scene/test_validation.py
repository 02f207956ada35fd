"""Bad input is a GranpackError (a ValueError) that names the parameter; never a panic,
a hang or NaN."""

from __future__ import annotations

import math

import numpy as np
import pytest

import granpack as gp


def raises(match: str):
    return pytest.raises(ValueError, match=match)


def test_error_class_is_a_value_error():
    assert issubclass(gp.GranpackError, ValueError)


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"poisson": 0.5}, "poisson"),
        ({"poisson": -1.0}, "poisson"),
        ({"friction": -0.1}, "friction"),
        ({"density": 0.0}, "density"),
        ({"young": -1.0}, "young"),
        ({"damping": 1.5}, "damping"),
        ({"young": float("nan")}, "young"),
        ({"density": "heavy"}, "density"),
    ],
)
def test_material_rejects_out_of_range(kwargs, name):
    with raises(name):
        gp.Material(**kwargs)


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"dim": 4}, "dim"),
        ({"dim": True}, "dim"),
        ({"dt": 0.0}, "dt"),
        ({"dt": -1e-4}, "dt"),
        ({"drag": -1.0}, "drag"),
        ({"gravity": [0.0, 1.0]}, "gravity"),
        ({"box": ((0, 0, 0), (0, 1, 1))}, "box"),
        ({"box": ((1, 0, 0), (0, 1, 1))}, "box"),
        ({"box": "cube"}, "box"),
        ({"rotations": "yes"}, "rotations"),
        ({"material": {"young": 1}}, "material"),
    ],
)
def test_simulation_rejects_bad_settings(kwargs, name):
    with raises(name):
        gp.Simulation(**{"dim": 3, **kwargs})


@pytest.mark.parametrize(
    ("positions", "radii", "name"),
    [
        ([[0.0, 0.0, 0.0]], [-0.01], "radii"),
        ([[0.0, 0.0, 0.0]], [0.0], "radii"),
        ([[np.nan, 0.0, 0.0]], [0.01], "positions"),
        ([[0.0, 0.0]], [0.01], "positions"),
        ([[0.0, 0.0, 0.0]], [0.01, 0.01], "radii"),
        (np.array([["a", "b", "c"]]), [0.01], "positions"),
        ([[0.0, 0.0, 0.0]], [np.inf], "radii"),
    ],
)
def test_add_particles_rejects_bad_arrays(positions, radii, name):
    sim = gp.Simulation(dim=3)
    with raises(name):
        sim.add_particles(positions, radii)
    assert len(sim) == 0


def test_particle_outside_the_box_is_refused():
    sim = gp.Simulation(dim=2, box=((0, 0), (1, math.inf)))
    with raises("positions"):
        sim.add_particles([[1.5, 0.5]], [0.01])


def test_bad_velocity_and_spin_shapes():
    sim = gp.Simulation(dim=3)
    with raises("velocities"):
        sim.add_particles([[0, 0, 0]], [0.01], velocities=[[0, 0]])
    with raises("spins"):
        sim.add_particles([[0, 0, 0]], [0.01], spins=[0.0])


def test_unstable_dt_is_refused_with_the_estimate():
    sim = gp.Simulation(dim=2, dt=5e-4)
    sim.add_particles([[0.0, 0.0]], [0.01])
    crit = sim.critical_time_step()
    assert crit == pytest.approx(math.pi * 0.01 * math.sqrt(1000 / 4e7) / (0.1631 * 0.25 + 0.8766))
    with raises(r"dt .*critical"):
        sim.step(1)


def test_step_count_must_be_a_non_negative_integer():
    sim = gp.Simulation(dim=2)
    for bad in (-1, 1.5, "3"):
        with raises("n"):
            sim.step(bad)


def test_blowup_is_caught_with_step_and_particle():
    """A violent collision at dt near the limit overlaps beyond the guard: the run
    stops with an error naming the step and particle instead of returning garbage."""
    sim = gp.Simulation(dim=3, dt=1.7e-4, gravity=[0, 0, 0])
    sim.add_particles(
        [[0, 0, 0], [0.0205, 0, 0]], [0.01, 0.01], velocities=[[200, 0, 0], [-200, 0, 0]]
    )
    with pytest.raises(gp.GranpackError, match=r"unstable at step 1 .*particle 0: speed"):
        sim.step(100)


def test_excessive_overlap_is_caught():
    sim = gp.Simulation(dim=3, dt=1e-5, gravity=[0, 0, 0], max_overlap_ratio=0.05)
    sim.add_particles(
        [[0, 0, 0], [0.0201, 0, 0]], [0.01, 0.01], velocities=[[10, 0, 0], [-10, 0, 0]]
    )
    with pytest.raises(
        gp.GranpackError, match=r"unstable at step \d+.*particle 0.*overlap with particle 1"
    ):
        sim.step(1000)
