"""`generate`: the deposit, then each stage the scene lists, in order
(`granpack.stages`); or, for a scene with a density target, the search over that list
(`granpack.density`)."""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable

from . import density, stages
from .errors import InvalidParameterError
from .pack import Pack
from .scene import PackScene

__all__ = ["generate"]


def generate(
    scene: PackScene,
    progress: bool | Callable[[dict], None] = False,
) -> Pack:
    """Builds one pack: the deposit, layer by layer (RSA layer, DEM jamming run, new
    height) until the height reaches `scene.height`, with the flat top (`trim`) where
    the scene asks; then each stage the scene lists, in the order of
    `granpack.stages.STAGES`: the settling to rest (`rest_tol`), the consolidation
    (`[consolidate]`), the element test on the consolidated sample (`[triaxial]`,
    `[oedometer]` or `[isotropic]`). Each stage adds its record to the pack's
    `history`. A scene with a density target (``target_phi``, ``target_void_ratio`` or
    ``target_relative_density``) is built by the density target's search
    (`granpack.density.run`), which runs that list up to the consolidation again with
    the deposit's friction changed and so may generate several packs of the scene
    (docs/density.md); the element test then runs on the pack it finds.

    Parameters
    ----------
    scene : PackScene
    progress : bool or callable
        False (default): silent. True: a tqdm bar per layer on stderr. A callable gets
        each layer's report dict (layer, added, total, phi_rsa, height, steps,
        kinetic_energy, wall_seconds, frozen, and memory: the engine's bytes by group).

    Raises
    ------
    DensityTargetError
        The scene's density target lies outside the window it reaches.

    Warns
    -----
    UnsettledPackWarning
        The pack has not come to rest (see `granpack.pack.settling_issue`): settle_time shorter than
        the fall time through a layer's slab, or particles still moving at the end.
    """
    if not isinstance(scene, PackScene):
        raise InvalidParameterError(
            f"invalid scene = {scene!r}: must be a granpack.PackScene", parameter="scene"
        )
    target = density.spec_of(scene)
    t0 = time.perf_counter()
    if target is not None:
        pack = density.run(scene, target, progress)
        tests = [s for s in stages.plan(scene) if s.stage in stages.ELEMENT_STAGES]
        if not tests:
            return pack
        # the element test runs on the sample at the density target
        for step in tests:
            pack = stages.run_step(pack, step, progress)
        return dataclasses.replace(pack, wall_time=time.perf_counter() - t0)
    steps = stages.plan(scene)
    pack = stages.run(scene, steps, progress, _stacklevel=3)
    if len(steps) > 1:
        # the time of every stage, not the layer loop's alone
        pack = dataclasses.replace(pack, wall_time=time.perf_counter() - t0)
    return pack
