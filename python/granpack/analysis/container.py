"""The container a pack lies in: the walled box, the laterally periodic cell or the vertical
cylinder. Its volume up to H_top, its core window, the minimum image of periodic axes, and the
wall ids of its contact table.

Containers
----------
- ``"box"``: floor and side walls at ``lo`` and ``hi`` (the paper's box).
- ``"periodic"``: the horizontal axes flagged in ``periodic`` repeat with periods
  ``hi - lo``; floor; open top. Branch vectors between particles are minimum images.
- ``"cylinder"``: 3D only; a vertical cylinder of radius R whose axis passes through
  (lo_x + R, lo_y + R); floor; open top.

The volume is taken up to H_top = max(z_i + r_i) in every case.

The container tag
-----------------
One line of ``key=value`` words that granpack's text exports carry, so that a pack read
back is analysed in the container it was made in (`Container.tag_words` writes it,
`Container.read_tag` and `Container.from_tag` read it)::

    container=<box|periodic|cylinder> [cylinder_radius=<R>] [lo=<x>,<y>[,<z>]] [hi=...]
        [lid=<z>]

A periodic cell analysed as a walled box gets branch vectors across the whole cell at the
seam; a cylinder analysed as its bounding box gets phi over the square. Formats that have a
place for the container keep it there (an extended XYZ file's ``pbc``, a dump's ``BOX
BOUNDS``); the tag adds what they cannot say (a cylinder's radius), and carries the whole
container in formats that have no place for it (YADE text, CSV, the LAMMPS data file,
whose title line holds it).

``lo`` and ``hi`` are the box corners (m; hi's vertical value is H_top); for the cylinder,
the square that holds it, its axis at lo + R. ``lid`` is the height (m, the vertical
coordinate) of the lid that closes a consolidated sample (`granpack.consolidate`): the
analysis then takes the sample up to the lid, not up to max(z + r), and counts the
particles that press on it as contacts with the lid (wall id -6). Side walls that a
consolidation moved are the box's corners themselves (the pack's box is the space between
them). The words may stand anywhere on the line, among others (``seed=...``) that the
parser skips.
"""

from __future__ import annotations

import dataclasses
import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import _core
from .._validate import FileFormatError, InvalidParameterError
from ..history import stage_table

__all__ = ["Container", "CONTAINERS", "ContainerTag", "wall_names"]

#: The container kinds, as the engine names them.
CONTAINERS = _core.CONTAINERS

_WORD = re.compile(r"(?<![\w.])(container|cylinder_radius|lo|hi|lid)=(\S+)")
# granpack's LAMMPS data files before the tag: "..., container cylinder radius 0.1)"
_OLD_DATA_TITLE = re.compile(r"container (box|periodic|cylinder)(?: radius ([^\s),]+))?")


def wall_names(kind: str, dim: int) -> list[str]:
    """The engine's walls of a generated pack's container (`kind` one of `CONTAINERS`,
    `dim` 2 or 3) in its order, the lid last: the floor, then x_lo, x_hi (and y_lo, y_hi
    in 3D) in a box, the cylinder's wall in a cylinder, none in a periodic cell. These are
    the walls a consolidation moves and reports (wall ids -1, -2, ... in that order, the
    lid -6)."""
    if kind == "cylinder":
        return ["floor", "cylinder", "lid"]
    if kind == "periodic":
        return ["floor", "lid"]
    sides = ["x_lo", "x_hi"] + (["y_lo", "y_hi"] if dim == 3 else [])
    return ["floor", *sides, "lid"]


