"""Pack generation (the paper's Algorithm 1) and pack files."""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from . import _core, packfile
from ._files import atomic_write, remove_stale_temporaries
from ._memory import memory_limit
from ._validate import InvalidParameterError
from .contacts import Contacts
from .history import STAGE_NAMES, TABLE_NAMES, StageRecord

# the pack file's versions and its check of a newer scene record, where they were
from .packfile import FORMAT_VERSION as FORMAT_VERSION
from .packfile import NEWER_FORMAT as NEWER_FORMAT
from .packfile import OLDEST_FORMAT_VERSION as OLDEST_FORMAT_VERSION
from .packfile import scene_record_error as scene_record_error
from .scene import PackScene

__all__ = [
    "Pack",
    "deposit",
    "load_pack",
    "atomic_write",
    "UnsettledPackWarning",
    "settling_issue",
    "fall_time",
    "remove_stale_temporaries",
]

#: A pack counts as unsettled when its particles' mean translational kinetic energy
#: exceeds this fraction of m g r (each particle's own): settled packs of the presets
#: end near 1e-8, and a last layer still landing above 0.05.
UNSETTLED_KE_RATIO = 0.05

#: The speed scale of a pack at rest, as a fraction of sqrt(g r_mean), the speed a
#: particle gains falling through a quarter of its radius; 1 cm/s for the 3D presets
#: (r = 0.02 m, g = 2 m/s^2), 0.7 cm/s for the 2D ones. A particle faster than this
#: counts as still moving. Settled preset packs end below 1e-3 sqrt(g r_mean), those of
#: the fast settings with 99 % of their particles below 0.04.
UNSETTLED_SPEED_RATIO = 0.05

#: A pack counts as unsettled when more than this fraction of its particles still move
#: (speed above `UNSETTLED_SPEED_RATIO` sqrt(g r_mean)): a moving minority, which the
#: mean kinetic energy of the whole pack hides. The fast settings' packs of the presets
#: end with about 1 % above the speed.
UNSETTLED_MOVING_FRACTION = 0.05


class UnsettledPackWarning(UserWarning):
    """`generate` returned a pack that has not come to rest. Any of:

    * its last layer had less settle_time than it needs to fall through its slab
      (`fall_time`);
    * more than `UNSETTLED_MOVING_FRACTION` (5 %) of its particles still move faster
      than `UNSETTLED_SPEED_RATIO` sqrt(g r_mean) (0.05 sqrt(g r_mean): 1 cm/s for the
      3D presets), a moving minority that the mean hides;
    * its particles' mean kinetic energy is above `UNSETTLED_KE_RATIO` m g r (a few
      fast ones).

    Its microstructure is then that of a pack in motion; give a longer settle_time."""


