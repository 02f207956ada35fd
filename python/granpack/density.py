"""Packs at the density the user asks for, and the model's own e_min and e_max.

A scene may give one density target: ``target_phi``, ``target_void_ratio`` or
``target_relative_density`` (with ``density_tol`` and ``density_method``). `generate`
then builds the pack through `generate_at_density`, by one of two mechanisms
(docs/density.md has the evidence behind each choice):

- **The deposition friction** (``density_method = "deposition"``). Every layer is jammed
  with a friction mu_dep instead of the material's, and the material's friction is
  restored once the pack is jammed; where mu_dep exceeded it, the pack then settles
  again under its own weight (`granpack.settle`), so that every contact lies in the
  material's Coulomb cone. phi falls as mu_dep rises, nearly linearly in
  ln(mu_dep + MU_SHIFT), from frictionless jamming (mu_dep = 0, the densest) to
  MU_DEP_MAX (the loosest: above it phi changes by less than 0.002). The search for
  mu_dep is a secant search in that variable, bracketed where it can be: deterministic,
  so the same scene and seed give the same pack, bit for bit.
- **Lowering friction under the servo** (``density_method = "servo"``; needs a
  ``[consolidate]`` table). The recipe's deposit is consolidated; while the servo holds
  the stress, the friction is lowered in phases, each run to equilibrium, until phi
  reaches the target; then the material's friction is restored and equilibrium reached
  again (`granpack.consolidate`'s ``target_phi``). It only densifies.

``"auto"`` (the default) lowers the friction under the servo when the scene consolidates
and the recipe's sample is looser than the target (one generation), and searches the
deposition friction otherwise.

Which phi: with a lid (a consolidating scene), the sample's, between the floor and the
lid; without one, the core window's (`Microstructure.phi_core`), away from the walls and
the free surface, the part of a deposit that a sample cut from it would have.

The void ratio limits of the model (`void_ratio_limits`) are the two ends of the
deposition friction: e_min from packs jammed frictionless (mu_dep = 0), e_max from packs
jammed at MU_DEP_MAX, each then brought back to the material's friction, settled and (when
the scene consolidates) consolidated, exactly as a target's pack is.
"""

from __future__ import annotations

import dataclasses
import math
import statistics
import time
from collections.abc import Callable
from typing import Any

from ._validate import as_int
from .analysis import microstructure
from .consolidation import consolidate, settle
from .errors import DensityTargetError, InvalidParameterError
from .pack import Pack, deposit
from .scene import PackScene

__all__ = [
    "VoidRatioLimits",
    "void_ratio_limits",
    "generate_at_density",
    "sample_phi",
    "MU_DEP_MAX",
]

#: The loosest deposition friction (-): between mu_dep = 1 and 2 the core phi of example
#: 4.3 changed by 0.001 (settled at the material's friction), within one pack's spread.
MU_DEP_MAX = 1.0
#: The search variable is ln(mu_dep + MU_SHIFT), in which phi is nearly linear.
MU_SHIFT = 0.1
#: The first step's slope, d phi / d ln(mu_dep + MU_SHIFT), before the search has two
#: points of its own: -0.022 was measured on example 4.3 in the box (core phi).
SLOPE_GUESS = -0.022
#: Most packs one search generates.
MAX_GENERATIONS = 8
#: The default tolerance in phi (in e and Dr: its equivalent at the target).
DEFAULT_TOL_PHI = 0.002
#: The unbalanced ratio a pack jammed above the material's friction settles to once the
#: friction is restored (when the scene sets no rest_tol).
REST_TOL = 1e-4

#: The scene's keys that the layer loop does not run: the pack is generated without
#: them (`_plain`), and its scene gets them back at the end.
_STAGE_FIELDS = (
    "target_phi",
    "target_void_ratio",
    "target_relative_density",
    "density_tol",
    "density_method",
    "consolidate",
    "rest_tol",
)


def sample_phi(pack: Pack) -> tuple[float, str]:
    """The packing fraction a density target is measured by, and which one it is:
    ("sample": between the floor and the lid) for a consolidated pack, ("core": the core
    window's, `Microstructure.phi_core`) for a deposit."""
    if pack.consolidation is not None:
        return float(pack.consolidation["phi"]), "sample"
    return float(microstructure(pack).phi_core), "core"


