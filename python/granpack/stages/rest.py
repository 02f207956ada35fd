"""The settling to rest (the scene's ``rest_tol``): the deposit runs on under its own
weight until its unbalanced-force ratio is at most the tolerance
(`granpack.consolidation.settle`)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from ..consolidation import settle
from ..pack import Pack
from ..scene import PackScene

__all__ = ["Spec", "spec_of", "run"]


@dataclass(frozen=True)
class Spec:
    """The settling's settings.

    Attributes
    ----------
    unbalanced_tol : float
        Largest unbalanced-force ratio at rest (-): the scene's ``rest_tol``.
    """

    unbalanced_tol: float


def spec_of(scene: PackScene) -> Spec | None:
    """The settling `scene` asks for (its ``rest_tol``), or None."""
    return None if scene.rest_tol is None else Spec(unbalanced_tol=scene.rest_tol)


def run(pack: Pack, spec: Spec, progress: bool | Callable[[dict], None] = False) -> Pack:
    """`pack` settled to ``spec.unbalanced_tol``; its history gains the "rest" record.
    (`progress` is the stage list's; the settling reports none.)"""
    return settle(pack, spec.unbalanced_tol)
