"""Isotropic compression (the scene's ``[isotropic]`` table) of the consolidated sample:
every wall's servo holds each of ``stresses`` in turn to equilibrium
(`granpack.isotropic_compression`). It needs the scene's ``[consolidate]`` and a box or
a cylinder, and runs after the consolidation."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

from ..element import isotropic_compression
from ..pack import Pack
from ..scene import PackScene

__all__ = ["Spec", "spec_of", "run"]

#: The test's settings: the scene's ``[isotropic]`` table as the scene holds it (the
#: keyword arguments of `granpack.isotropic_compression`, ``stresses`` among them; the
#: signature holds the defaults).
Spec = Mapping[str, Any]


def spec_of(scene: PackScene) -> Spec | None:
    """The isotropic compression `scene` asks for (its ``[isotropic]`` table), or None."""
    return None if scene.isotropic is None else dict(scene.isotropic)


def run(pack: Pack, spec: Spec, progress: bool | Callable[[dict], None] = False) -> Pack:
    """`pack` (consolidated) compressed as `spec` says; its history gains the
    "isotropic" record. (`progress` is the stage list's; the test reports none.)"""
    return isotropic_compression(pack, **spec)