def _plain(scene: PackScene) -> PackScene:
    """The scene without its target, settling and consolidation: the layer loop's part."""
    defaults = {f.name: f.default for f in dataclasses.fields(PackScene)}
    return scene.replace(**{k: defaults[k] for k in _STAGE_FIELDS})


def _at_friction(
    scene: PackScene,
    mu_dep: float,
    servo_phi: float | None = None,
    servo_tol: float = DEFAULT_TOL_PHI,
    progress: bool | Callable[[dict], None] = False,
) -> Pack:
    """The scene's pack with every layer jammed at friction `mu_dep`, the material's
    friction restored, settled where needed, and consolidated when the scene asks
    (lowering the friction under the servo to `servo_phi` when given)."""
    plain = _plain(scene)
    mat = scene.material
    jam = plain
    if mu_dep != mat.friction:
        jam = plain.replace(material=dataclasses.replace(mat, friction=mu_dep))
    pack = deposit(jam, progress)
    pack = dataclasses.replace(pack, scene=plain)
    if mu_dep > mat.friction or scene.rest_tol is not None:
        pack = settle(pack, scene.rest_tol if scene.rest_tol is not None else REST_TOL)
    if scene.consolidate is not None:
        pack = consolidate(pack, **scene.consolidate, target_phi=servo_phi, density_tol=servo_tol)
    return pack


def _u(mu: float) -> float:
    return math.log(mu + MU_SHIFT)


def _mu(u: float) -> float:
    return min(max(math.exp(u) - MU_SHIFT, 0.0), MU_DEP_MAX)


@dataclasses.dataclass(frozen=True)
class VoidRatioLimits:
    """The model's e_min and e_max for a scene (`void_ratio_limits`).

    Attributes:
        e_min, e_max: the mean void ratio (-) of the densest and the loosest packs.
        e_min_sd, e_max_sd: their sample standard deviation over the packs (0 for one).
        e_min_values, e_max_values: each pack's.
        measure: "sample" (floor to lid, a consolidating scene) or "core".
        packs: how many packs each end was measured on (the scene's stream and the next
            ones, of its seed).
    """

    e_min: float
    e_max: float
    e_min_sd: float
    e_max_sd: float
    e_min_values: tuple[float, ...]
    e_max_values: tuple[float, ...]
    measure: str
    packs: int

    @property
    def phi_min(self) -> float:
        """The loosest packing fraction, 1 / (1 + e_max)."""
        return 1.0 / (1.0 + self.e_max)

    @property
    def phi_max(self) -> float:
        """The densest packing fraction, 1 / (1 + e_min)."""
        return 1.0 / (1.0 + self.e_min)

    def relative_density(self, e: float) -> float:
        """Dr = (e_max - e) / (e_max - e_min) of void ratio `e` (-)."""
        return (self.e_max - e) / (self.e_max - self.e_min)


def void_ratio_limits(
    scene: PackScene,
    packs: int = 5,
    progress: bool | Callable[[dict], None] = False,
) -> VoidRatioLimits:
    """e_min and e_max of the model for `scene`'s size distribution, container and
    material, each over `packs` packs.

    e_min: every layer jammed frictionless (mu_dep = 0); e_max: jammed at MU_DEP_MAX.
    The packs take the scene's stream and the next ``packs - 1``.
    Each pack then gets the material's friction back, settles (REST_TOL, or the scene's
    rest_tol) and, when the scene consolidates, is consolidated at the material's
    friction. The void ratio is the sample's (floor to lid) when the scene consolidates,
    the core window's otherwise (see `sample_phi`). The scene's density target, if any,
    plays no part.

    Parameters
    ----------
    scene : PackScene
    packs : int
        Packs per end, in [1, 1000]. Default 5.
    progress : bool or callable
        A callable gets a dict per pack (end, stream, phi, void_ratio, seconds); True
        prints one line per pack to stderr.
    """
    if not isinstance(scene, PackScene):
        raise InvalidParameterError(
            f"invalid scene = {scene!r}: must be a granpack.PackScene", parameter="scene"
        )
    packs = as_int("packs", packs, 1, 1000)
    values: dict[str, list[float]] = {"e_min": [], "e_max": []}
    measure = "core"
    for end, mu in (("e_min", 0.0), ("e_max", MU_DEP_MAX)):
        for k in range(packs):
            t0 = time.perf_counter()
            pack = _at_friction(scene.replace(stream=scene.stream + k), mu)
            phi, measure = sample_phi(pack)
            values[end].append(1.0 / phi - 1.0)
            _report(
                progress,
                {
                    "end": end,
                    "stream": scene.stream + k,
                    "phi": phi,
                    "void_ratio": 1.0 / phi - 1.0,
                    "seconds": time.perf_counter() - t0,
                },
            )
    return _limits(values["e_min"], values["e_max"], measure)