@dataclass(frozen=True, eq=False)
class Pack:
    """A finished pack and where it came from.

    Attributes
    ----------
    scene : PackScene
        The scene (seed and stream included) that produced it.
    positions : (N, D) float64
        Centres (m); vertical axis last.
    radii : (N,) float64
        Radii (m).
    velocities : (N, D) float64
        Velocities at the end (m/s).
    spins : (N,) or (N, 3) float64
        Angular velocities at the end (rad/s).
    layer : (N,) int64
        Layer (0-based) in which each particle was placed.
    contacts : Contacts
        Contacts in force at the end (particle-particle and wall).
    height : float
        Final height H_top = max(z + r) (m).
    layers : list of dict
        One report per layer: added, total, phi_rsa, height, steps, kinetic_energy,
        wall_seconds.
    wall_time : float
        Seconds spent generating.
    history : tuple of StageRecord
        One record per stage run after the layer loop, in order (`granpack.history`):
        the flat top ("trim"), the settling to rest ("rest"), the consolidation
        ("consolidate"), the density target ("density"), the tiling ("tile"). Each
        holds the settings the stage ran with, what it measured, its seconds and its
        time steps; `record` finds one by its stage. Empty for a plain deposit.
    engine : dict or None
        The engine that ran the deposit's DEM where it was not granpack's own: ``name``
        ("lammps"), ``version`` (LAMMPS' date, e.g. 20250722) and ``ranks`` (MPI
        ranks); None (default) for granpack's engine (`granpack.mpi`).
    """

    scene: PackScene
    positions: np.ndarray
    radii: np.ndarray
    velocities: np.ndarray
    spins: np.ndarray
    layer: np.ndarray
    contacts: Contacts
    height: float
    layers: list[dict] = field(default_factory=list)
    wall_time: float = 0.0
    history: tuple[StageRecord, ...] = ()
    engine: dict | None = None

    def record(self, stage: str) -> StageRecord | None:
        """The last record of `stage` ("trim", "rest", "consolidate", "density",
        "tile") in the pack's history, or None where that stage did not run."""
        if stage not in STAGE_NAMES:
            raise InvalidParameterError(
                f"invalid stage = {stage!r}: expected one of {', '.join(STAGE_NAMES)}",
                parameter="stage",
                value=stage,
                expected=f"one of {STAGE_NAMES}",
            )
        for rec in reversed(self.history):
            if rec.stage == stage:
                return rec
        return None

    def with_record(self, record: StageRecord, **changes: Any) -> Pack:
        """A copy of the pack with `changes` (`dataclasses.replace`'s) and `record`
        added to its history."""
        return replace(self, history=(*self.history, record), **changes)

    def _table(self, stage: str) -> dict | None:
        warnings.warn(
            f"Pack.{TABLE_NAMES[stage]} is deprecated and will be removed in the next "
            f"release: use Pack.record({stage!r}) (a StageRecord: settings, report, "
            "seconds, steps), or its .table() for this table",
            DeprecationWarning,
            stacklevel=3,
        )
        rec = self.record(stage)
        return None if rec is None else rec.table()

    @property
    def trim(self) -> dict | None:
        """Deprecated: ``record("trim").table()``, the flat top's table (``removed``,
        ``top``, ``phi_hd``, ``steps``), or None."""
        return self._table("trim")

    @property
    def tiled(self) -> dict | None:
        """Deprecated: ``record("tile").table()``, the tiling's table, or None."""
        return self._table("tile")

    @property
    def consolidation(self) -> dict | None:
        """Deprecated: ``record("consolidate").table()``, the consolidation's table, or
        None."""
        return self._table("consolidate")

    @property
    def rest(self) -> dict | None:
        """Deprecated: ``record("rest").table()``, the settling's table, or None."""
        return self._table("rest")

    @property
    def density(self) -> dict | None:
        """Deprecated: ``record("density").table()``, the density target's table, or
        None."""
        return self._table("density")

    @property
    def dim(self) -> int:
        return self.scene.dim

    @property
    def n_layers(self) -> int:
        """Number of layers placed."""
        return len(self.layers)

    def __len__(self) -> int:
        return int(self.radii.shape[0])

    @property
    def box(self) -> tuple[np.ndarray, np.ndarray]:
        """Box corners (lo, hi) up to H_top: lo = 0, hi = (base..., height)."""
        lo = np.zeros(self.dim)
        hi = np.array([*self.scene.base, self.height])
        return lo, hi

    @property
    def phi(self) -> float:
        """Solid fraction of the box up to H_top (-)."""
        vol = (
            np.sum(np.pi * self.radii**2)
            if self.dim == 2
            else np.sum(4 / 3 * np.pi * self.radii**3)
        )
        return float(vol / (self.scene.base_area * self.height))

    # -- files ------------------------------------------------------------------------
    def save(self, path: str | Path) -> Path:
        """Writes the pack to a `.npz` file atomically (temporary file, then rename); the
        format is `granpack.packfile`'s."""
        return atomic_write(path, lambda f: packfile.write(f, self))


def load_pack(path: str | Path) -> Pack:
    """Reads a pack written by `Pack.save` (in this version's format or granpack
    0.1.0's); a truncated or foreign file is a GranpackError, never a crash."""
    return Pack(**packfile.read(path))


#: Bytes per particle to budget: the engine's peak is about 1.2 kB per sphere
#: (`cargo run --release --example memory`), plus the arrays handed to Python.
BYTES_PER_PARTICLE = 1500


