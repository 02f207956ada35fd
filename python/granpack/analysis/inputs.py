"""Coercion and checks of what the analysis is given: particles, contacts, box."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from .. import _core
from .._validate import FileFormatError, GranpackError, InvalidParameterError
from ..contacts import LID_ID, WALL_IDS, Contacts

#: Largest coordinate the analysis takes (m): the cube of a span of 2e100 m is still a
#: finite volume.
MAX_COORDINATE = 1e100
#: Wall ids of the contact table (j < 0).
_MIN_WALL_ID = -6


def _as_contacts(contacts, n: int, d: int) -> Contacts:
    if isinstance(contacts, Contacts):
        cols = contacts.to_dict()
    elif isinstance(contacts, Mapping):
        cols = dict(contacts)
    else:
        raise InvalidParameterError(
            f"invalid contacts = {type(contacts).__name__}: expected granpack.Contacts or a "
            "dict of arrays (i, j, normal, and optionally force_normal, force_tangential)",
            parameter="contacts",
        )
    for key in ("i", "j", "normal"):
        if key not in cols:
            raise InvalidParameterError(
                f"invalid contacts: missing column {key!r}", parameter="contacts"
            )
    try:
        i = np.asarray(cols["i"])
        j = np.asarray(cols["j"])
        normal = np.asarray(cols["normal"], dtype=float)
    except (TypeError, ValueError) as exc:
        raise InvalidParameterError(f"invalid contacts: {exc}", parameter="contacts") from None
    m = i.shape[0] if i.ndim == 1 else -1
    if m < 0 or j.shape != (m,) or normal.shape != (m, d):
        raise InvalidParameterError(
            f"invalid contacts: shapes i {i.shape}, j {j.shape}, normal {normal.shape}; "
            f"expected (M,), (M,), (M, {d})",
            parameter="contacts",
        )
    for name, arr in (("i", i), ("j", j)):
        if m and not np.issubdtype(arr.dtype, np.integer):
            raise InvalidParameterError(
                f"invalid contacts.{name}: dtype {arr.dtype}, expected integers",
                parameter=f"contacts.{name}",
            )
    i = i.astype(np.int64)
    j = j.astype(np.int64)
    if m and (i.min() < 0 or i.max() >= n):
        raise InvalidParameterError(
            f"invalid contacts.i: particle indices must lie in [0, {n - 1}]", parameter="contacts.i"
        )
    if m and (j.min() < _MIN_WALL_ID or j.max() >= n):
        raise InvalidParameterError(
            f"invalid contacts.j: must lie in [0, {n - 1}] or be a wall id -1..-6",
            parameter="contacts.j",
        )
    if m and np.any(i == j):
        k = int(np.argmax(i == j))
        raise InvalidParameterError(
            f"invalid contacts: contact {k} joins particle {int(i[k])} to itself (i == j)",
            parameter="contacts",
        )
    if m:
        # a pair listed twice (as (i, j) or (j, i)) would count twice in Z and the fabric
        lo_ = np.where(j >= 0, np.minimum(i, j), i)
        hi_ = np.where(j >= 0, np.maximum(i, j), j)
        pairs = np.unique(np.stack([lo_, hi_], axis=1), axis=0, return_counts=True)
        if np.any(pairs[1] > 1):
            a, b = pairs[0][int(np.argmax(pairs[1] > 1))]
            raise InvalidParameterError(
                f"invalid contacts: the pair ({int(a)}, {int(b)}) is listed more than once",
                parameter="contacts",
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
            f"{full['force_tangential'].shape}; expected ({m},), ({m}, {d})",
            parameter="contacts",
        )
    for key in ("normal", "force_normal", "force_tangential"):
        if not np.all(np.isfinite(full[key])):
            raise InvalidParameterError(
                f"invalid contacts.{key}: non-finite values", parameter=f"contacts.{key}"
            )
    if m and np.min(full["force_normal"]) < 0.0:
        k = int(np.argmin(full["force_normal"]))
        raise InvalidParameterError(
            f"invalid contacts.force_normal[{k}] = {full['force_normal'][k]}: must be >= 0 (N)",
            parameter=f"contacts.force_normal[{k}]",
        )
    if m and np.any(np.linalg.norm(normal, axis=1) == 0.0):
        raise InvalidParameterError(
            "invalid contacts.normal: a row has zero length", parameter="contacts.normal"
        )
    return Contacts.from_dict(full)


def _as_box(box, d: int):
    try:
        lo, hi = box
        lo = np.asarray(lo, dtype=float).ravel()
        hi = np.asarray(hi, dtype=float).ravel()
    except (TypeError, ValueError):
        raise InvalidParameterError(
            f"invalid box = {box!r}: expected (lo, hi), each a sequence of {d} lengths (m)",
            parameter="box",
        ) from None
    if lo.shape != (d,) or hi.shape[0] not in (d - 1, d):
        raise InvalidParameterError(
            f"invalid box: lo has {lo.shape[0]} values and hi {hi.shape[0]}; expected {d} and "
            f"{d} (hi's vertical value is ignored: the top is H_top) or {d - 1}",
            parameter="box",
        )
    hi = hi[: d - 1]
    if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi)) and np.all(hi > lo[:-1])):
        raise InvalidParameterError(
            f"invalid box: lo = {lo.tolist()}, hi = {hi.tolist()}; need finite hi > lo (m)",
            parameter="box",
        )
    return lo, hi


def _as_particles(positions, radii):
    try:
        x = np.asarray(positions, dtype=float)
        r = np.asarray(radii, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InvalidParameterError(
            f"invalid positions/radii: {exc}", parameter="positions"
        ) from None
    if x.ndim != 2 or x.shape[1] not in (2, 3):
        raise InvalidParameterError(
            f"invalid positions: shape {x.shape}, expected (N, 2) or (N, 3)", parameter="positions"
        )
    if x.shape[0] == 0:
        raise InvalidParameterError(
            "invalid positions: no particles (N = 0)", parameter="positions"
        )
    if r.shape != (x.shape[0],):
        raise InvalidParameterError(
            f"invalid radii: shape {r.shape}, expected ({x.shape[0]},)", parameter="radii"
        )
    if not np.all(np.isfinite(x)):
        raise InvalidParameterError("invalid positions: non-finite values", parameter="positions")
    if np.max(np.abs(x)) > MAX_COORDINATE:
        k = int(np.argmax(np.max(np.abs(x), axis=1)))
        raise InvalidParameterError(
            f"invalid positions[{k}] = {x[k].tolist()}: coordinates must lie within "
            f"+-{MAX_COORDINATE:g} m (beyond it the container's volume overflows)",
            parameter="positions",
        )
    if not (np.all(np.isfinite(r)) and np.all(r > 0)):
        k = int(np.argmin(np.where(np.isfinite(r), r, -np.inf)))
        raise InvalidParameterError(
            f"invalid radii[{k}] = {r[k]}: must be finite and > 0 (m)", parameter=f"radii[{k}]"
        )
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
            f"{ratio[k]:.3g}; at most 1): not a valid pack",
            parameter="positions",
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


# -- contacts against the particles --------------------------------------------------------

#: A listed contact may leave a gap of this fraction of the smaller radius between the
#: two surfaces (or the surface and the wall), beyond what the positions' printed
#: precision allows.
CONTACT_GAP_TOLERANCE = 1e-6
#: A listed contact that carries no force (every force component zero) may leave a gap of
#: this fraction of the smaller radius: the verge contacts that the DEM codes list at
#: zero force. YADE keeps such interactions in its list, and computes the forces before
#: it moves the spheres, so a pair at a step lies apart by up to a step's relative
#: travel: up to 6.9e-6 r in YADE's 4.3 pack after its fourth layer, 6.7e-4 r in a
#: layer still falling (LAMMPS and LIGGGHTS list no pair at zero force in their dump
#: local with `cutoff radius`). A DEM step's travel stays well below the contact
#: overlaps (a few 1e-3 r) for the run to be stable, so 1e-2 r bounds it, while a pair
#: of another step or numbering lies a good part of a radius apart.
VERGE_GAP_TOLERANCE = 1e-2
#: The fewest significant digits a text file is taken to print its numbers with: C's
#: %g (LAMMPS' and LIGGGHTS' dump default, YADE's export.text). A file whose numbers are
#: all short (a lattice of integers written with %.17g prints "1") tells no coarser
#: format, and is not given the tolerance of a one-digit one.
MIN_PRINTED_DIGITS = 6
# the values _digits looks at: an even stride through larger arrays
_DIGITS_SAMPLE = 200_000


def _digits(values) -> int:
    """The fewest significant decimal digits (1 to 12) that give every value to a relative
    1e-12: the precision a text file printed them with (6 for LAMMPS' default %g). 17
    where no such count does (binary data, or values computed from printed ones)."""
    a = np.abs(np.asarray(values, dtype=float).ravel())
    a = a[np.isfinite(a) & (a > 1e-280) & (a < 1e280)]
    if a.size > _DIGITS_SAMPLE:
        a = a[:: a.size // _DIGITS_SAMPLE + 1]
    if a.size == 0:
        return 17
    e = np.floor(np.log10(a))
    for p in range(1, 13):
        scale = 10.0 ** (p - 1 - e)
        y = np.round(a * scale) / scale
        if np.all(np.abs(y - a) <= 1e-12 * a):
            return p
    return 17


def _resolution(values, p: int) -> np.ndarray:
    """Half a unit in the last of `p` significant digits of each value (0 for p = 17)."""
    a = np.abs(np.asarray(values, dtype=float))
    if p > 12:
        return np.zeros_like(a)
    with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
        e = np.floor(np.log10(np.where(a > 0.0, a, 1.0)))
        out = np.where(a > 0.0, 0.5 * 10.0 ** (e - p + 1), 0.0)
    return np.where(np.isfinite(out), out, 0.0)


def _float32_resolution(values) -> np.ndarray:
    """Half a float32 unit in the last place of each value where every value is a float32
    (positions stored or computed in single precision), else 0."""
    a = np.asarray(values, dtype=float)
    with np.errstate(over="ignore", invalid="ignore"):
        single = a.astype(np.float32)
        if not np.array_equal(single.astype(float), a):
            return np.zeros_like(a)
        return 0.5 * np.spacing(np.abs(single)).astype(float)


def written_digits(words) -> int:
    """The most significant digits among numbers as a text file wrote them (``0.0125``
    has 3, ``1.2500e-02`` 5, ``7`` 1): the precision of the file's format, as far as its
    text shows it. 17 for an empty list. Looks at an even stride of at most
    200 000 words."""
    if len(words) == 0:
        return 17
    if len(words) > _DIGITS_SAMPLE:
        words = words[:: len(words) // _DIGITS_SAMPLE + 1]
    best = 1
    for w in words:
        mant = w.lstrip("+-").split("e", 1)[0].split("E", 1)[0]
        n = sum(c.isdigit() for c in mant.replace(".", "").lstrip("0"))
        if n > best:
            best = n
            if best >= 17:
                return 17
    return best


def verge_note(n: int, widest: float) -> str:
    """The note of `n` contacts without force taken at a gap (the widest `widest`, m)."""
    return (
        f"{n} listed contact{'s' if n > 1 else ''} without force lie apart by up to "
        f"{widest:.3g} m (verge contacts, as YADE keeps an interaction until its collider's "
        "next pass): counted as the file lists them"
    )


def printed_digits(x, r, digits: int | None = None) -> int:
    """The significant digits the contact check takes positions and radii to be printed
    with: `digits` (what a text file's words show, `written_digits`) where given, else
    what the values need (`_digits`); never fewer than `MIN_PRINTED_DIGITS`."""
    p = digits if digits is not None else max(_digits(x), _digits(r))
    return max(int(p), MIN_PRINTED_DIGITS)


def _position_resolution(x: np.ndarray, box, p: int) -> np.ndarray:
    """(N, D) how far each coordinate may lie from the value the file meant: half a unit
    in the last of `p` printed digits, or in the last digit of the fractions of the box
    (LAMMPS' scaled coordinates xs, ys, zs), whichever the file printed."""
    res = np.maximum(_resolution(x, p), _float32_resolution(x))
    if box is not None:
        try:
            lo = np.asarray(box[0], dtype=float).ravel()
            hi = np.asarray(box[1], dtype=float).ravel()
        except (TypeError, ValueError, IndexError):
            return res
        d = x.shape[1]
        if lo.shape == (d,) and hi.shape == (d,):
            size = hi - lo
            ok = np.isfinite(size) & (size > 0.0)
            if np.any(ok):
                s = (x[:, ok] - lo[ok]) / size[ok]
                p = max(_digits(s), MIN_PRINTED_DIGITS)
                if p <= 12:
                    res[:, ok] = np.maximum(res[:, ok], _resolution(s, p) * size[ok])
    return res


def check_contacts_touch(
    i,
    j,
    x,
    r,
    *,
    container=None,
    periods=None,
    walls: bool = False,
    box=None,
    path=None,
    lines=None,
    ids=None,
    what: str = "contacts",
    file_periods=None,
    force=None,
    digits: int | None = None,
) -> tuple[int, float]:
    """Refuses contacts whose two particles (or particle and wall) do not touch: the one
    check of every contact table the analysis is given, read from a file or passed as
    arrays, so that contacts of another run, step or numbering never count.

    A pair is a contact where |x_j - x_i| (the minimum image across periodic axes) is at
    most r_i + r_j plus a tolerance: `CONTACT_GAP_TOLERANCE` of the smaller radius
    (`VERGE_GAP_TOLERANCE` for a contact that carries no force, `force`), plus what the
    precision of the positions and radii allows (half a unit in the last printed digit:
    the digits the file's text shows, `digits`, else those the values need, never fewer
    than `MIN_PRINTED_DIGITS`; half a float32 unit where every value is a float32), plus
    rounding. A contact that carries force across a gap wider than the first tolerance
    is refused, whatever its force. A wall contact
    (j < 0) is checked against the wall's distance where the walls are known (`walls`,
    with `container`): the floor, a box side, the cylinder; a wall id that this
    container does not have is refused.

    Parameters
    ----------
    i, j : (M,) int
        Rows of `x`; j < 0 a wall (-1 floor, -2..-5 box sides, -2 the cylinder).
    x, r : (N, D), (N,)
        Centres and radii (m).
    container : Container, optional
        Its periodic axes give the minimum image; its walls are checked if `walls`.
    periods : (D,) float, optional
        Without a container: the period of each axis (inf where none).
    box : (lo, hi), optional
        The box the positions were written in (to recognise scaled coordinates).
    path : Path, optional
        The file the contacts came from: the error is then a FileFormatError naming it
        (with `lines`, the line of each contact; `ids`, the particles' ids there).
        Otherwise an InvalidParameterError naming `what`.
    file_periods : (D,) float, optional
        The periods the positions' file declares (inf where none): a pair that touches
        only across one the container does not repeat (a dump's periodic vertical axis)
        is named as such.
    force : (M,) bool or float, optional
        Whether each contact carries force (nonzero: it does). Default None: unknown,
        every contact held to the strict tolerance.
    digits : int, optional
        The significant digits the positions' and radii's text shows
        (`written_digits`). Default None: counted from the values.

    Returns
    -------
    (int, float)
        How many contacts without force were taken at a gap beyond the strict tolerance
        (verge contacts), and the largest such gap (m; 0.0 where none).

    Raises
    ------
    FileFormatError or InvalidParameterError
        Naming the first contact that is none, its particles and the gap, and how many
        contacts are apart.
    """
    i = np.asarray(i, dtype=np.int64)
    j = np.asarray(j, dtype=np.int64)
    m = i.shape[0]
    if m == 0:
        return 0, 0.0
    x = np.asarray(x, dtype=float)
    r = np.asarray(r, dtype=float)
    n, d = x.shape
    if container is not None:
        periods = container.periods
    per = np.full(d, np.inf) if periods is None else np.asarray(periods, dtype=float)
    finite = np.isfinite(per)
    # one count of digits for positions and radii (a file prints them alike; round
    # values, such as one radius for all, have fewer than the file printed)
    digits = printed_digits(x, r, digits)
    res_x = _position_resolution(x, box, digits)
    res_r = np.maximum(_resolution(r, digits), _float32_resolution(r))
    big = float(np.max(np.abs(x))) + float(np.max(r)) + float(np.max(per[finite], initial=0.0))
    rounding = 64.0 * np.finfo(float).eps * big

    gap = np.full(m, -np.inf)
    tol = np.zeros(m)
    dist = np.zeros(m)
    wall_missing = np.zeros(m, dtype=bool)
    pair = j >= 0
    if np.any(pair):
        a, b = i[pair], j[pair]
        dx = x[b] - x[a]
        if np.any(finite):
            dx[:, finite] -= per[finite] * np.round(dx[:, finite] / per[finite])
        dd = np.linalg.norm(dx, axis=1)
        dist[pair] = dd
        gap[pair] = dd - (r[a] + r[b])
        tol[pair] = (
            CONTACT_GAP_TOLERANCE * np.minimum(r[a], r[b])
            + 2.0 * (res_x[a].sum(axis=1) + res_x[b].sum(axis=1) + res_r[a] + res_r[b])
            + rounding
        )
    if walls and container is not None and np.any(~pair):
        wall = ~pair
        q, w = i[wall], j[wall]
        xq = x[q]
        to_wall = np.full(q.shape[0], np.nan)
        res_w = np.zeros(q.shape[0])
        lo, hi = container.lo, container.hi
        bounds = np.concatenate([lo, hi[:-1]])
        res_b = _resolution(bounds, max(digits, _digits(bounds)))
        floor = w == -1
        to_wall[floor] = xq[floor, -1] - lo[-1]
        res_w[floor] = res_x[q[floor], -1] + res_b[d - 1]
        if container.lid:
            top = w == LID_ID
            to_wall[top] = hi[-1] - xq[top, -1]
            res_w[top] = res_x[q[top], -1] + res_b[d - 1]
        if container.radius is not None:
            cyl = w == -2
            off = xq[cyl, :2] - container.axis
            to_wall[cyl] = container.radius - np.linalg.norm(off, axis=1)
            res_w[cyl] = res_x[q[cyl], 0] + res_x[q[cyl], 1] + 2.0 * res_b[0]
        else:
            for k in range(d - 1):
                if container.periodic[k]:
                    continue
                for wid, dist_k, rb in (
                    (-2 - 2 * k, xq[:, k] - lo[k], res_b[k]),
                    (-3 - 2 * k, hi[k] - xq[:, k], res_b[d + k]),
                ):
                    sel = w == wid
                    to_wall[sel] = dist_k[sel]
                    res_w[sel] = res_x[q[sel], k] + rb
        wall_missing[wall] = np.isnan(to_wall)
        dist[wall] = np.where(np.isnan(to_wall), 0.0, to_wall)
        gap[wall] = np.where(np.isnan(to_wall), np.inf, to_wall - r[q])
        tol[wall] = CONTACT_GAP_TOLERANCE * r[q] + 2.0 * (res_w + res_r[q]) + rounding
    strict = gap > tol
    verge = np.zeros(m, dtype=bool)
    if force is not None:
        idle = np.asarray(force) == 0
        smaller = np.where(pair, np.minimum(r[i], r[np.maximum(j, 0)]), r[i])
        verge = (
            strict & idle & (gap <= tol + (VERGE_GAP_TOLERANCE - CONTACT_GAP_TOLERANCE) * smaller)
        )
    bad = strict & ~verge
    if not np.any(bad):
        n_verge = int(np.sum(verge))
        return n_verge, float(np.max(gap[verge])) if n_verge else 0.0
    k = int(np.argmax(bad))
    n_bad = int(np.sum(bad))
    count = f"{n_bad} of {m} contacts" if n_bad > 1 else f"1 of {m} contacts"

    def name(q: int) -> str:
        return str(int(ids[q])) if ids is not None else str(q)

    who = "particle id" if ids is not None else "particle"
    a, b = int(i[k]), int(j[k])
    if b >= 0:
        carries = force is not None and np.asarray(force)[k] != 0
        what_k = (
            f"{who}s {name(a)} and {name(b)} do not touch: their surfaces are "
            f"{gap[k]:.6g} m apart (centres {dist[k]:.6g} m apart"
            f"{' by minimum image' if np.any(finite) else ''}, r_i + r_j = "
            f"{r[a] + r[b]:.6g} m; at most {tol[k]:.2g} m allowed"
            + (
                " for a contact that carries force"
                if carries
                else (
                    f", {VERGE_GAP_TOLERANCE:g} of the smaller radius more without force"
                    if force is not None
                    else ""
                )
            )
            + ")"
        )
        if file_periods is not None:
            fp = np.asarray(file_periods, dtype=float)
            extra = np.isfinite(fp) & ~finite
            if np.any(extra):
                dxf = x[b] - x[a]
                on = np.isfinite(fp) | finite
                both = np.where(np.isfinite(fp), fp, per)
                dxf[on] -= both[on] * np.round(dxf[on] / both[on])
                if np.linalg.norm(dxf) - (r[a] + r[b]) <= tol[k]:
                    axes = ", ".join("xyz"[q] for q in np.flatnonzero(extra))
                    what_k += (
                        f"; they touch across the file's periodic {axes} side, which the "
                        "analysis does not repeat (it bounds the vertical axis by the floor "
                        "and the open top)"
                    )
    elif wall_missing[k]:
        kind = container.kind if container is not None else "box"
        what_k = (
            f"{who} {name(a)} touches wall id {b}, which the {kind} container does not have "
            f"(its walls: {', '.join(str(v) for v in container.wall_ids())})"
        )
    else:
        wall_name = (
            "the cylinder wall"
            if container.radius is not None and b == -2
            else f"the {WALL_IDS.get(b, str(b))} wall"
        )
        what_k = (
            f"{who} {name(a)} does not touch {wall_name} (wall id {b}): its surface is "
            f"{gap[k]:.6g} m from it (centre {dist[k]:.6g} m, radius {r[a]:.6g} m; at most "
            f"{tol[k]:.2g} m allowed)"
        )
    if path is not None:
        where = f"{path}:{int(lines[k])}" if lines is not None else f"{path}"
        reason = (
            f"contact {k} is no contact: {what_k}; {count} are apart: the contacts and the "
            "particles come from different runs, steps or numberings"
        )
        raise FileFormatError(f"{where}: {reason}", path=path, reason=reason)
    raise InvalidParameterError(
        f"invalid {what}: contact {k} is no contact: {what_k}; {count} are apart: the "
        "contacts do not belong to these positions and radii",
        parameter=what,
    )
