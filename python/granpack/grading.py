"""Grading of a set of particles: the characteristic diameters D10 ... D90, the
uniformity coefficient Cu and the curvature coefficient Cc, by mass and by number, of a
pack (realised) and of a scene's radius law (target).

Definitions (docs/grading.md):

- D_x is the diameter below which a fraction x of the particles lies, by mass or by
  number. For a set of particles it is the smallest diameter d_i at which the
  cumulative fraction (of the particles with d <= d_i) reaches x; for a law, the exact
  quantile of its cumulative distribution.
- Cu = D60 / D10 and Cc = D30^2 / (D10 D60).
- Mass is the engine's particle mass, proportional to r^p: p = 3 for spheres and for 2D
  particles with a sphere's mass (inertia_2d = "sphere"), p = 2 for 2D discs of unit
  thickness (inertia_2d = "disc"). Density is common to all particles, so "by mass" is
  by volume (by area for discs).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any, Literal

import numpy as np

from . import _core
from ._validate import InvalidParameterError, as_array, short_repr

__all__ = [
    "Grading",
    "FRACTIONS",
    "realised_grading",
    "target_grading",
    "passing",
    "target_passing",
    "mass_exponent",
]

#: The fractions passing whose diameters a grading reports (D10, D30, D50, D60, D90).
FRACTIONS = (0.10, 0.30, 0.50, 0.60, 0.90)

#: Points per segment of the grid on which a continuous law's distribution is
#: integrated (trapezoids in ln r: quantiles to about 1e-8 relative).
_GRID = 4001


@dataclass(frozen=True)
class Grading:
    """Characteristic diameters (m) and coefficients (-) of a size distribution.

    Attributes
    ----------
    d10_mass, d30_mass, d50_mass, d60_mass, d90_mass : float
        Diameters below which 10, 30, 50, 60, 90 % of the mass lies (m).
    cu_mass, cc_mass : float
        Cu = D60 / D10 and Cc = D30^2 / (D10 D60), by mass.
    d10_number, d30_number, d50_number, d60_number, d90_number : float
        The same by number (m).
    cu_number, cc_number : float
        Cu and Cc by number.
    """

    d10_mass: float
    d30_mass: float
    d50_mass: float
    d60_mass: float
    d90_mass: float
    cu_mass: float
    cc_mass: float
    d10_number: float
    d30_number: float
    d50_number: float
    d60_number: float
    d90_number: float
    cu_number: float
    cc_number: float

    def to_dict(self) -> dict[str, float]:
        """The fields as a flat dict (keys d10_mass ... cc_number)."""
        return asdict(self)

    @classmethod
    def _from(cls, by_mass: list[float], by_number: list[float]) -> Grading:
        out: dict[str, float] = {}
        for by, d in (("mass", by_mass), ("number", by_number)):
            d10, d30, d50, d60, d90 = d
            out.update(
                {f"d{int(round(100 * f))}_{by}": v for f, v in zip(FRACTIONS, d, strict=True)}
            )
            # ratios of diameters only: the same at any scale (a product such as
            # D30^2 would underflow for radii near 1e-200 and overflow near 1e200)
            out[f"cu_{by}"] = d60 / d10
            out[f"cc_{by}"] = (d30 / d10) * (d30 / d60)
        return cls(**out)


def mass_exponent(dim: int, inertia_2d: str = "disc") -> int:
    """The power p of the radius a particle's mass grows with: 3, or 2 for 2D discs of
    unit thickness (inertia_2d = "disc", the default; "sphere" gives 3 in 2D too)."""
    if dim not in (2, 3):
        raise InvalidParameterError(
            f"invalid dim = {short_repr(dim)}: must be 2 or 3", parameter="dim"
        )
    if inertia_2d not in ("sphere", "disc"):
        raise InvalidParameterError(
            f"invalid inertia_2d = {short_repr(inertia_2d)}: must be 'sphere' or 'disc'",
            parameter="inertia_2d",
        )
    return 2 if dim == 2 and inertia_2d == "disc" else 3


def _radii_and_exponent(
    pack_or_radii: Any, dim: int | None, inertia_2d: str | None
) -> tuple[np.ndarray, int]:
    scene = getattr(pack_or_radii, "scene", None)
    if scene is not None and hasattr(pack_or_radii, "radii"):
        r = np.asarray(pack_or_radii.radii, dtype=np.float64)
        dim = scene.dim if dim is None else dim
        inertia_2d = scene.inertia_2d if inertia_2d is None else inertia_2d
    else:
        r = as_array("radii", pack_or_radii, (None,))
    with np.errstate(over="ignore"):
        finite_d = np.isfinite(2.0 * r)
    if r.size == 0 or not np.all(np.isfinite(r) & (r > 0) & finite_d):
        raise InvalidParameterError(
            "invalid radii: expected one or more finite radii > 0 whose diameters are "
            f"finite too (0 < r <= {np.finfo(np.float64).max / 2:.4g} m)",
            parameter="radii",
        )
    return r, mass_exponent(3 if dim is None else dim, inertia_2d or "disc")


def _quantiles(d: np.ndarray, w: np.ndarray) -> list[float]:
    """The smallest d_i whose cumulative weight fraction reaches each of FRACTIONS."""
    order = np.argsort(d, kind="stable")
    d, w = d[order], w[order]
    cum = np.cumsum(w)
    cum /= cum[-1]
    # (a fraction within rounding of a step counts as reaching it)
    idx = np.searchsorted(cum, np.asarray(FRACTIONS) * (1 - 1e-12), side="left")
    return [float(d[min(i, len(d) - 1)]) for i in idx]


def realised_grading(
    pack_or_radii: Any, dim: int | None = None, *, inertia_2d: str | None = None
) -> Grading:
    """The realised grading of a pack (`gp.realised_grading(pack)`) or of a set of radii
    (`gp.realised_grading(radii, dim=3)`).

    Parameters
    ----------
    pack_or_radii : Pack or array of float
        A pack (its radii, dim and inertia_2d are used), or radii (m).
    dim : int, optional
        2 or 3; default the pack's, or 3 for bare radii.
    inertia_2d : {"sphere", "disc"}, optional
        2D mass model (sets what "mass" weighs, see the module); default the pack's
        scene's, or "disc" (the engine's default).
    """
    r, p = _radii_and_exponent(pack_or_radii, dim, inertia_2d)
    d = 2.0 * r
    return Grading._from(_quantiles(d, (r / r.max()) ** p), _quantiles(d, np.ones_like(r)))


def passing(
    pack_or_radii: Any,
    diameters: Any,
    dim: int | None = None,
    *,
    inertia_2d: str | None = None,
    by: Literal["mass", "number"] = "mass",
) -> np.ndarray:
    """The realised fraction (by mass or number) of particles with diameter <= each of
    `diameters` (m): a pack's or a set of radii's grading curve."""
    r, p = _radii_and_exponent(pack_or_radii, dim, inertia_2d)
    w = (r / r.max()) ** p if _by(by) == "mass" else np.ones_like(r)
    order = np.argsort(r, kind="stable")
    d, cum = 2.0 * r[order], np.cumsum(w[order])
    x = np.asarray(diameters, dtype=np.float64)
    k = np.searchsorted(d, x, side="right")
    out = np.where(k > 0, cum[np.maximum(k - 1, 0)], 0.0) / cum[-1]
    return out


def _by(by: str) -> str:
    if by not in ("mass", "number"):
        raise InvalidParameterError(
            f"invalid by = {short_repr(by)}: must be 'mass' or 'number'", parameter="by"
        )
    return by


# -- the target: a scene's law -------------------------------------------------------------
class _Law:
    """A scene's radius law as cumulative distributions of the radius, by number and by
    mass: atoms (discrete, constant) or piecewise-integrated densities."""

    def __init__(self, scene: Any) -> None:
        self.p = mass_exponent(scene.dim, scene.inertia_2d)
        law = scene.radius_law
        self.atoms: tuple[np.ndarray, np.ndarray] | None = None
        if law == "constant" or (law in ("gaussian", "lognormal") and scene.r_std == 0.0):
            self.atoms = (np.array([scene.r_mean]), np.array([1.0]))
            return
        if law == "discrete":
            fractions = _core.number_fractions(scene)
            assert fractions is not None
            self.atoms = (np.asarray(scene.radii, dtype=float), np.asarray(fractions))
            return
        segments: list[tuple[float, float]]
        if law == "sieve":
            d = np.asarray(scene.sieve_sizes, dtype=float)
            w = np.diff(np.asarray(scene.sieve_passing, dtype=float))
            segments = [(d[k] / 2, d[k + 1] / 2) for k in range(len(w)) if w[k] > 0]
            weights = {k: w[k] / math.log(d[k + 1] / d[k]) for k in range(len(w))}
            starts = {d[k] / 2: k for k in range(len(w))}
        else:
            segments = [(float(scene.r_min), float(scene.r_max))]
        if segments[0][0] == segments[-1][1]:  # a point: the window has no width
            self.atoms = (np.array([segments[0][0]]), np.array([1.0]))
            return
        r_all, fn_all = [], []
        for lo, hi in segments:
            r = np.exp(np.linspace(math.log(lo), math.log(hi), _GRID))
            if law == "sieve":
                # mass uniform in ln d within the class: number density in r
                # proportional to (w_k / du_k) r^(-p-1)
                c = weights[starts[lo]]
                f = c * (r / lo) ** (-self.p - 1) / lo ** (self.p + 1)
            elif law == "uniform":
                f = np.ones_like(r)
            elif law == "gaussian":
                z = (r - scene.r_mean) / scene.r_std
                f = np.exp(-0.5 * (z * z - np.min(z * z)))
            elif law == "lognormal":
                s2 = math.log1p((scene.r_std / scene.r_mean) ** 2)
                mu, sigma = math.log(scene.r_mean) - 0.5 * s2, math.sqrt(s2)
                z = (np.log(r) - mu) / sigma
                f = np.exp(-0.5 * (z * z - np.min(z * z))) / r
            else:  # pragma: no cover (the scene refuses other names)
                raise InvalidParameterError(f"invalid radius_law = {law!r}", parameter="radius_law")
            r_all.append(r)
            fn_all.append(f)
        self.segments = (r_all, fn_all)

    def cdf(self, r: np.ndarray, by: str) -> np.ndarray:
        """Fraction (by number or mass) of the law at radius <= r."""
        grid, cum = self._table(by)
        if self.atoms is not None:
            k = np.searchsorted(grid, r, side="right")
            return np.where(k > 0, cum[np.maximum(k - 1, 0)], 0.0)
        return np.interp(r, grid, cum, left=0.0, right=1.0)

    def _table(self, by: str) -> tuple[np.ndarray, np.ndarray]:
        if self.atoms is not None:
            r, n = self.atoms
            w = n * (r / r.max()) ** self.p if by == "mass" else n
            cum = np.cumsum(w)
            return r, cum / cum[-1]
        r_all, fn_all = self.segments
        grids, cums, total = [], [], 0.0
        scale = max(float(r[-1]) for r in r_all)
        for r, f in zip(r_all, fn_all, strict=True):
            g = f * (r / scale) ** self.p if by == "mass" else f
            # trapezoids in the radius, on the log-spaced grid
            part = np.concatenate([[0.0], np.cumsum(0.5 * (g[1:] + g[:-1]) * np.diff(r))])
            grids.append(r)
            cums.append(total + part)
            total += float(part[-1])
        return np.concatenate(grids), np.concatenate(cums) / total

    def quantiles(self, by: str) -> list[float]:
        """Diameters (m) at FRACTIONS."""
        grid, cum = self._table(by)
        if self.atoms is not None:
            idx = np.searchsorted(cum, np.asarray(FRACTIONS) * (1 - 1e-12), side="left")
            return [float(2 * grid[min(i, len(grid) - 1)]) for i in idx]
        # cum is non-decreasing (flat across an empty class): interpolate on the
        # strictly increasing part
        keep = np.concatenate([[True], np.diff(cum) > 0])
        return [float(2 * v) for v in np.interp(FRACTIONS, cum[keep], grid[keep])]


def target_grading(scene: Any) -> Grading:
    """The grading of a scene's radius law (`PackScene`): exact quantiles of its
    distributions by mass and by number (continuous laws integrated numerically, to
    about 1e-8 relative)."""
    law = _Law(scene)
    return Grading._from(law.quantiles("mass"), law.quantiles("number"))


def target_passing(
    scene: Any, diameters: Any, *, by: Literal["mass", "number"] = "mass"
) -> np.ndarray:
    """The fraction (by mass or number) of a scene's radius law with diameter <= each of
    `diameters` (m): the target grading curve. For a sieve law by mass it is the
    sieve curve, log-linear between sieves."""
    x = np.asarray(diameters, dtype=np.float64)
    return _Law(scene).cdf(0.5 * x, _by(by))