def check_memory(scene: PackScene, total_bytes: float | None = None) -> None:
    """Refuses a scene whose particles would not fit in 80 % of the memory this process
    may use (`granpack._memory.memory_limit`: the machine's, RLIMIT_AS's or the control
    group's, the smallest), or of `total_bytes`, before any work is done."""
    source = "this machine's memory"
    if total_bytes is None:
        limit = memory_limit()
        if limit is None:  # cannot tell
            return
        total_bytes, source = limit.bytes, limit.source
    n = scene.estimated_particles()
    need = n * BYTES_PER_PARTICLE
    if need > 0.8 * total_bytes:
        raise InvalidParameterError(
            f"invalid scene: about {n:.3g} particles (~{need / 2**30:.1f} GiB) would not fit "
            f"in {source} ({total_bytes / 2**30:.1f} GiB); shrink base or height, or grow "
            "r_mean",
            parameter="scene",
        )


def _packer(scene: PackScene) -> _core.LayerPacker:
    """The engine's layer loop for `scene` (which the engine reads by attribute)."""
    return _core.LayerPacker(scene)


def fall_time(scene: PackScene) -> float:
    """Time (s) a particle at the top of a layer's slab needs to reach its bottom: free
    fall sqrt(2 h_layer / g), or, when drag is strong, h_layer over the terminal speed
    m g / c_D of the lightest particle, whichever is longer."""
    t = math.sqrt(2.0 * scene.h_layer / scene.gravity)
    if scene.drag > 0.0:
        r = scene.r_min
        assert r is not None  # set by PackScene.__post_init__
        disc = scene.dim == 2 and scene.inertia_2d == "disc"
        vol = math.pi * r * r if disc else 4.0 / 3.0 * math.pi * r * r * r
        v_terminal = scene.material.density * vol * scene.gravity / scene.drag
        t = max(t, scene.h_layer / v_terminal) if v_terminal > 0 else math.inf
    return t


def settling_issue(pack: Pack) -> str | None:
    """Why `pack` has not come to rest (see `UnsettledPackWarning`), or None."""
    scene = pack.scene
    t_fall = fall_time(scene)
    if scene.settle_time < t_fall:
        return (
            f"settle_time = {scene.settle_time:g} s is shorter than the {t_fall:.3g} s a "
            f"layer needs to fall through its slab (h_layer = {scene.h_layer:g} m, gravity = "
            f"{scene.gravity:g} m/s^2, drag = {scene.drag:g} N s/m): the last layer is still "
            "in the air; give settle_time >= the fall time"
        )
    if len(pack) == 0:
        return None
    with np.errstate(over="ignore", invalid="ignore"):
        v2 = np.sum(np.asarray(pack.velocities, dtype=float) ** 2, axis=1)
        ratio = float(np.mean(0.5 * v2 / (scene.gravity * pack.radii)))
        speed = np.sqrt(v2)
    vmax = float(np.max(speed))
    # the speed of a pack at rest, from the scene (r_mean: the mean radius by number)
    r_mean = float(scene.r_mean) if scene.r_mean else float(np.mean(pack.radii))
    v_rest = UNSETTLED_SPEED_RATIO * math.sqrt(scene.gravity * r_mean)
    moving = int(np.count_nonzero(~(speed <= v_rest)))  # NaN counts as moving
    if moving > UNSETTLED_MOVING_FRACTION * len(pack):
        # (the numbers in one pair of parentheses: the command line groups its notes
        # by the words outside them)
        return (
            f"more than {UNSETTLED_MOVING_FRACTION:.0%} of the particles still move at the "
            f"end, faster than {UNSETTLED_SPEED_RATIO} sqrt(g r_mean) ({moving} of "
            f"{len(pack)} faster than {v_rest:.3g} m/s; fastest {vmax:.3g} m/s): the pack "
            f"has not settled in settle_time = {scene.settle_time:g} s; give a longer "
            "settle_time"
        )
    if not ratio <= UNSETTLED_KE_RATIO:
        return (
            f"the particles still move at the end (mean kinetic energy {ratio:.3g} m g r, "
            f"above {UNSETTLED_KE_RATIO} m g r; fastest {vmax:.3g} m/s): the pack has not "
            f"settled in settle_time = {scene.settle_time:g} s; give a longer settle_time"
        )
    return None


