"""Tiling a laterally periodic pack: a large representative volume from a small one.

`tile` copies a pack made in a periodic cell ``nx`` times along x (and ``ny`` times along
y in 3D), as YADE's ``cellRepeat`` or DEMGen's cloning do. The copies fit together
without a gap or an overlap because the cell is periodic: the contacts across the new
junctions are those that crossed the original cell's seam, with the same forces.
"""

from __future__ import annotations

import copy
import dataclasses
import hashlib
import math
import time
from numbers import Integral

import numpy as np

from . import _core
from ._memory import memory_limit
from ._validate import InvalidParameterError, short_repr
from .contacts import Contacts
from .history import StageRecord
from .pack import Pack

__all__ = ["tile", "MAX_TILED_PARTICLES"]

#: The largest tiled pack `tile` makes (particles): beyond it a typo in the counts (an
#: extra digit or two) would fill the memory instead of failing at once.
MAX_TILED_PARTICLES = 10**8

#: Bytes a tiled copy may need, per byte of the original's arrays (the result, and the
#: index arrays and sort of its contacts while they are built).
_WORK_FACTOR = 3

#: The keys of a layer report that count particles or add up over them: a tiled pack's
#: reports give the tiled pack's counts (copies times the original's); the other keys
#: (layer, phi_rsa, height, steps, wall_seconds) are the original's.
_EXTENSIVE_LAYER_KEYS = ("added", "total", "frozen", "kinetic_energy")