def _limits(e_min: list[float], e_max: list[float], measure: str) -> VoidRatioLimits:
    """The limits from each end's packs (the mean of one pack is its value, exactly)."""
    sd = {
        k: statistics.stdev(v) if len(v) > 1 else 0.0 for k, v in (("min", e_min), ("max", e_max))
    }
    return VoidRatioLimits(
        e_min=statistics.fmean(e_min),
        e_max=statistics.fmean(e_max),
        e_min_sd=sd["min"],
        e_max_sd=sd["max"],
        e_min_values=tuple(e_min),
        e_max_values=tuple(e_max),
        measure=measure,
        packs=len(e_min),
    )


def _report(progress, row: dict) -> None:
    if callable(progress):
        progress(row)
    elif progress:
        import sys

        print(
            " ".join(
                f"{k}={v:.6g}" if isinstance(v, float) else f"{k}={v}" for k, v in row.items()
            ),
            file=sys.stderr,
        )


def _band(
    key: str, value: float, tol: float | None, limits: VoidRatioLimits | None
) -> tuple[float, float, float, float]:
    """The target as phi, the band of phi that meets it, and the tolerance in the
    target's quantity: (phi_target, phi_lo, phi_hi, tol). `limits` for a relative
    density."""
    if key == "target_phi":
        tol = DEFAULT_TOL_PHI if tol is None else tol
        return value, value - tol, value + tol, tol
    if key == "target_void_ratio":
        e = value
        tol = DEFAULT_TOL_PHI * (1.0 + e) ** 2 if tol is None else tol
    else:
        assert limits is not None
        e_min, e_max = limits.e_min, limits.e_max
        e = e_max - value * (e_max - e_min)
        if tol is None:
            tol = DEFAULT_TOL_PHI * (1.0 + e) ** 2 / (e_max - e_min)
        # the band in e, from the band in Dr
        de = tol * (e_max - e_min)
        return 1.0 / (1.0 + e), 1.0 / (1.0 + e + de), 1.0 / (1.0 + max(e - de, 0.0)), tol
    return 1.0 / (1.0 + e), 1.0 / (1.0 + e + tol), 1.0 / (1.0 + max(e - tol, 0.0)), tol