@dataclass(frozen=True)
class Container:
    """Geometry of a pack's container (SI units).

    Attributes
    ----------
    kind : str
        One of `CONTAINERS`.
    lo, hi : (D,) float64
        Lower and upper corners (m); ``hi[-1]`` is H_top. For the cylinder, the square
        [lo, lo + 2R] that holds it laterally.
    periodic : tuple of bool
        Per horizontal axis (D - 1 values): True where the axis repeats.
    radius : float or None
        Cylinder radius R (m); None for the box and the periodic cell.
    lid : bool
        Whether a lid closes the top at ``hi[-1]`` (a consolidated pack; wall id -6).
    """

    kind: str
    lo: np.ndarray
    hi: np.ndarray
    periodic: tuple[bool, ...]
    radius: float | None = None
    lid: bool = False

    @classmethod
    def from_scene(cls, scene, height: float = math.nan, lid: bool = False) -> Container:
        """The container a scene (`granpack.PackScene`) describes, in the one place that
        reads its description: ``scene.container`` (a name; "box" where the scene has
        none), ``scene.cylinder_radius`` (None: half the base) and ``scene.base``; the
        corners from 0 to (base, `height`), `height` being H_top (NaN where not known)."""
        kind = getattr(scene, "container", "box")
        base = tuple(float(b) for b in scene.base)
        d = len(base) + 1
        radius = None
        if kind == "cylinder":
            radius = getattr(scene, "cylinder_radius", None)
            radius = base[0] / 2.0 if radius is None else float(radius)
        lo = np.zeros(d)
        hi = np.array([*base, float(height)])
        return cls(kind, lo, hi, (kind == "periodic",) * (d - 1), radius, lid)

    @property
    def dim(self) -> int:
        return int(self.lo.shape[0])

    @property
    def height(self) -> float:
        """H_top - floor (m)."""
        return float(self.hi[-1] - self.lo[-1])

    @property
    def axis(self) -> np.ndarray | None:
        """(x, y) of the cylinder's axis (m); None for the other containers."""
        if self.radius is None:
            return None
        return self.lo[:2] + self.radius

    @property
    def base_area(self) -> float:
        """Cross-section (m^2 in 3D; m in 2D): pi R^2 for the cylinder, the product of the
        lateral extents otherwise."""
        if self.radius is not None:
            return math.pi * self.radius**2
        return float(np.prod(self.hi[:-1] - self.lo[:-1]))

    @property
    def volume(self) -> float:
        """Volume up to H_top (m^3; m^2 in 2D): base_area x (H_top - floor)."""
        return self.base_area * self.height

    @property
    def periods(self) -> np.ndarray:
        """(D,) period of each axis (m); inf where the axis does not repeat (the vertical
        axis never does)."""
        per = np.full(self.dim, np.inf)
        for k, p in enumerate(self.periodic):
            if p:
                per[k] = self.hi[k] - self.lo[k]
        return per

    @property
    def any_periodic(self) -> bool:
        return any(self.periodic)

    def minimum_image(self, dx) -> np.ndarray:
        """Difference vectors (..., D) mapped to their minimum image along the periodic axes
        (each component into [-L/2, L/2]); unchanged along the other axes."""
        dx = np.array(dx, dtype=float, copy=True)
        for k, p in enumerate(self.periodic):
            if p:
                period = self.hi[k] - self.lo[k]
                dx[..., k] -= period * np.round(dx[..., k] / period)
        return dx

    def wrap(self, x) -> np.ndarray:
        """Positions (N, D) mapped into [lo, hi) along the periodic axes."""
        x = np.array(x, dtype=float, copy=True)
        for k, p in enumerate(self.periodic):
            if p:
                period = self.hi[k] - self.lo[k]
                x[:, k] = self.lo[k] + np.mod(x[:, k] - self.lo[k], period)
        return x

    @classmethod
    def of_pack(cls, pack) -> Container:
        """The container of a generated pack (`granpack.Pack`, or anything with its
        ``scene``, ``height`` and ``consolidation``), as its exports write it and its
        pictures draw it: the scene's kind (a box where the scene names none), the pack's
        box (lo = 0, hi = (base, H_top), `Pack.box`), the lid of a consolidated pack at
        the top of that box, and a consolidated cylinder's radius where the consolidation
        left it (the scene's, or half its base, otherwise)."""
        rec = _consolidation_record(pack)
        c = cls.from_scene(pack.scene, float(getattr(pack, "height", math.nan)), rec is not None)
        if c.kind == "cylinder" and rec is not None and "cylinder" in rec["walls"]:
            return dataclasses.replace(c, radius=float(rec["walls"]["cylinder"]))
        return c

    @property
    def lid_height(self) -> float | None:
        """The height (m) of the lid that closes a consolidated sample (the top of the
        box, ``hi[-1]``); None for an open top."""
        return float(self.hi[-1]) if self.lid else None

    @property
    def wall_names(self) -> list[str]:
        """The engine's walls of this kind of container, the lid last (`wall_names`)."""
        return wall_names(self.kind, self.dim)

    def tag(self, corners: bool = True) -> ContainerTag:
        """The container tag of this container (with its corners, or without; with its
        lid where it has one)."""
        return ContainerTag.from_container(self, corners)

    def tag_words(self, corners: bool = True) -> str:
        """The container tag's words (full float precision: ``repr``): ``container=...``,
        the cylinder's radius, the corners (where `corners`) and the lid's height."""
        return self.tag(corners).words()

    @staticmethod
    def read_tag(text: str, path: Path, line: int, dim: int) -> ContainerTag | None:
        """The container tag a line `text` names (line number `line` of `path`, for
        messages), or None where it names none; what the file says, corners where it
        gives them. A tag that is there but wrong is a FileFormatError (see
        `ContainerTag.parse`)."""
        return ContainerTag.parse(text, path, line, dim)

    @classmethod
    def from_tag(
        cls, text: str, path: Path, line: int, dim: int, lo=None, hi=None
    ) -> Container | None:
        """The container a line `text` names, or None where it names none: its corners,
        or `lo` and `hi` (each (D,), m) where the tag gives none."""
        tag = ContainerTag.parse(text, path, line, dim)
        return None if tag is None else tag.to_container(lo, hi)

    def wall_ids(self) -> tuple[int, ...]:
        """The wall ids (j < 0) of this container's contact table: -1 the floor; in the
        box -2/-3 x-lo/x-hi and -4/-5 y-lo/y-hi; in the cylinder -2 its wall; a periodic
        cell only the floor (and the side walls of a non-periodic axis, as in the box)."""
        lid = (-6,) if self.lid else ()
        if self.radius is not None:
            return (-1, -2, *lid)
        ids = [-1]
        for k in range(self.dim - 1):
            if not self.periodic[k]:
                ids += [-2 - 2 * k, -3 - 2 * k]
        return (*ids, *lid)


