"""The tiling: a laterally periodic pack copied ``nx`` (x ``ny``) times
(`granpack.tile`). No scene asks for it; ``granpack tile`` runs it on a pack file."""

from __future__ import annotations

from collections.abc import Callable

from ..pack import Pack
from ..scene import PackScene
from ..tiling import tile

__all__ = ["Spec", "spec_of", "run"]

#: The tiling's settings: the copies along each horizontal axis, ``(nx, ny)`` in 3D,
#: ``(nx,)`` in 2D.
Spec = tuple[int, ...]


def spec_of(scene: PackScene) -> Spec | None:
    """None: a scene does not ask for a tiling (it is run on a finished pack)."""
    return None


def run(pack: Pack, spec: Spec, progress: bool | Callable[[dict], None] = False) -> Pack:
    """`pack` tiled `spec` times; its history gains (or updates) the "tile" record."""
    return tile(pack, spec)
