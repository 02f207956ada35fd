"""`_core.LayerPlacer`, the layer loop's placement alone (the LAMMPS engine's): seeded as
the native layer loop, it places the same layers on the same particles beneath."""

from __future__ import annotations

import numpy as np
import pytest

import granpack as gp
from granpack import _core


def _scene(**changes) -> gp.PackScene:
    return gp.PackScene.preset("4.3").replace(base=(0.3, 0.3), height=0.25, **changes)


@pytest.mark.parametrize("container", ["box", "periodic"])
def test_placer_draws_the_native_loops_layers(container):
    scene = _scene(container=container, settle_time=0.3)
    packer = _core.LayerPacker(scene)
    placer = _core.LayerPlacer(scene)
    state = packer.state()
    height = 0.0
    for layer in range(3):
        x, r = placer.place(state["positions"], state["radii"], height)
        n0 = len(state["radii"])
        packer.next_layer()
        state = packer.state()
        # the same radii in the same (Morton) order: the same draws, placed at the same
        # centres (the order is that of the centres)
        np.testing.assert_array_equal(r, state["radii"][n0:])
        assert x.shape == (len(r), 3)
        assert placer.layers == layer + 1
        # every centre inside the slab above the pack, one radius inside the walls
        assert np.all(x[:, 2] >= height - 1e-12)
        assert np.all(x[:, 2] <= height + scene.h_layer + 1e-12)
        if container == "box":
            assert np.all(x[:, :2] >= r[:, None] - 1e-12)
            assert np.all(x[:, :2] <= 0.3 - r[:, None] + 1e-12)
        # no overlap within the layer nor with the particles beneath
        both = np.concatenate([state["positions"][:n0], x])
        rb = np.concatenate([state["radii"][:n0], r])
        table = _core.find_contacts(
            both,
            rb,
            walls=(np.zeros(3), np.array([0.3, 0.3, np.inf])),
            periodic=[True, True] if container == "periodic" else None,
        )
        new_pairs = (table["j"] >= 0) & (np.maximum(table["i"], table["j"]) >= n0)
        assert not np.any(new_pairs)
        height = float(packer.height)


def test_only_the_particles_near_the_top_matter():
    scene = _scene(settle_time=0.3)
    packer = _core.LayerPacker(scene)
    for _ in range(2):
        packer.next_layer()
    state = packer.state()
    h = float(packer.height)
    r_max = 0.02
    near = state["positions"][:, 2] + state["radii"] > h - 2.0 * r_max
    assert 0 < near.sum() < len(near)
    a = _core.LayerPlacer(scene)
    b = _core.LayerPlacer(scene)
    # both draw the first two layers first, so that their generators stand where the
    # packer's stood before its third layer
    for p in (a, b):
        for _ in range(2):
            p.place(np.zeros((0, 3)), np.zeros(0), 0.0)
    xa, ra = a.place(state["positions"], state["radii"], h)
    xb, rb = b.place(state["positions"][near][::-1].copy(), state["radii"][near][::-1].copy(), h)
    np.testing.assert_array_equal(xa, xb)
    np.testing.assert_array_equal(ra, rb)


def test_positions_outside_the_periodic_cell_are_wrapped():
    scene = _scene(container="periodic", settle_time=0.3)
    packer = _core.LayerPacker(scene)
    packer.next_layer()
    state = packer.state()
    h = float(packer.height)
    shifted = state["positions"].copy()
    shifted[::2, 0] += 0.3  # one period further along x
    shifted[1::2, 1] -= 0.3
    a, b = _core.LayerPlacer(scene), _core.LayerPlacer(scene)
    for p in (a, b):
        p.place(np.zeros((0, 3)), np.zeros(0), 0.0)
    xa, _ = a.place(state["positions"], state["radii"], h)
    xb, _ = b.place(shifted, state["radii"], h)
    np.testing.assert_array_equal(xa, xb)


@pytest.mark.parametrize(
    ("positions", "radii", "height", "parameter"),
    [
        (np.zeros((2, 3)), np.full(3, 0.02), 0.0, "radii"),
        (np.zeros((0, 3)), np.zeros(0), -1.0, "height"),
        (np.zeros((0, 3)), np.zeros(0), float("nan"), "height"),
        (np.zeros((1, 2)), np.full(1, 0.02), 0.0, "positions"),
    ],
)
def test_bad_input_is_named(positions, radii, height, parameter):
    placer = _core.LayerPlacer(_scene())
    with pytest.raises(gp.InvalidParameterError, match=parameter):
        placer.place(positions, radii, height)


def test_max_layers_stops_the_placement():
    placer = _core.LayerPlacer(_scene(max_layers=1))
    placer.place(np.zeros((0, 3)), np.zeros(0), 0.0)
    with pytest.raises(gp.InvalidParameterError, match="max_layers"):
        placer.place(np.zeros((0, 3)), np.zeros(0), 0.1)