def make_container(
    kind: str,
    lo,
    hi,
    periodic: tuple[bool, ...] | None,
    radius: float | None,
    lid: bool = False,
) -> Container:
    """Checks and builds a Container (``lo``, ``hi`` (D,) with hi[-1] = H_top)."""
    lo = np.asarray(lo, dtype=float)
    hi = np.asarray(hi, dtype=float)
    d = lo.shape[0]
    if kind not in CONTAINERS:
        raise InvalidParameterError(
            f"invalid container = {kind!r}: must be one of {', '.join(CONTAINERS)}",
            parameter="container",
        )
    if kind == "cylinder":
        if d != 3:
            raise InvalidParameterError(
                "invalid container = 'cylinder': a cylinder needs 3D positions",
                parameter="container",
            )
        if radius is None or not (math.isfinite(radius) and radius > 0.0):
            raise InvalidParameterError(
                f"invalid cylinder_radius = {radius!r}: must be finite and > 0 (m)",
                parameter="cylinder_radius",
            )
        return Container("cylinder", lo, hi, (False,) * (d - 1), float(radius), lid)
    if radius is not None:
        raise InvalidParameterError(
            f"invalid cylinder_radius = {radius!r}: only a cylinder has one (container is "
            f"{kind!r})",
            parameter="cylinder_radius",
        )
    per = (False,) * (d - 1) if periodic is None else tuple(bool(p) for p in periodic)
    if len(per) != d - 1:
        raise InvalidParameterError(
            f"invalid periodic = {periodic!r}: expected {d - 1} flags, one per horizontal axis",
            parameter="periodic",
        )
    if kind == "periodic" and not any(per):
        per = (True,) * (d - 1)
    return Container("periodic" if any(per) else "box", lo, hi, per, None, lid)