def tile(pack: Pack, counts) -> Pack:
    """Copies a laterally periodic pack ``nx`` x ``ny`` times (3D; ``(nx,)`` in 2D).

    Parameters
    ----------
    pack : Pack
        A pack made with ``container = "periodic"``. A walled pack (box, cylinder) is
        refused: its walls would end up inside the tiled pack.
    counts : sequence of D - 1 int
        Copies along each horizontal axis, each >= 1: ``(nx, ny)`` in 3D, ``(nx,)`` (or
        ``nx``) in 2D. The tiled pack holds at most `MAX_TILED_PARTICLES` particles.

    Returns
    -------
    Pack
        The tiled pack. Its scene is the original's with ``base`` multiplied by the
        counts; particle ``k`` of copy ``(a, b)`` (``0 <= a < nx``, ``0 <= b < ny``) is
        particle ``k + N (a + nx b)`` (in 2D, ``k + N a``), at the original's position
        shifted by ``(a L, b B)`` and wrapped into the new cell. Radii, velocities,
        spins and layer indices are copied. A particle-particle contact ``(i, j)`` of
        branch ``l`` (the minimum image in the original cell) joins copy ``(a, b)`` of
        ``i`` to the copy of ``j`` that lies at ``x_i + l`` in the new cell, with the
        same overlap and forces (the tangential force is the pack's record of the
        tangential history); wall (floor) contacts are copied with their particle.
        Contacts are listed as the engine lists them: particle pairs with ``i < j`` in
        order of ``(i, j)``, then wall contacts in order of particle. The coordination
        number, solid fraction, fabric and force tensors are therefore the original's.
        ``height`` is the original's; ``layers`` are the original's layer reports with
        their counts (added, total, frozen) and kinetic energy multiplied by the number
        of copies; ``wall_time`` is the original's plus the tiling's; ``tiled`` records
        the counts and the original (its N, base, seed, stream and a hash of its scene),
        and a tiled pack tiled again records the counts from the first original.
        A consolidated pack (`granpack.consolidate`, oedometric in a periodic cell)
        tiles with its lid at the same height: ``consolidation`` is the original's
        record (the walls, stresses, phi, k0 and force ratios hold for every copy and
        for the whole), with ``wall_contacts`` multiplied by the number of copies and
        ``deposit_base`` by the counts; the lid's contacts (wall id -6) are copied with
        their particle, so the tiled pack is analysed up to the lid and exported with
        it (the lid force of ``in.granpack`` is the copies' sum). ``rest`` and
        ``density`` are the original's records.

    Notes
    -----
    A tiled pack repeats exactly: its structure is periodic with the original's cell, so
    it holds no correlation longer than the original cell that the original lacked, and
    its ensemble statistics are those of one pack, not of ``nx ny`` independent ones.
    """
    t0 = time.perf_counter()
    if not isinstance(pack, Pack):
        raise InvalidParameterError(
            f"invalid pack = {short_repr(pack)}: expected a granpack.Pack (a periodic pack "
            "from generate or load_pack)",
            parameter="pack",
            value=short_repr(pack),
            expected="a granpack.Pack with container = 'periodic'",
        )
    scene = pack.scene
    # the engine's check of the tiling stage: a periodic pack (walls would lie inside)
    _core.resolve_stage("tile", scene, {})
    dim = scene.dim
    n = len(pack)
    reps = _counts(counts, dim, n)
    copies = math.prod(reps)
    _check_memory(pack, copies, reps)

    periods = np.array(scene.base, dtype=np.float64)
    new_periods = periods * np.array(reps, dtype=np.float64)
    try:
        new_scene = scene.replace(base=tuple(float(p) for p in new_periods))
    except InvalidParameterError as exc:  # the scene's own bounds, before any work
        raise InvalidParameterError(
            f"invalid counts = {reps}: the tiled scene is refused: {exc}",
            parameter="counts",
            value=reps,
            expected="counts whose tiled scene is valid",
        ) from None
    # copy c = a + nx b sits at (a, b) in the grid of copies
    cell = np.stack(np.unravel_index(np.arange(copies), reps[::-1])[::-1], axis=1)
    offsets = np.zeros((copies, dim))
    offsets[:, : dim - 1] = cell * periods

    x = np.asarray(pack.positions, dtype=np.float64)
    positions = (x[None, :, :] + offsets[:, None, :]).reshape(copies * n, dim)
    for h in range(dim - 1):
        positions[:, h] = _wrap(positions[:, h], new_periods[h])

    def copied(a: np.ndarray) -> np.ndarray:
        a = np.asarray(a)
        return np.tile(a, (copies,) + (1,) * (a.ndim - 1))

    contacts = _tiled_contacts(pack.contacts, x, periods, reps, cell, n)
    layers = [
        {k: (v * copies if k in _EXTENSIVE_LAYER_KEYS else v) for k, v in rep.items()}
        for rep in pack.layers
    ]
    seconds = time.perf_counter() - t0
    history = [_tiled_record(rec, copies, reps) for rec in pack.history]
    original = pack.record("tile")
    if original is None:
        history.append(
            StageRecord(
                stage="tile",
                settings={"counts": list(reps)},
                report={
                    "particles": n,
                    "base": [float(b) for b in scene.base],
                    "seed": int(scene.seed),
                    "stream": int(scene.stream),
                    "scene_sha256": hashlib.sha256(scene.to_toml().encode()).hexdigest(),
                },
                seconds=seconds,
            )
        )
    return Pack(
        scene=new_scene,
        positions=positions,
        radii=copied(pack.radii),
        velocities=copied(pack.velocities),
        spins=copied(pack.spins),
        layer=copied(pack.layer),
        contacts=contacts,
        height=pack.height,
        layers=layers,
        wall_time=pack.wall_time + (time.perf_counter() - t0),
        history=tuple(history),
    )


def _tiled_record(rec: StageRecord, copies: int, reps: tuple[int, ...]) -> StageRecord:
    """A stage's record for the tiled pack: the flat top's count of removed particles
    and the consolidation's counts of wall contacts times the copies; the tiling's
    counts (a pack tiled again: those from the first original) times `reps`; the
    others as they were."""
    if rec.stage == "trim":
        report = {**rec.report, "removed": rec.report["removed"] * copies}
        return dataclasses.replace(rec, report=report)
    if rec.stage == "consolidate":
        table = _tiled_consolidation(rec.table(), copies, reps)
        assert table is not None
        return StageRecord.from_table("consolidate", table)
    if rec.stage == "tile":
        counts = [int(c) * r for c, r in zip(rec.settings["counts"], reps, strict=True)]
        return dataclasses.replace(rec, settings={**rec.settings, "counts": counts})
    return copy.deepcopy(rec)