def generate_at_density(
    scene: PackScene,
    progress: bool | Callable[[dict], None] = False,
) -> Pack:
    """The scene's pack at its density target (see the module's notes); `generate` calls
    it for a scene with a target. `progress` is `generate`'s, passed to every pack the
    search generates.

    Raises
    ------
    DensityTargetError
        The target lies outside the window this scene reaches (the error gives the
        window), or the search did not reach it in MAX_GENERATIONS packs.
    """
    target = scene.density_target
    if target is None:
        raise InvalidParameterError(
            "invalid scene: it gives no density target (target_phi, target_void_ratio or "
            "target_relative_density)",
            parameter="scene",
        )
    key, value = target
    t0 = time.perf_counter()
    history: list[dict[str, Any]] = []
    done: dict[float, tuple[Pack, float]] = {}
    measure = "sample" if scene.consolidate is not None else "core"

    def at(mu: float) -> tuple[Pack, float]:
        if mu not in done:
            t = time.perf_counter()
            pack = _at_friction(scene, mu, progress=progress)
            phi, _ = sample_phi(pack)
            if not math.isfinite(phi):
                raise InvalidParameterError(
                    f"invalid {key} = {value:g}: the pack has no core window to measure "
                    "phi in (it is lower than twice the analysis' core margin, or "
                    "narrower); give a taller and wider scene, or a [consolidate] table "
                    "(phi between the floor and the lid)",
                    parameter=key,
                    value=value,
                )
            done[mu] = (pack, phi)
            history.append(
                {
                    "friction": mu,
                    "phi": phi,
                    "method": "deposition",
                    "seconds": time.perf_counter() - t,
                }
            )
        return done[mu]

    limits = None
    if key == "target_relative_density":
        # Dr needs e_min and e_max: the two ends of this seed's deposition friction,
        # which bracket the search as well
        phi_loose, phi_dense = at(MU_DEP_MAX)[1], at(0.0)[1]
        limits = _limits([1.0 / phi_dense - 1.0], [1.0 / phi_loose - 1.0], measure)
    phi_t, lo, hi, tol = _band(key, value, scene.density_tol, limits)

    def finish(pack: Pack, phi: float, method: str, friction: float) -> Pack:
        e = 1.0 / phi - 1.0
        record: dict[str, Any] = {
            "target": {key: value},
            "target_phi": phi_t,
            "density_tol": tol,
            "measure": measure,
            "method": method,
            "friction": friction,
            "phi": phi,
            "void_ratio": e,
            "generations": len(history),
            "history": history,
            "seconds": time.perf_counter() - t0,
        }
        if limits is not None:
            record["e_min"], record["e_max"] = limits.e_min, limits.e_max
            record["relative_density"] = limits.relative_density(e)
        return dataclasses.replace(
            pack,
            scene=pack.scene.replace(**{k: getattr(scene, k) for k in _STAGE_FIELDS}),
            density=record,
            wall_time=time.perf_counter() - t0,
        )

    mu0 = float(scene.material.friction)
    method = scene.density_method
    if method == "auto":
        method = "servo" if scene.consolidate is not None else "deposition"
    if method == "servo" and limits is None:
        try:
            t = time.perf_counter()
            pack = _at_friction(
                scene,
                mu0,
                servo_phi=phi_t,
                servo_tol=min(hi - phi_t, phi_t - lo),
                progress=progress,
            )
            phi, _ = sample_phi(pack)
            history.append(
                {
                    "friction": mu0,
                    "phi": phi,
                    "method": "servo",
                    "seconds": time.perf_counter() - t,
                    "phases": (pack.consolidation or {})["density"]["phases"],
                }
            )
            return finish(pack, phi, "servo", mu0)
        except DensityTargetError as e:
            history.append(
                {
                    "friction": mu0,
                    "phi": e.realised,
                    "method": "servo",
                    "seconds": time.perf_counter() - t,
                }
            )
            if scene.density_method == "servo" or not e.phi_min > phi_t:
                raise _renamed(e, key, value, phi_t) from None
            # the recipe's sample is denser than the target: the deposition friction
            # loosens it (the servo's first equilibrium was this pack at mu0)
            return _search(key, value, phi_t, lo, hi, at, finish, mu0, tried=[(mu0, e.phi_min)])
    # a relative density's window ends bracket the search from the start
    for end in (MU_DEP_MAX, 0.0) if limits else ():
        pack, phi = done[end]
        if lo <= phi <= hi:
            return finish(pack, phi, "deposition", end)
    ends = [(MU_DEP_MAX, done[MU_DEP_MAX][1]), (0.0, done[0.0][1])] if limits else []
    return _search(key, value, phi_t, lo, hi, at, finish, mu0, tried=ends)