def _check_trim_keeps_particles(packer: _core.LayerPacker, scene: PackScene) -> None:
    """Refuses a flat top that would remove every particle (an empty pack), naming the
    trim height `height` and the heights that keep particles."""
    state = packer.state()
    x = np.asarray(state["positions"], dtype=np.float64)
    r = np.asarray(state["radii"], dtype=np.float64)
    tops = x[:, scene.vertical] + r if len(r) else np.array([math.inf])
    lowest = float(np.min(tops))
    if not lowest <= scene.height:
        raise InvalidParameterError(
            f"invalid height = {scene.height:g} m with trim = true: the flat top would "
            "remove every particle (each one's top z + r lies above height; the lowest "
            f"reaches {lowest!r} m) and leave an empty pack; give height >= "
            f"{lowest!r} m, or trim = false",
            parameter="height",
            value=scene.height,
            expected=f">= {lowest!r} m with trim = true",
        )


def deposit(
    scene: PackScene,
    progress: bool | Callable[[dict], None] = False,
    *,
    _stacklevel: int = 2,
) -> Pack:
    """The layer loop alone: one pack built layer by layer (RSA layer, DEM jamming run,
    new height) until the height reaches `scene.height`, then the flat top if the scene
    asks. The stages after it (a density target, `rest_tol`, `[consolidate]`) are
    `granpack.generate`'s; this runs none of them.

    Parameters
    ----------
    scene : PackScene
    progress : bool or callable
        As `granpack.generate`; a callable's report also holds ``memory``, the
        engine's bytes by group (`_core.LayerPacker.memory`).

    Warns
    -----
    UnsettledPackWarning
        The pack has not come to rest (see `settling_issue`).
    """
    check_memory(scene)
    t0 = time.perf_counter()
    packer = _packer(scene)
    reports: list[dict] = []
    bar = None
    if progress is True:
        from tqdm.auto import tqdm

        bar = tqdm(total=round(scene.height, 6), unit="m", desc="layers", leave=False)
    try:
        while not packer.done:
            rep: dict[str, Any] = dict(packer.next_layer())
            reports.append(rep)
            if bar is not None:
                bar.n = round(min(rep["height"], scene.height), 6)
                bar.set_postfix(layer=rep["layer"], N=rep["total"], s=f"{rep['wall_seconds']:.1f}")
                bar.refresh()
            elif callable(progress):
                # the engine's memory with the report, for the callback only (the pack
                # keeps the reports as the engine gave them)
                progress({**rep, "memory": dict(packer.memory())})
    finally:
        if bar is not None:
            bar.close()
    trim = None
    if scene.trim:
        _check_trim_keeps_particles(packer, scene)
        done = packer.trim(scene.height)
        trim = {
            "removed": int(done["removed"]),
            "top": float(done["height"]),
            "steps": done["steps"],
        }
    height = float(packer.height)
    # The engine is spent to build the pack: its pair state is freed as the contact
    # table is written, so the two are never held whole at once (at a million spheres
    # that is the generation's peak).
    state, table = packer.finish()
    del packer
    contacts = Contacts.from_dict(table)
    del table
    if trim is not None:
        r = np.asarray(state["radii"])
        solid = float(np.sum(np.pi * r**2 if scene.dim == 2 else 4 / 3 * np.pi * r**3))
        trim["phi_hd"] = solid / (scene.base_area * scene.height)
    pack = Pack(
        scene=scene,
        positions=state["positions"],
        radii=state["radii"],
        velocities=state["velocities"],
        spins=state["spins"],
        layer=state["layer"],
        contacts=contacts,
        height=height,
        layers=reports,
        wall_time=time.perf_counter() - t0,
        history=() if trim is None else (StageRecord.from_table("trim", trim),),
    )
    issue = settling_issue(pack)
    if issue is not None:
        warnings.warn(issue, UnsettledPackWarning, stacklevel=_stacklevel)
    return pack
