"""The deposit: the layer loop (the paper's Algorithm 1), with the flat top where the
scene asks for it (``trim``: run on the loop's own state before the pack is finished,
and recorded in the history as the "trim" stage)."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass

from .. import pack as _pack
from ..pack import Pack
from ..scene import PackScene

__all__ = ["Spec", "spec_of", "run"]


@dataclass(frozen=True)
class Spec:
    """The deposit's settings beyond the scene's.

    Attributes
    ----------
    friction : float or None
        The friction (-) every layer is jammed with, the deposition friction of a
        density target's search; the pack keeps the scene's material (its friction).
        None: the material's friction.
    """

    friction: float | None = None


def spec_of(scene: PackScene) -> Spec:
    """The deposit of `scene`: its layers jammed at the material's friction."""
    return Spec()


def run(
    scene: PackScene,
    spec: Spec,
    progress: bool | Callable[[dict], None] = False,
    *,
    _stacklevel: int = 2,
) -> Pack:
    """The layer loop of `scene` (`granpack.pack.deposit`), every layer jammed at
    ``spec.friction`` where it is given and differs from the material's."""
    mat = scene.material
    jam = scene
    if spec.friction is not None and spec.friction != mat.friction:
        jam = scene.replace(material=dataclasses.replace(mat, friction=spec.friction))
    pack = _pack.deposit(jam, progress, _stacklevel=_stacklevel + 1)
    return pack if jam is scene else dataclasses.replace(pack, scene=scene)