def _search(key, value, phi_t, lo, hi, at, finish, mu0, tried=()) -> Pack:
    """The secant search of the deposition friction in ln(mu + MU_SHIFT), from the
    recipe's friction `mu0` or, after `tried` (mu, phi) points, from where they point."""
    points: list[tuple[float, float]] = list(tried)
    mu: float | None = None if points else mu0
    for _ in range(MAX_GENERATIONS):
        if mu is None:
            mu = _next_friction(points, key, value, phi_t, lo, hi, at)
        pack, phi = at(mu)
        if lo <= phi <= hi:
            return finish(pack, phi, "deposition", mu)
        points.append((mu, phi))
        mu = None
    best = min(points, key=lambda p: abs(p[1] - phi_t))
    raise DensityTargetError(
        f"{key} = {value:g} (phi = {phi_t:.4f}) not reached in {MAX_GENERATIONS} packs of "
        f"the deposition friction search (nearest: phi = {best[1]:.4f} at mu_dep = "
        f"{best[0]:.4g}); give a larger density_tol (the spread of phi between packs "
        "grows as the pack gets smaller)",
        parameter=key,
        value=value,
        target_phi=phi_t,
        phi_min=math.nan,
        phi_max=math.nan,
        realised=best[1],
    )


def _next_friction(points, key, value, phi_t, lo, hi, at) -> float:
    """The next deposition friction to try, or the out-of-window error when the points
    show that no friction in [0, MU_DEP_MAX] reaches the band."""
    mu, phi = points[-1]
    tried = {p[0]: p[1] for p in points}
    if phi < lo and 0.0 in tried and tried[0.0] < lo:
        raise _out_of_window(key, value, phi_t, at(MU_DEP_MAX)[1], tried[0.0])
    if phi > hi and MU_DEP_MAX in tried and tried[MU_DEP_MAX] > hi:
        raise _out_of_window(key, value, phi_t, tried[MU_DEP_MAX], at(0.0)[1])
    dense = [p for p in points if p[1] > hi]  # need more friction than these
    loose = [p for p in points if p[1] < lo]  # and less than these
    if dense and loose:
        a = max(dense, key=lambda p: p[0])
        b = min(loose, key=lambda p: p[0])
    elif len(points) >= 2:
        a, b = sorted(points, key=lambda p: abs(p[1] - phi_t))[:2]
    else:
        a = b = points[0]
    ua, ub = _u(a[0]), _u(b[0])
    if ua != ub and (a[1] - b[1]) * (ua - ub) < 0:
        u = ua + (phi_t - a[1]) * (ub - ua) / (b[1] - a[1])
    else:
        u = _u(mu) + (phi_t - phi) / SLOPE_GUESS
    if dense and loose and ua != ub:
        # strictly inside the bracket
        u_lo, u_hi = sorted((ua, ub))
        u = min(max(u, u_lo + 0.1 * (u_hi - u_lo)), u_hi - 0.1 * (u_hi - u_lo))
    nxt = _mu(u)
    if nxt in tried:
        # clamped onto a friction tried already: try the window's end instead
        nxt = 0.0 if phi < lo else MU_DEP_MAX
        if nxt in tried:
            raise (
                _out_of_window(key, value, phi_t, at(MU_DEP_MAX)[1], tried[0.0])
                if phi < lo
                else _out_of_window(key, value, phi_t, tried[MU_DEP_MAX], at(0.0)[1])
            )
    return nxt


def _out_of_window(key, value, phi_t, phi_min, phi_max) -> DensityTargetError:
    return DensityTargetError(
        f"invalid {key} = {value:g} (phi = {phi_t:.4f}): out of reach; this scene and seed "
        f"go from phi = {phi_min:.4f} (layers jammed at mu_dep = {MU_DEP_MAX:g}, the "
        f"loosest) to {phi_max:.4f} (jammed frictionless, the densest): the window is "
        f"[{phi_min:.4f}, {phi_max:.4f}], e in [{1 / phi_max - 1:.4f}, "
        f"{1 / phi_min - 1:.4f}]",
        parameter=key,
        value=value,
        target_phi=phi_t,
        phi_min=phi_min,
        phi_max=phi_max,
    )


def _renamed(e: DensityTargetError, key: str, value: float, phi_t: float):
    """The consolidation stage's error, naming the scene's target key."""
    if key == "target_phi":
        return e
    return DensityTargetError(
        f"{key} = {value:g} (phi = {phi_t:.4f}): {e}",
        parameter=key,
        value=value,
        target_phi=phi_t,
        phi_min=e.phi_min,
        phi_max=e.phi_max,
        realised=e.realised,
    )