def _tiled_consolidation(record: dict | None, copies: int, reps: tuple[int, ...]) -> dict | None:
    """The consolidation record of the tiled pack: the original's, whose walls (the floor
    and the lid: a periodic cell has no side walls) stand where they stood, whose
    stresses, phi, k0 and force ratios are those of every copy and so of the whole; only
    the counts of wall contacts are multiplied by the copies, and the deposit's base by
    the counts (the base of the tiled scene's deposit)."""
    if record is None:
        return None
    out = copy.deepcopy(record)
    if "wall_contacts" in out:
        out["wall_contacts"] = {n: int(v) * copies for n, v in out["wall_contacts"].items()}
    if "deposit_base" in out:
        out["deposit_base"] = [float(b) * r for b, r in zip(out["deposit_base"], reps, strict=True)]
    return out


def _counts(counts, dim: int, n: int) -> tuple[int, ...]:
    """The copies per horizontal axis, checked: D - 1 integers >= 1 whose product times
    N stays within `MAX_TILED_PARTICLES`."""
    names = ("nx",) if dim == 2 else ("nx", "ny")
    form = "(nx,)" if dim == 2 else "(nx, ny)"
    if dim == 2 and isinstance(counts, Integral | np.integer) and not isinstance(counts, bool):
        counts = (counts,)
    if isinstance(counts, str | bytes) or not hasattr(counts, "__len__"):
        raise InvalidParameterError(
            f"invalid counts = {short_repr(counts)}: expected {form}, {dim - 1} integer(s) >= 1",
            parameter="counts",
            value=short_repr(counts),
            expected=f"{form}, integers >= 1",
        )
    if len(counts) != dim - 1:
        raise InvalidParameterError(
            f"invalid counts = {short_repr(counts)}: a {dim}D pack takes {form}, "
            f"{dim - 1} count(s), not {len(counts)}",
            parameter="counts",
            value=short_repr(counts),
            expected=f"{form}, integers >= 1",
        )
    bound = max(1, MAX_TILED_PARTICLES // max(n, 1))
    out = []
    for name, c in zip(names, counts, strict=True):
        if isinstance(c, bool) or not isinstance(c, Integral | np.integer):
            raise InvalidParameterError(
                f"invalid {name} = {short_repr(c)} in counts: must be an integer in [1, {bound}]",
                parameter="counts",
                value=short_repr(counts),
                expected=f"{form}, integers in [1, {bound}]",
            )
        if not 1 <= int(c) <= bound:
            raise InvalidParameterError(
                f"invalid {name} = {int(c)} in counts: must lie in [1, {bound}] (at most "
                f"{MAX_TILED_PARTICLES:.0e} particles in all, from {n} per copy)",
                parameter="counts",
                value=short_repr(counts),
                expected=f"{form}, integers in [1, {bound}]",
            )
        out.append(int(c))
    total = n * math.prod(out)
    if total > MAX_TILED_PARTICLES:
        raise InvalidParameterError(
            f"invalid counts = {tuple(out)}: {n} particles times {math.prod(out)} copies "
            f"gives {total}, beyond the {MAX_TILED_PARTICLES:.0e} particles a tiled pack "
            f"may hold; counts must keep nx{' ny' if dim == 3 else ''} N <= "
            f"{MAX_TILED_PARTICLES:.0e}",
            parameter="counts",
            value=tuple(out),
            expected=f"nx{' ny' if dim == 3 else ''} <= {bound}",
        )
    return tuple(out)


def _check_memory(pack: Pack, copies: int, reps: tuple[int, ...]) -> None:
    """Refuses, before any work, a tiled pack that would not fit in 80 % of the memory
    this process may use (`granpack._memory.memory_limit`: the machine's, RLIMIT_AS's or
    the control group's, the smallest)."""
    limit = memory_limit()
    if limit is None:  # cannot tell
        return
    total = limit.bytes
    arrays = [pack.positions, pack.radii, pack.velocities, pack.spins, pack.layer]
    arrays += list(pack.contacts.to_dict().values())
    per_copy = sum(np.asarray(a).nbytes for a in arrays)
    need = _WORK_FACTOR * per_copy * copies
    if need > 0.8 * total:
        raise InvalidParameterError(
            f"invalid counts = {reps}: {copies} copies of {per_copy / 2**20:.3g} MiB "
            f"(~{need / 2**30:.2f} GiB to build) would not fit in {limit.source} "
            f"({total / 2**30:.2f} GiB); give smaller counts",
            parameter="counts",
            value=reps,
            expected=f"at most {max(1, int(0.8 * total / (_WORK_FACTOR * per_copy)))} copies",
        )


def _wrap(x: np.ndarray, period: float) -> np.ndarray:
    """Coordinates mapped into [0, period) (those already inside are unchanged)."""
    w = np.mod(x, period)
    w[w >= period] = 0.0  # a tiny negative coordinate rounds up to the period
    return w


def _tiled_contacts(
    c: Contacts,
    x: np.ndarray,
    periods: np.ndarray,
    reps: tuple[int, ...],
    cell: np.ndarray,
    n: int,
) -> Contacts:
    """The contacts of every copy: a pair's partner is the copy of j at x_i + branch."""
    copies = len(cell)
    dim = x.shape[1]
    i = np.asarray(c.i, dtype=np.int64)
    j = np.asarray(c.j, dtype=np.int64)
    wall = j < 0
    base_copy = (np.arange(copies, dtype=np.int64) * n)[:, None]

    # particle pairs: the copy of j lies `shift` cells over from that of i
    pi, pj = i[~wall], j[~wall]
    branch = np.asarray(c.branch, dtype=np.float64)[~wall]
    shift = np.rint((x[pi, : dim - 1] + branch[:, : dim - 1] - x[pj, : dim - 1]) / periods)
    shift = shift.astype(np.int64)
    partner = np.zeros((copies, len(pi)), dtype=np.int64)
    stride = 1
    for h, r in enumerate(reps):
        partner += ((cell[:, h : h + 1] + shift[None, :, h]) % r) * stride
        stride *= r
    ii = (pi[None, :] + base_copy).ravel()
    jj = (pj[None, :] + partner * n).ravel()
    m = len(pi)

    def rows(col: str, mask: np.ndarray) -> np.ndarray:
        a = np.asarray(getattr(c, col))[mask]
        return np.tile(a, (copies,) + (1,) * (a.ndim - 1))

    normal = rows("normal", ~wall)
    branch_t = rows("branch", ~wall)
    ft = rows("force_tangential", ~wall)
    # a pair listed with i > j is turned round (the engine lists i < j): the normal and
    # branch point the other way, and the tangential force on the new j is the reaction
    flip = ii > jj
    ii[flip], jj[flip] = jj[flip], ii[flip]
    normal[flip] *= -1.0
    branch_t[flip] *= -1.0
    ft[flip] *= -1.0
    order = np.lexsort((jj, ii))
    pairs = {
        "i": ii[order],
        "j": jj[order],
        "normal": normal[order],
        "overlap": rows("overlap", ~wall)[order],
        "force_normal": rows("force_normal", ~wall)[order],
        "force_tangential": ft[order],
        "branch": branch_t[order],
    }
    assert len(pairs["i"]) == copies * m

    # wall contacts: copied with their particle
    wi = (i[wall][None, :] + base_copy).ravel()
    wj = np.tile(j[wall], copies)
    order = np.lexsort((-wj, wi))
    walls = {
        "i": wi[order],
        "j": wj[order],
        **{
            col: rows(col, wall)[order]
            for col in ("normal", "overlap", "force_normal", "force_tangential", "branch")
        },
    }
    return Contacts.from_dict({k: np.concatenate([pairs[k], walls[k]]) for k in pairs})
