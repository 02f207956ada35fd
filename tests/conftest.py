"""Shared fixtures and helpers for granpack's Python tests."""

from __future__ import annotations

import pytest

import granpack as gp


@pytest.fixture
def tiny_scene_2d() -> gp.PackScene:
    """A reduced 2D scene (about 100 discs, 6 layers) that packs in about 0.1 s."""
    return gp.PackScene.preset("4.1").replace(
        base=(0.3,), height=0.12, h_layer=0.04, settle_time=0.3, seed=5
    )
