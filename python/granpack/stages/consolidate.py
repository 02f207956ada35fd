"""The consolidation (the scene's ``[consolidate]`` table): servo-controlled walls bring
the deposit to a target stress and hold it there until it is in static equilibrium
(`granpack.consolidation.consolidate`). It runs at the material's contact model
throughout; with a density target (``target_phi``) it lowers the friction in phases,
each keeping the material's rolling model but the one at zero friction, which runs
without rolling resistance (mu_r = 0) until the friction is restored
(docs/contact_models.md)."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

from ..consolidation import consolidate
from ..pack import Pack
from ..scene import PackScene

__all__ = ["Spec", "spec_of", "run"]

#: The consolidation's settings: the scene's ``[consolidate]`` table as the scene holds
#: it (the keyword arguments of `granpack.consolidate`, whose signature holds the
#: defaults), with, for a density target under the servo, ``target_phi`` and
#: ``density_tol``.
Spec = Mapping[str, Any]


def spec_of(scene: PackScene) -> Spec | None:
    """The consolidation `scene` asks for (its ``[consolidate]`` table), or None."""
    return None if scene.consolidate is None else dict(scene.consolidate)


def run(pack: Pack, spec: Spec, progress: bool | Callable[[dict], None] = False) -> Pack:
    """`pack` consolidated as `spec` says; its history gains the "consolidate" record.
    (`progress` is the stage list's; the consolidation reports none.)"""
    return consolidate(pack, **spec)
