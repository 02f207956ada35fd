"""Oedometric loading and unloading (the scene's ``[oedometer]`` table) of the
consolidated sample: the lid's servo holds each of ``stresses`` in turn to equilibrium,
the side walls fixed (`granpack.oedometer`). It needs the scene's ``[consolidate]``, and
runs after it."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

from ..element import oedometer
from ..pack import Pack
from ..scene import PackScene

__all__ = ["Spec", "spec_of", "run"]

#: The test's settings: the scene's ``[oedometer]`` table as the scene holds it (the
#: keyword arguments of `granpack.oedometer`, ``stresses`` among them; the signature
#: holds the defaults).
Spec = Mapping[str, Any]


def spec_of(scene: PackScene) -> Spec | None:
    """The oedometer test `scene` asks for (its ``[oedometer]`` table), or None."""
    return None if scene.oedometer is None else dict(scene.oedometer)


def run(pack: Pack, spec: Spec, progress: bool | Callable[[dict], None] = False) -> Pack:
    """`pack` (consolidated) loaded as `spec` says; its history gains the "oedometer"
    record. (`progress` is the stage list's; the test reports none.)"""
    return oedometer(pack, **spec)
