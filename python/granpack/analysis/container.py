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
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import _core
from .._validate import InvalidParameterError

__all__ = ["Container", "CONTAINERS"]

#: The container kinds, as the engine names them.
CONTAINERS = _core.CONTAINERS


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
