"""The drained triaxial compression (the scene's ``[triaxial]`` table) of the consolidated
sample: the lid moves in at a constant strain rate while the side walls hold sigma_3
(`granpack.triaxial`). It needs the scene's ``[consolidate]``, and runs after it."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

from ..element import triaxial
from ..pack import Pack
from ..scene import PackScene

__all__ = ["Spec", "spec_of", "run"]

#: The test's settings: the scene's ``[triaxial]`` table as the scene holds it (the
#: keyword arguments of `granpack.triaxial`, whose signature holds the defaults).
Spec = Mapping[str, Any]


def spec_of(scene: PackScene) -> Spec | None:
    """The triaxial test `scene` asks for (its ``[triaxial]`` table), or None."""
    return None if scene.triaxial is None else dict(scene.triaxial)


def run(pack: Pack, spec: Spec, progress: bool | Callable[[dict], None] = False) -> Pack:
    """`pack` (consolidated) sheared as `spec` says; its history gains the "triaxial"
    record. (`progress` is the stage list's; the test reports none.)"""
    return triaxial(pack, **spec)