@dataclass(frozen=True)
class ContainerTag:
    """What a file says of its container: the container tag, read from a file or to be
    written (see "The container tag" above). A file may give no corners (the reader then
    takes them from the file's box): `to_container` makes the `Container`.

    Attributes
    ----------
    kind : str
        One of `CONTAINERS`.
    cylinder_radius : float or None
        R (m) of the cylinder; None for the other kinds.
    lo, hi : (D,) float64 or None
        Box corners (m) where the tag gives them.
    lid : float or None
        Height (m) of the lid of a consolidated sample; None where the top is open.
    """

    kind: str
    cylinder_radius: float | None = None
    lo: np.ndarray | None = None
    hi: np.ndarray | None = None
    lid: float | None = None

    @classmethod
    def from_container(cls, container: Container, corners: bool = True) -> ContainerTag:
        """The tag of a `granpack.analysis.Container` (with its corners, or without; with
        its lid where it has one)."""
        lo, hi = (container.lo, container.hi) if corners else (None, None)
        lid = float(container.hi[-1]) if container.lid else None
        return cls(container.kind, container.radius, lo, hi, lid)

    def to_container(self, lo=None, hi=None) -> Container:
        """The `granpack.analysis.Container` the tag names: its corners, or `lo` and `hi`
        where it gives none (each (D,), hi's vertical value H_top)."""
        lo = self.lo if self.lo is not None else lo
        hi = self.hi if self.hi is not None else hi
        if lo is None or hi is None:
            raise ValueError("the tag gives no corners: pass lo and hi")
        if self.lid is not None:
            hi = np.array([*np.asarray(hi, dtype=float)[:-1], self.lid])
        periodic = (self.kind == "periodic",) * (len(lo) - 1)
        return make_container(
            self.kind, lo, hi, periodic, self.cylinder_radius, lid=self.lid is not None
        )

    def words(self) -> str:
        """The tag's words (full float precision: ``repr``)."""
        words = [f"container={self.kind}"]
        if self.cylinder_radius is not None:
            words.append(f"cylinder_radius={float(self.cylinder_radius)!r}")
        for name, v in (("lo", self.lo), ("hi", self.hi)):
            if v is not None:
                words.append(f"{name}=" + ",".join(repr(float(a)) for a in np.asarray(v).ravel()))
        if self.lid is not None:
            words.append(f"lid={float(self.lid)!r}")
        return " ".join(words)

    @classmethod
    def parse(cls, text: str, path: Path, line: int, dim: int) -> ContainerTag | None:
        """The container tag a line `text` names (line number `line` of `path`, for
        messages), or None where it names none. A tag that is there but wrong (an unknown
        kind, a cylinder without a radius, a radius <= 0, corners that are not `dim` finite
        numbers, a lid that is not a finite number above the floor, or not at the top of
        ``hi``) is a FileFormatError: a file that says its container is read in it, or
        not at all."""
        found = {m.group(1): m.group(2) for m in _WORD.finditer(text)}
        if "container" not in found:
            old = _OLD_DATA_TITLE.search(text)
            if old is None:
                return None
            found = {"container": old.group(1)}
            if old.group(2) is not None:
                found["cylinder_radius"] = old.group(2)
        where = f"{path}:{line}"
        kind = found["container"].strip("\"'),")
        if kind not in CONTAINERS:
            raise FileFormatError(
                f"{where}: container={kind!r} is not one of {', '.join(CONTAINERS)}",
                path=path,
                reason="unknown container",
            )
        radius = None
        if kind == "cylinder":
            if "cylinder_radius" not in found:
                raise FileFormatError(
                    f"{where}: container=cylinder needs cylinder_radius=<R> (m)",
                    path=path,
                    reason="missing cylinder radius",
                )
            radius = _number(found["cylinder_radius"], "cylinder_radius", where, path)
            if not (math.isfinite(radius) and radius > 0.0):
                raise FileFormatError(
                    f"{where}: cylinder_radius={radius!r} must be finite and > 0 (m)", path=path
                )
            if dim != 3:
                raise FileFormatError(
                    f"{where}: container=cylinder in a {dim}D file: a cylinder is 3D", path=path
                )
        corners: list[np.ndarray | None] = []
        for name in ("lo", "hi"):
            if name not in found:
                corners.append(None)
                continue
            values = found[name].strip("\"'),").split(",")
            v = np.array([_number(s, name, where, path) for s in values])
            if v.shape != (dim,) or not np.all(np.isfinite(v)):
                raise FileFormatError(
                    f"{where}: {name}={found[name]} must be {dim} finite numbers (m), "
                    "comma-separated",
                    path=path,
                )
            corners.append(v)
        lo, hi = corners
        if lo is not None and hi is not None and not np.all(hi > lo):
            raise FileFormatError(
                f"{where}: the container's corners lo={lo.tolist()} and hi={hi.tolist()} "
                "need hi > lo",
                path=path,
            )
        lid = None
        if "lid" in found:
            lid = _number(found["lid"], "lid", where, path)
            if not math.isfinite(lid):
                raise FileFormatError(
                    f"{where}: lid={lid!r} must be a finite height (m)", path=path
                )
            if lo is not None and not lid > lo[-1]:
                raise FileFormatError(
                    f"{where}: lid={lid!r} must lie above the floor at {float(lo[-1])!r} (m)",
                    path=path,
                )
            if hi is not None and lid != hi[-1]:
                raise FileFormatError(
                    f"{where}: lid={lid!r} must be the top of the box, hi's last value "
                    f"{float(hi[-1])!r} (m)",
                    path=path,
                )
        return cls(kind, radius, lo, hi, lid)


#: The stages that leave a consolidated sample closed by its lid, the walls where they
#: stopped: the consolidation and the element tests run on it.
LID_STAGES = ("consolidate", "triaxial", "oedometer", "isotropic")


def lid_record(pack) -> dict | None:
    """The table of the last stage that left a consolidated pack's walls where they are
    (the consolidation, or an element test run after it: its ``walls`` say where the lid
    and the side walls stopped, its ``gravity`` whether it ran with gravity); None for a
    deposit and for what is not a granpack Pack."""
    if stage_table(pack, "consolidate") is None:
        return None
    for rec in reversed(pack.history):
        if rec.stage in LID_STAGES:
            table = rec.table()
            return table if isinstance(table, dict) and "walls" in table else None
    return None


def _consolidation_record(pack) -> dict | None:
    """The walls' record of a consolidated pack (`lid_record`), None for a deposit and
    for what is not a granpack Pack."""
    return lid_record(pack)


def _number(s: str, name: str, where: str, path: Path) -> float:
    try:
        return float(s.strip("\"'),"))
    except ValueError:
        raise FileFormatError(f"{where}: {name}={s!r} is not a number", path=path) from None
