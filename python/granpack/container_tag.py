"""The container tag: one line of ``key=value`` words that granpack's text exports carry, so
that a pack read back is analysed in the container it was made in.

A periodic cell analysed as a walled box gets branch vectors across the whole cell at the
seam; a cylinder analysed as its bounding box gets phi over the square. Formats that have a
place for the container keep it there (an extended XYZ file's ``pbc``, a dump's ``BOX
BOUNDS``); the tag adds what they cannot say (a cylinder's radius), and carries the whole
container in formats that have no place for it (YADE text, CSV, the LAMMPS data file,
whose title line holds it).

The tag::

    container=<box|periodic|cylinder> [cylinder_radius=<R>] [lo=<x>,<y>[,<z>]] [hi=...]
        [lid=<z>]

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

import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ._validate import FileFormatError
from .analysis.container import CONTAINERS, Container, make_container

__all__ = ["ContainerTag", "container_tag", "parse_container_tag", "CONTAINER_KINDS"]

#: The container kinds a tag names: the analysis' (granpack.analysis.container).
CONTAINER_KINDS = CONTAINERS

_WORD = re.compile(r"(?<![\w.])(container|cylinder_radius|lo|hi|lid)=(\S+)")
# granpack's LAMMPS data files before the tag: "..., container cylinder radius 0.1)"
_OLD_DATA_TITLE = re.compile(r"container (box|periodic|cylinder)(?: radius ([^\s),]+))?")


@dataclass(frozen=True)
class ContainerTag:
    """What a file says of its container.

    Attributes
    ----------
    kind : str
        One of `CONTAINER_KINDS`.
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


def container_tag(
    kind: str, radius: float | None, lo=None, hi=None, lid: float | None = None
) -> str:
    """The tag's words for a container (full float precision: ``repr``); `lid` the height
    (m) of a consolidated sample's lid, None for an open top."""
    return ContainerTag(kind, radius, lo, hi, lid).words()


def parse_container_tag(text: str, path: Path, line: int, dim: int) -> ContainerTag | None:
    """The container a line `text` names (line number `line` of `path`, for messages), or
    None where it names none. A tag that is there but wrong (an unknown kind, a cylinder
    without a radius, a radius <= 0, corners that are not `dim` finite numbers, a lid
    that is not a finite number above the floor, or not at the top of ``hi``) is a
    FileFormatError: a file that says its container is read in it, or not at all."""
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
    if kind not in CONTAINER_KINDS:
        raise FileFormatError(
            f"{where}: container={kind!r} is not one of {', '.join(CONTAINER_KINDS)}",
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
                f"{where}: {name}={found[name]} must be {dim} finite numbers (m), comma-separated",
                path=path,
            )
        corners.append(v)
    lo, hi = corners
    if lo is not None and hi is not None and not np.all(hi > lo):
        raise FileFormatError(
            f"{where}: the container's corners lo={lo.tolist()} and hi={hi.tolist()} need hi > lo",
            path=path,
        )
    lid = None
    if "lid" in found:
        lid = _number(found["lid"], "lid", where, path)
        if not math.isfinite(lid):
            raise FileFormatError(f"{where}: lid={lid!r} must be a finite height (m)", path=path)
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
    return ContainerTag(kind, radius, lo, hi, lid)


def _number(s: str, name: str, where: str, path: Path) -> float:
    try:
        return float(s.strip("\"'),"))
    except ValueError:
        raise FileFormatError(f"{where}: {name}={s!r} is not a number", path=path) from None
