"""The one analysis input (`System.from_any`) and the one container type
(`Container.from_scene`, `ContainerTag` to and from it)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import granpack as gp
from granpack.analysis import Container, System
from granpack.analysis.container import ContainerTag


def _square_lattice():
    g = np.stack(np.meshgrid(np.arange(6), np.arange(6)), -1).reshape(-1, 2)
    x = (g + 0.5) * 0.02
    return x, np.full(len(x), 0.01)


def test_a_system_is_what_the_analysis_functions_take():
    x, r = _square_lattice()
    box = ([0.0, 0.0], [0.12, np.inf])
    system = System.from_any(positions=x, radii=r, box=box)
    assert System.from_any(system) is system
    by_arrays = gp.microstructure(positions=x, radii=r, box=box, core_margin=0.01)
    by_system = gp.microstructure(system, core_margin=0.01)
    assert by_system.phi == by_arrays.phi and by_system.z == by_arrays.z
    assert gp.profiles(system).equals(gp.profiles(positions=x, radii=r, box=box))
    assert System.from_any(x, radii=r, box=box).n == len(r)
    with pytest.raises(gp.InvalidParameterError, match="box"):
        System.from_any(system, box=box)
    with pytest.raises(TypeError, match="radius"):
        System.from_any(positions=x, radii=r, radius=1.0)  # type: ignore[call-arg]


def test_a_scene_and_a_tag_map_to_one_container():
    scene = gp.PackScene(dim=3, base=(0.2, 0.2), container="cylinder", phi_layer=0.3)
    c = Container.from_scene(scene, height=0.3)
    assert (c.kind, c.radius, c.hi.tolist()) == ("cylinder", 0.1, [0.2, 0.2, 0.3])
    tag = ContainerTag.from_container(c)
    back = ContainerTag.parse(tag.words(), Path("t"), 1, 3)
    assert back is not None
    again = back.to_container()
    assert (again.kind, again.radius, again.hi.tolist()) == (c.kind, c.radius, c.hi.tolist())
    periodic = Container.from_scene(gp.PackScene(dim=2, base=(0.3,), container="periodic"))
    assert periodic.periodic == (True,) and periodic.kind == "periodic"
