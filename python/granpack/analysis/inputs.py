"""Coercion and checks of what the analysis is given: particles, contacts, box."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from .. import _core
from .._validate import GranpackError, InvalidParameterError
from ..contacts import Contacts

#: Wall ids of the contact table (j < 0).
_MIN_WALL_ID = -5


def _as_contacts(contacts, n: int, d: int) -> Contacts:
    if isinstance(contacts, Contacts):
        cols = contacts.to_dict()
    elif isinstance(contacts, Mapping):
        cols = dict(contacts)
    else:
        raise InvalidParameterError(
            f"invalid contacts = {type(contacts).__name__}: expected granpack.Contacts or a "
            "dict of arrays (i, j, normal, and optionally force_normal, force_tangential)"
        )
    for key in ("i", "j", "normal"):
        if key not in cols:
            raise InvalidParameterError(f"invalid contacts: missing column {key!r}")
    try:
        i = np.asarray(cols["i"])
        j = np.asarray(cols["j"])
        normal = np.asarray(cols["normal"], dtype=float)
    except (TypeError, ValueError) as exc:
        raise InvalidParameterError(f"invalid contacts: {exc}") from None
    m = i.shape[0] if i.ndim == 1 else -1
    if m < 0 or j.shape != (m,) or normal.shape != (m, d):
        raise InvalidParameterError(
            f"invalid contacts: shapes i {i.shape}, j {j.shape}, normal {normal.shape}; "
            f"expected (M,), (M,), (M, {d})"
        )
    for name, arr in (("i", i), ("j", j)):
        if m and not np.issubdtype(arr.dtype, np.integer):
            raise InvalidParameterError(
                f"invalid contacts.{name}: dtype {arr.dtype}, expected integers"
            )
    i = i.astype(np.int64)
    j = j.astype(np.int64)
    if m and (i.min() < 0 or i.max() >= n):
        raise InvalidParameterError(
            f"invalid contacts.i: particle indices must lie in [0, {n - 1}]"
        )
    if m and (j.min() < _MIN_WALL_ID or j.max() >= n):
        raise InvalidParameterError(
            f"invalid contacts.j: must lie in [0, {n - 1}] or be a wall id -1..-5"
        )
    if m and np.any(i == j):
        k = int(np.argmax(i == j))
        raise InvalidParameterError(
            f"invalid contacts: contact {k} joins particle {int(i[k])} to itself (i == j)"
        )
    if m:
        # a pair listed twice (as (i, j) or (j, i)) would count twice in Z and the fabric
        lo_ = np.where(j >= 0, np.minimum(i, j), i)
        hi_ = np.where(j >= 0, np.maximum(i, j), j)
        pairs = np.unique(np.stack([lo_, hi_], axis=1), axis=0, return_counts=True)
        if np.any(pairs[1] > 1):
            a, b = pairs[0][int(np.argmax(pairs[1] > 1))]
            raise InvalidParameterError(
                f"invalid contacts: the pair ({int(a)}, {int(b)}) is listed more than once"
            )
    zeros_d = np.zeros((m, d))
    full = {
        "i": i,
        "j": j,
        "normal": normal,
        "overlap": np.asarray(cols.get("overlap", np.zeros(m)), dtype=float),
        "force_normal": np.asarray(cols.get("force_normal", np.zeros(m)), dtype=float),
        "force_tangential": np.asarray(cols.get("force_tangential", zeros_d), dtype=float),
        "branch": np.asarray(cols.get("branch", zeros_d), dtype=float),
    }
    if full["force_normal"].shape != (m,) or full["force_tangential"].shape != (m, d):
        raise InvalidParameterError(
            f"invalid contacts: force_normal {full['force_normal'].shape}, force_tangential "
            f"{full['force_tangential'].shape}; expected ({m},), ({m}, {d})"
        )
    for key in ("normal", "force_normal", "force_tangential"):
        if not np.all(np.isfinite(full[key])):
            raise InvalidParameterError(f"invalid contacts.{key}: non-finite values")
    if m and np.min(full["force_normal"]) < 0.0:
        k = int(np.argmin(full["force_normal"]))
        raise InvalidParameterError(
            f"invalid contacts.force_normal[{k}] = {full['force_normal'][k]}: must be >= 0 (N)"
        )
    if m and np.any(np.linalg.norm(normal, axis=1) == 0.0):
        raise InvalidParameterError("invalid contacts.normal: a row has zero length")
    return Contacts.from_dict(full)


def _as_box(box, d: int):
    try:
        lo, hi = box
        lo = np.asarray(lo, dtype=float).ravel()
        hi = np.asarray(hi, dtype=float).ravel()
    except (TypeError, ValueError):
        raise InvalidParameterError(
            f"invalid box = {box!r}: expected (lo, hi), each a sequence of {d} lengths (m)"
        ) from None
    if lo.shape != (d,) or hi.shape[0] not in (d - 1, d):
        raise InvalidParameterError(
            f"invalid box: lo has {lo.shape[0]} values and hi {hi.shape[0]}; expected {d} and "
            f"{d} (hi's vertical value is ignored: the top is H_top) or {d - 1}"
        )
    hi = hi[: d - 1]
    if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi)) and np.all(hi > lo[:-1])):
        raise InvalidParameterError(
            f"invalid box: lo = {lo.tolist()}, hi = {hi.tolist()}; need finite hi > lo (m)"
        )
    return lo, hi


def _as_particles(positions, radii):
    try:
        x = np.asarray(positions, dtype=float)
        r = np.asarray(radii, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InvalidParameterError(f"invalid positions/radii: {exc}") from None
    if x.ndim != 2 or x.shape[1] not in (2, 3):
        raise InvalidParameterError(
            f"invalid positions: shape {x.shape}, expected (N, 2) or (N, 3)"
        )
    if x.shape[0] == 0:
        raise InvalidParameterError("invalid positions: no particles (N = 0)")
    if r.shape != (x.shape[0],):
        raise InvalidParameterError(f"invalid radii: shape {r.shape}, expected ({x.shape[0]},)")
    if not np.all(np.isfinite(x)):
        raise InvalidParameterError("invalid positions: non-finite values")
    if not (np.all(np.isfinite(r)) and np.all(r > 0)):
        k = int(np.argmin(np.where(np.isfinite(r), r, -np.inf)))
        raise InvalidParameterError(f"invalid radii[{k}] = {r[k]}: must be finite and > 0 (m)")
    return np.ascontiguousarray(x), np.ascontiguousarray(r)


def _check_overlaps(pairs: Contacts, r: np.ndarray) -> None:
    """Refuses interpenetrating particles: an overlap beyond the smaller radius puts a
    centre inside the other particle, and phi and Z then mean nothing (phi above 1)."""
    if len(pairs) == 0:
        return
    ratio = pairs.overlap / np.minimum(r[pairs.i], r[pairs.j])
    k = int(np.argmax(ratio))
    if ratio[k] > 1.0:
        i, j = int(pairs.i[k]), int(pairs.j[k])
        raise InvalidParameterError(
            f"invalid positions: particles {i} and {j} overlap by {pairs.overlap[k]:.4g} m, "
            f"more than the smaller radius {min(r[i], r[j]):.4g} m (overlap ratio "
            f"{ratio[k]:.3g}; at most 1): not a valid pack"
        )


def _find_contacts(x, r, walls) -> Contacts:
    try:
        found = _core.find_contacts(x, r, walls=walls)
    except GranpackError as exc:
        hint = ""
        if "max_overlap_ratio" in str(exc):
            # find_contacts reuses the engine's blow-up guard; for analysis it only means
            # that two particles interpenetrate by a radius or more
            hint = " (two particles overlap by the smaller radius or more: not a valid pack)"
        raise GranpackError(
            f"cannot find the contacts of the given positions/radii: {exc}{hint}"
        ) from None
    return Contacts.from_dict(found)


def find_container_contacts(x, r, container) -> Contacts:
    """Geometric contacts (overlap > 0, forces zero) of particles in a container, from the
    Rust cell grid (``granpack._core.find_contacts``): the box's walls; along a periodic axis
    the minimum image (pairs across the seam, no walls); in a cylinder the floor (j = -1)
    and the cylinder wall (j = -2)."""
    lo, hi = container.lo, container.hi
    walls = (lo.tolist(), hi.tolist())
    if container.kind == "box":
        return _find_contacts(x, r, walls)
    kwargs: dict = {}
    if container.radius is not None:
        kwargs["cylinder"] = float(container.radius)
    else:
        kwargs["periodic"] = list(container.periodic)
    try:
        found = _core.find_contacts(x, r, walls=walls, **kwargs)
    except GranpackError as exc:
        cls = InvalidParameterError if isinstance(exc, InvalidParameterError) else GranpackError
        raise cls(f"cannot find the contacts of the given positions/radii: {exc}") from None
    return Contacts.from_dict(found)
