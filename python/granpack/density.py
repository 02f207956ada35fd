"""Packs at the density the user asks for, and the model's own e_min and e_max.

A scene may give one density target: ``target_phi``, ``target_void_ratio`` or
``target_relative_density`` (with ``density_tol`` and ``density_method``). `generate`
then builds the pack through `generate_at_density`, by one of two mechanisms
(docs/density.md has the evidence behind each choice):

- **The deposition friction** (``density_method = "deposition"``). Every layer is jammed
  with a friction mu_dep instead of the material's, and the material's friction is
  restored once the pack is jammed; where mu_dep exceeded it, the pack then settles
  again under its own weight (`granpack.settle`), so that every contact lies in the
  material's Coulomb cone. As a deposit, phi falls as mu_dep rises, nearly linearly in
  ln(mu_dep + MU_SHIFT); once the friction is restored, the pack settled and
  consolidated, phi need not be monotone in mu_dep at all. The search is a secant
  search in that variable, inside a bracket of measured packs (one pack denser and one
  looser than the target, adjacent in mu_dep) once it has one, and otherwise over the
  measured grid MU_DEP_GRID: deterministic, so the same scene and seed give the same
  pack, bit for bit. The layers keep the material's rolling model, except at mu_dep =
  0, the frictionless jam, which has no rolling resistance either; for a material with
  a rolling model the grid also jams at the material's friction with each rolling
  friction of MU_R_GRID, and the search splits a bracket among those in ln(mu_r +
  MU_SHIFT) where the deposition frictions give none (docs/contact_models.md).
- **Lowering friction under the servo** (``density_method = "servo"``; needs a
  ``[consolidate]`` table). The recipe's deposit is consolidated; while the servo holds
  the stress, the friction is lowered in phases, each run to equilibrium, until phi
  reaches the target; then the material's friction is restored and equilibrium reached
  again (`granpack.consolidate`'s ``target_phi``). It only densifies. Every phase keeps
  the material's rolling model but the one at zero friction, which has none.

``"auto"`` (the default) lowers the friction under the servo when the scene consolidates
and the recipe's sample is looser than the target (one generation), and searches the
deposition friction otherwise, or where the servo did not reach the target.

Which phi: with a lid (a consolidating scene), the sample's, between the floor and the
lid; without one, the core window's (`Microstructure.phi_core`), away from the walls and
the free surface, the part of a deposit that a sample cut from it would have.

The void ratio limits of the model (`void_ratio_limits`) are the measured extremes over
what granpack makes of the scene: the packs jammed at every deposition friction of
MU_DEP_GRID and at the material's own (the recipe), each brought back to the material's
friction, settled and (when the scene consolidates) consolidated exactly as a target's
pack is, and, when the scene consolidates (and its density_method is not
"deposition"), the recipe's sample with its friction lowered to zero under the servo;
for a material with a rolling model, also the packs jammed at the material's friction
with each rolling friction of MU_R_GRID. e_min is the densest of them, e_max the
loosest, whichever friction, rolling friction or mechanism gave each.
"""

from __future__ import annotations

import dataclasses
import math
import statistics
import time
import warnings
from collections.abc import Callable
from typing import Any

from . import _core, stages
from ._contact_model import has_rolling
from ._validate import as_int
from .analysis import microstructure
from .errors import DensityTargetError, InvalidParameterError
from .history import StageRecord
from .pack import Pack, UnsettledPackWarning
from .scene import PackScene
from .stages import consolidate as consolidate_stage
from .stages import deposit as deposit_stage
from .stages import rest as rest_stage

__all__ = [
    "VoidRatioLimits",
    "void_ratio_limits",
    "generate_at_density",
    "sample_phi",
    "DensityWindowWarning",
    "MU_DEP_MAX",
    "MU_DEP_GRID",
    "MU_R_GRID",
    "Spec",
    "spec_of",
    "run",
]

#: The loosest deposition friction the search tries (-): between mu_dep = 1 and 2 the
#: core phi of example 4.3 changed by 0.001 (settled at the material's friction), within
#: one pack's spread.
MU_DEP_MAX = 1.0
#: The deposition frictions (-) at which the window's ends are measured (with the
#: material's own friction, the recipe's). Once the friction is restored and the pack
#: settled and consolidated, phi is not monotone in mu_dep (2D example 4.1 consolidated
#: to 10 kPa: 0.947, 0.936, 0.933, 0.925 and 0.927 at these five), so neither end of
#: the range need be an extreme.
MU_DEP_GRID = (0.0, 0.1, 0.2, 0.5, MU_DEP_MAX)
#: The rolling frictions mu_r (-) at which the window is measured as well, with the
#: material's friction, for a material with a rolling model (with the material's own
#: mu_r): rolling resistance is a knob of the loose end (docs/contact_models.md).
MU_R_GRID = (0.0, 0.1, 0.2, 0.4)
#: The search variable is ln(mu_dep + MU_SHIFT), in which phi is nearly linear (and
#: ln(mu_r + MU_SHIFT) along the rolling frictions).
MU_SHIFT = 0.1
#: The first step's slope, d phi / d ln(mu_dep + MU_SHIFT), before the search has two
#: points of its own: -0.022 was measured on example 4.3 in the box (core phi).
SLOPE_GUESS = -0.022
#: Most packs one search generates (the measured grid's included).
MAX_GENERATIONS = 12
#: Secant steps outside any bracket before the search measures the grid instead: past
#: two, an extrapolation that has not bracketed the target is following a slope that
#: the packs do not have.
MAX_EXTRAPOLATIONS = 2
#: A bracket narrower than this in ln(mu_dep + MU_SHIFT) is not split further: phi
#: jumps across the band there (a collapse of a few arches at once).
MIN_BRACKET = 1e-3
#: A bracket whose phi changes by more than this per unit of ln(mu_dep + MU_SHIFT) (20
#: times SLOPE_GUESS) looks like a jump: the search measures the grid before splitting it.
STEEP = 20 * abs(SLOPE_GUESS)
#: The default tolerance in phi (in e and Dr: its equivalent at the target); the
#: engine's, `granpack._core.DEFAULT_DENSITY_TOL`.
DEFAULT_TOL_PHI = _core.DEFAULT_DENSITY_TOL
#: The unbalanced ratio a pack jammed above the material's friction settles to once the
#: friction is restored (when the scene sets no rest_tol): the settling's default.
REST_TOL = _core.DEFAULT_REST["unbalanced_tol"]
#: The target the servo is given to measure its dense end: above any packing fraction,
#: so that it lowers the friction to zero and reports the phi it reached there.
_SERVO_PROBE = 0.9999


@dataclasses.dataclass(frozen=True)
class Spec:
    """A density target as the scene gives it.

    Attributes
    ----------
    target : str
        Its key: "target_phi", "target_void_ratio" or "target_relative_density".
    value : float
        Its value, in that key's quantity.
    tol : float or None
        The scene's ``density_tol``; None: the default of `_band`.
    method : str
        The scene's ``density_method``: "auto", "deposition" or "servo".
    """

    target: str
    value: float
    tol: float | None
    method: str


def spec_of(scene: PackScene) -> Spec | None:
    """The density target `scene` gives, or None."""
    target = scene.density_target
    if target is None:
        return None
    return Spec(target[0], target[1], scene.density_tol, scene.density_method)


def run(scene: PackScene, spec: Spec, progress: bool | Callable[[dict], None] = False) -> Pack:
    """The pack of `scene`'s stages at the density target `spec` (`generate_at_density`);
    its history ends with the "density" record."""
    if spec != spec_of(scene):
        changes: dict[str, Any] = {k: None for k in PackScene.TARGET_KEYS}
        changes.update({spec.target: spec.value, "density_tol": spec.tol})
        scene = scene.replace(**changes, density_method=spec.method)
    return generate_at_density(scene, progress)


class DensityWindowWarning(UserWarning):
    """A sample granpack made lies outside the window (e_min, e_max) measured for its
    scene and seed, so its relative density is outside [0, 1]. The message says by how
    much and why: the window's ends are measured packs (`void_ratio_limits`), and a
    sample at a target within density_tol of an end, or one whose friction was
    restored after the end was measured, can lie beyond it by that much."""


def sample_phi(pack: Pack) -> tuple[float, str]:
    """The packing fraction a density target is measured by, and which one it is:
    ("sample": between the floor and the lid) for a consolidated pack, ("core": the core
    window's, `Microstructure.phi_core`) for a deposit."""
    rec = pack.record("consolidate")
    if rec is not None:
        return float(rec.report["phi"]), "sample"
    return float(microstructure(pack).phi_core), "core"


def _measured_phi(pack: Pack, parameter: str, value: object) -> float:
    """`sample_phi`, or an InvalidParameterError naming `parameter` where the pack has no
    core window to measure phi in (NaN)."""
    from .analysis.result import MicrostructureWarning

    with warnings.catch_warnings():
        # an empty core window is this function's error, with what to do about it
        warnings.simplefilter("ignore", MicrostructureWarning)
        phi, _ = sample_phi(pack)
    if not math.isfinite(phi):
        shown = (
            "" if value is None else f" = {value:g}" if isinstance(value, float) else f" = {value}"
        )
        raise InvalidParameterError(
            f"invalid {parameter}{shown}: the pack has no core window to measure phi in "
            "(it is lower than twice the analysis' core margin, or narrower); give a taller "
            "and wider scene, or a [consolidate] table (phi between the floor and the lid)",
            parameter=parameter,
            value=value,
        )
    return phi


def _deposit_at(
    scene: PackScene,
    mu_dep: float,
    progress: bool | Callable[[dict], None] = False,
    *,
    rolling_friction: float | None = None,
) -> Pack:
    """The scene's deposit with every layer jammed at friction `mu_dep` (and rolling
    friction `rolling_friction`: 0 without rolling resistance, None the material's
    rolling model), the material restored and the pack settled where needed (not
    consolidated): the scene's stages up to the consolidation, with the deposit's
    friction changed, and a settling (to REST_TOL where the scene sets no rest_tol)
    where the friction, or the rolling friction, was above the material's."""
    mat = scene.material
    settles = (
        mu_dep > mat.friction
        or (rolling_friction is not None and rolling_friction > _mu_r0(scene))
        or scene.rest_tol is not None
    )
    tol = scene.rest_tol if scene.rest_tol is not None else REST_TOL
    spec = deposit_stage.Spec(friction=mu_dep, rolling_friction=rolling_friction)
    steps = stages.with_spec(stages.plan(scene), "deposit", spec)
    steps = stages.with_spec(steps, "rest", rest_stage.Spec(tol) if settles else None)
    steps = stages.with_spec(steps, "consolidate", None)
    for name in stages.ELEMENT_STAGES:  # they run on the pack the search finds
        steps = stages.with_spec(steps, name, None)
    with warnings.catch_warnings():
        if settles or scene.consolidate is not None:
            # the deposit is brought to rest right after (settled below, or consolidated
            # to equilibrium by the caller): its motion at the end of the layer loop is
            # not the sample's
            warnings.simplefilter("ignore", UnsettledPackWarning)
        return stages.run(scene, steps, progress, _stacklevel=3)


def _consolidated(scene: PackScene, pack: Pack, **changes: Any) -> Pack:
    """`pack` consolidated as the scene's consolidation stage, its spec changed by
    `changes` (the servo's ``target_phi`` and ``density_tol``)."""
    spec = consolidate_stage.spec_of(scene)
    assert spec is not None
    return consolidate_stage.run(pack, stages.replace_spec(spec, **changes))


def _consolidation_report(pack: Pack) -> dict[str, Any]:
    """What a consolidated pack's consolidation measured."""
    rec = pack.record("consolidate")
    assert rec is not None
    return rec.report


def _at_friction(
    scene: PackScene,
    mu_dep: float,
    servo_phi: float | None = None,
    servo_tol: float = DEFAULT_TOL_PHI,
    progress: bool | Callable[[dict], None] = False,
    *,
    rolling_friction: float | None = None,
) -> Pack:
    """The scene's pack with every layer jammed at friction `mu_dep` (and rolling
    friction `rolling_friction`, as `_deposit_at`), the material restored, settled where
    needed, and consolidated when the scene asks (lowering the friction under the servo
    to `servo_phi` when given)."""
    pack = _deposit_at(scene, mu_dep, progress, rolling_friction=rolling_friction)
    if scene.consolidate is not None:
        pack = _consolidated(scene, pack, target_phi=servo_phi, density_tol=servo_tol)
    return pack


def _servo_end(scene: PackScene, deposit_pack: Pack) -> tuple[float, float]:
    """(phi at the material's friction, phi at zero friction) of `deposit_pack`
    consolidated as the scene asks, the friction lowered to zero under the servo (and,
    at zero friction, the rolling resistance off: `granpack.consolidate`'s phases): the
    servo's window."""
    assert scene.consolidate is not None
    try:
        sample = _consolidated(scene, deposit_pack, target_phi=_SERVO_PROBE)
    except DensityTargetError as e:
        if math.isfinite(e.phi_max):
            return float(e.phi_min), float(e.phi_max)
        raise
    # reached the probe: no pack is that dense, but were it, it is the end
    rec = _consolidation_report(sample)
    return float(rec["density"]["phi_before"]), float(rec["phi"])


def _u(mu: float) -> float:
    return math.log(mu + MU_SHIFT)


def _mu(u: float) -> float:
    """The friction at `u`, clamped to [0, MU_DEP_MAX] (before exp: a near-flat secant
    can point far beyond)."""
    return min(max(math.exp(min(u, _u(MU_DEP_MAX))) - MU_SHIFT, 0.0), MU_DEP_MAX)


#: A deposit's jam: (mu_dep, mu_r), its friction and its rolling friction (-); mu_r is 0
#: for a scene without a rolling model, and for a jam without rolling resistance.
Point = tuple[float, float]


def _mu_r0(scene: PackScene) -> float:
    """The material's rolling friction mu_r (-), 0 without a rolling model."""
    mat = scene.material
    return float(mat.rolling_friction) if has_rolling(mat) and mat.rolling_friction else 0.0


def _on_line(scene: PackScene, mu: float) -> Point:
    """The jam at deposition friction `mu` with the material's rolling friction, except
    the frictionless jam (mu = 0 below a material with friction), which stands for the
    densest deposit: without rolling resistance either."""
    mu = float(mu)
    if mu == 0.0 and scene.material.friction > 0.0:
        return (mu, 0.0)
    return (mu, _mu_r0(scene))


def _grid(scene: PackScene) -> tuple[Point, ...]:
    """The jams the window is measured at: every deposition friction of MU_DEP_GRID and
    the material's own (`_on_line`), then, for a material with a rolling model, the
    material's friction with every rolling friction of MU_R_GRID and the material's
    own."""
    mu0 = float(scene.material.friction)
    line = [_on_line(scene, mu) for mu in sorted({*MU_DEP_GRID, mu0})]
    if has_rolling(scene.material):
        line += [(mu0, float(r)) for r in sorted({*MU_R_GRID, _mu_r0(scene)})]
    return tuple(dict.fromkeys(line))


def _uses_servo(scene: PackScene) -> bool:
    return scene.consolidate is not None and scene.density_method != "deposition"


def _describe(mechanism: str, point: Point, rolling: bool = False) -> str:
    """What made a pack of the window; `rolling`: the scene has a rolling model, and the
    jam's mu_r is named too."""
    if mechanism == "servo":
        return "the recipe's sample, friction lowered to zero under the servo" + (
            " (rolling resistance off)" if rolling else ""
        )
    return f"layers jammed at {_jam(point, rolling, 'g')}"


def _jam(point: Point, rolling: bool, fmt: str) -> str:
    """A jam as text: "mu_dep = 0.2", with ", mu_r = 0.1" for a rolling scene."""
    text = f"mu_dep = {point[0]:{fmt}}"
    return text + f", mu_r = {point[1]:{fmt}}" if rolling else text


@dataclasses.dataclass(frozen=True)
class VoidRatioLimits:
    """The model's e_min and e_max for a scene (`void_ratio_limits`).

    Attributes:
        e_min, e_max: the mean void ratio (-) of the densest and the loosest packs.
        e_min_sd, e_max_sd: their sample standard deviation over the packs (0 for one).
        e_min_values, e_max_values: each pack's.
        measure: "sample" (floor to lid, a consolidating scene) or "core".
        packs: how many streams each end was measured on (the scene's stream and the
            next ones, of its seed).
        e_min_from, e_max_from: per stream, what made its densest and its loosest pack
            ("layers jammed at mu_dep = 0", "the recipe's sample, friction lowered to zero
            under the servo").
        points: every pack measured, as (stream, mechanism, friction, phi): mechanism
            "deposition" (friction: mu_dep) or "servo" (friction: 0, the servo's end).
        rolling_frictions: for a material with a rolling model, each point's rolling
            friction mu_r (-) during its layers (0 for the frictionless jam and the
            servo's end, which run without rolling resistance); empty otherwise.
    """

    e_min: float
    e_max: float
    e_min_sd: float
    e_max_sd: float
    e_min_values: tuple[float, ...]
    e_max_values: tuple[float, ...]
    measure: str
    packs: int
    e_min_from: tuple[str, ...] = ()
    e_max_from: tuple[str, ...] = ()
    points: tuple[tuple[int, str, float, float], ...] = ()
    rolling_frictions: tuple[float, ...] = ()

    @property
    def phi_min(self) -> float:
        """The loosest packing fraction, 1 / (1 + e_max)."""
        return 1.0 / (1.0 + self.e_max)

    @property
    def phi_max(self) -> float:
        """The densest packing fraction, 1 / (1 + e_min)."""
        return 1.0 / (1.0 + self.e_min)

    def relative_density(self, e: float) -> float:
        """Dr = (e_max - e) / (e_max - e_min) of void ratio `e` (-).

        Raises InvalidParameterError where the window has no width (e_max = e_min: every
        pack measured has the same phi), where Dr has no meaning."""
        width = self.e_max - self.e_min
        if not width > 0.0:
            raise InvalidParameterError(
                f"invalid relative density: the window has no width (e_min = "
                f"{self.e_min:.6g}, e_max = {self.e_max:.6g}): every pack measured has the "
                "same void ratio, so the relative density is undefined; give a void ratio "
                "or phi instead",
                parameter="target_relative_density",
            )
        return (self.e_max - e) / width


def void_ratio_limits(
    scene: PackScene,
    packs: int = 5,
    progress: bool | Callable[[dict], None] = False,
) -> VoidRatioLimits:
    """e_min and e_max of the model for `scene`'s size distribution, container and
    material, each over `packs` streams: the measured extremes over what granpack makes.

    Per stream, one pack with every layer jammed at each deposition friction of
    MU_DEP_GRID (0, 0.1, 0.2, 0.5, 1) and at the material's own (for a material with a
    rolling model: with its rolling friction, except at mu_dep = 0, the frictionless
    jam, which has no rolling resistance either; and at the material's friction with
    each rolling friction of MU_R_GRID, 0, 0.1, 0.2, 0.4, and the material's own), each
    given the material back, settled (REST_TOL, or the scene's rest_tol) and, when the
    scene consolidates, consolidated at the material's friction; and, when the scene
    consolidates (unless its density_method is "deposition"), the recipe's deposit
    consolidated with its friction lowered to zero under the servo (rolling resistance
    off at zero friction). e_min is the void
    ratio of the densest of these, e_max of the loosest (phi is not monotone in the
    deposition friction once the pack is settled and consolidated, so neither is
    assumed). The void ratio is the sample's (floor to lid) when the scene consolidates,
    the core window's otherwise (see `sample_phi`). The scene's density target, if any,
    plays no part. The streams are the scene's and the next ``packs - 1``.

    Parameters
    ----------
    scene : PackScene
    packs : int
        Streams per end, in [1, 1000]. Default 5.
    progress : bool or callable
        A callable gets a dict per pack (stream, mechanism, friction, phi, void_ratio,
        seconds; and rolling_friction, for a material with a rolling model); True prints
        one line per pack to stderr.

    Raises
    ------
    InvalidParameterError
        A deposit without a core window to measure phi in (``parameter="scene"``), or
        `packs` out of range.
    """
    if not isinstance(scene, PackScene):
        raise InvalidParameterError(
            f"invalid scene = {scene!r}: must be a granpack.PackScene", parameter="scene"
        )
    packs = as_int("packs", packs, 1, 1000)
    measure = "sample" if scene.consolidate is not None else "core"
    e_min: list[float] = []
    e_max: list[float] = []
    dense_from: list[str] = []
    loose_from: list[str] = []
    points: list[tuple[int, str, float, float]] = []
    rolls: list[float] = []
    rolling = has_rolling(scene.material)
    recipe = (float(scene.material.friction), _mu_r0(scene))
    for k in range(packs):
        stream = scene.stream + k
        sc = scene.replace(stream=stream)
        here: list[tuple[str, Point, float]] = []
        for point in _grid(sc):
            t0 = time.perf_counter()
            dep = _deposit_at(sc, point[0], rolling_friction=point[1] if rolling else None)
            pack = _consolidated(sc, dep) if sc.consolidate is not None else dep
            here.append(("deposition", point, _measured_phi(pack, "scene", None)))
            _report_point(progress, stream, here[-1], t0, rolling)
            if point == recipe and _uses_servo(sc):
                t0 = time.perf_counter()
                here.append(("servo", (0.0, 0.0), _servo_end(sc, dep)[1]))
                _report_point(progress, stream, here[-1], t0, rolling)
        points += [(stream, m, p[0], phi) for m, p, phi in here]
        rolls += [p[1] for _, p, _ in here] if rolling else []
        dense = max(here, key=lambda p: p[2])
        loose = min(here, key=lambda p: p[2])
        e_min.append(1.0 / dense[2] - 1.0)
        e_max.append(1.0 / loose[2] - 1.0)
        dense_from.append(_describe(dense[0], dense[1], rolling))
        loose_from.append(_describe(loose[0], loose[1], rolling))
    return _limits(e_min, e_max, measure, dense_from, loose_from, points, rolls)


def _limits(
    e_min: list[float],
    e_max: list[float],
    measure: str,
    dense_from: list[str],
    loose_from: list[str],
    points: list[tuple[int, str, float, float]],
    rolling_frictions: list[float] | None = None,
) -> VoidRatioLimits:
    """The limits from each stream's ends (the mean of one pack is its value, exactly),
    checked for order: each stream's ends are the extremes of its own packs, so a mean
    e_min above the mean e_max cannot happen, and would be a defect."""
    sd = {
        k: statistics.stdev(v) if len(v) > 1 else 0.0 for k, v in (("min", e_min), ("max", e_max))
    }
    lim = VoidRatioLimits(
        e_min=statistics.fmean(e_min),
        e_max=statistics.fmean(e_max),
        e_min_sd=sd["min"],
        e_max_sd=sd["max"],
        e_min_values=tuple(e_min),
        e_max_values=tuple(e_max),
        measure=measure,
        packs=len(e_min),
        e_min_from=tuple(dense_from),
        e_max_from=tuple(loose_from),
        points=tuple(points),
        rolling_frictions=tuple(rolling_frictions or ()),
    )
    if not lim.e_min <= lim.e_max:
        raise AssertionError(f"the window's ends cross: e_min {lim.e_min} > e_max {lim.e_max}")
    return lim


def _report_point(
    progress, stream: int, point: tuple[str, Point, float], t0: float, rolling: bool
) -> None:
    mechanism, (friction, rolling_friction), phi = point
    row: dict[str, Any] = {"stream": stream, "mechanism": mechanism, "friction": friction}
    if rolling:
        row["rolling_friction"] = rolling_friction
    row.update(phi=phi, void_ratio=1.0 / phi - 1.0, seconds=time.perf_counter() - t0)
    _report(progress, row)


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


class _Runs:
    """The packs one target's search made of the scene (its seed and stream), each made
    once: deposition samples by jam (mu_dep, mu_r), the recipe's deposit, and the
    servo's window."""

    def __init__(self, scene: PackScene, key: str, value: float, progress) -> None:
        self.scene = scene
        self.key = key
        self.value = value
        self.progress = progress
        self.rolling = has_rolling(scene.material)
        self.mu0 = float(scene.material.friction)
        self.p0: Point = (self.mu0, _mu_r0(scene))  # the recipe's jam
        self.phi: dict[Point, float] = {}  # deposition samples' phi by jam
        self.packs: dict[Point, Pack] = {}
        self.recipe_deposit: Pack | None = None
        self.servo: tuple[float, float] | None = None  # (phi at mu0, phi at zero friction)
        self.history: list[dict[str, Any]] = []

    @property
    def generations(self) -> int:
        """Layer loops run: one per jam measured."""
        return len(set(self.phi) | ({self.p0} if self.recipe_deposit is not None else set()))

    def entry(self, point: Point, **values: Any) -> dict[str, Any]:
        """A history entry of the jam `point`: its friction, its rolling friction for a
        scene with a rolling model, then `values`."""
        out: dict[str, Any] = {"friction": point[0]}
        if self.rolling:
            out["rolling_friction"] = point[1]
        return {**out, **values}

    def deposit(self, point: Point) -> Pack:
        roll = point[1] if self.rolling else None
        if point == self.p0:
            if self.recipe_deposit is None:
                self.recipe_deposit = _deposit_at(
                    self.scene, point[0], self.progress, rolling_friction=roll
                )
            return self.recipe_deposit
        return _deposit_at(self.scene, point[0], self.progress, rolling_friction=roll)

    def sample(self, point: Point) -> tuple[Pack, float]:
        """The deposition sample of the jam `point` (made again, bit for bit, where only
        its phi was kept)."""
        if point not in self.packs:
            t = time.perf_counter()
            pack = self.deposit(point)
            if self.scene.consolidate is not None:
                pack = _consolidated(self.scene, pack)
            phi = _measured_phi(pack, self.key, self.value)
            self.packs[point] = pack
            if point not in self.phi:
                self.phi[point] = phi
                self.history.append(
                    self.entry(point, phi=phi, method="deposition", seconds=time.perf_counter() - t)
                )
        return self.packs[point], self.phi[point]

    def servo_window(self) -> tuple[float, float]:
        if self.servo is None:
            t = time.perf_counter()
            self.servo = _servo_end(self.scene, self.deposit(self.p0))
            self.phi.setdefault(self.p0, self.servo[0])
            self.history.append(
                self.entry(
                    (0.0, 0.0),
                    phi=self.servo[1],
                    method="servo window",
                    seconds=time.perf_counter() - t,
                )
            )
        return self.servo

    def window(self, every: bool = False) -> tuple[tuple[float, str], tuple[float, str]]:
        """((phi, what) of the loosest, of the densest) over the grid's packs and (where
        the scene uses it) the servo's end, measuring those not measured yet: the same
        packs, and so the same window, as `void_ratio_limits` of this seed and stream.
        `every`: over the search's other packs too, the window it reached."""
        grid = _grid(self.scene)
        for point in grid:
            if point not in self.phi:
                self.sample(point)
        pts = [
            (self.phi[p], _describe("deposition", p, self.rolling))
            for p in (self.phi if every else grid)
        ]
        if _uses_servo(self.scene):
            pts.append((self.servo_window()[1], _describe("servo", (0.0, 0.0), self.rolling)))
        return min(pts), max(pts)

    def grid_measured(self) -> bool:
        return all(p in self.phi for p in _grid(self.scene))


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
        window, measured over the grid of deposition frictions and the servo), or the
        search did not reach it in MAX_GENERATIONS packs.
    InvalidParameterError
        A relative density where every pack measured has the same phi (the window has no
        width), or a deposit with no core window to measure phi in.

    Warns
    -----
    DensityWindowWarning
        A relative density's sample lies outside the window measured for it (by at most
        the tolerance, or the change when the friction was restored after the servo).
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
    runs = _Runs(scene, key, value, progress)
    measure = "sample" if scene.consolidate is not None else "core"

    limits = None
    if key == "target_relative_density":
        # Dr needs e_min and e_max: the extremes of this seed's packs, over the grid
        # and the servo, which then bracket the search as well
        (phi_loose, loose_from), (phi_dense, dense_from) = runs.window()
        limits = _limits(
            [1.0 / phi_dense - 1.0],
            [1.0 / phi_loose - 1.0],
            measure,
            [dense_from],
            [loose_from],
            [],
        )
        limits.relative_density(limits.e_min)  # the window has a width, or the error
    phi_t, lo, hi, tol = _band(key, value, scene.density_tol, limits)

    def finish(pack: Pack, phi: float, method: str, point: Point) -> Pack:
        e = 1.0 / phi - 1.0
        record: dict[str, Any] = {
            "target": {key: value},
            "target_phi": phi_t,
            "density_tol": tol,
            "measure": measure,
            "method": method,
            "friction": point[0],
            **({"rolling_friction": point[1]} if runs.rolling else {}),
            "phi": phi,
            "void_ratio": e,
            "generations": runs.generations,
            "history": runs.history,
            "seconds": time.perf_counter() - t0,
        }
        if limits is not None:
            record["e_min"], record["e_max"] = limits.e_min, limits.e_max
            dr = limits.relative_density(e)
            record["relative_density"] = dr
            if not 0.0 <= dr <= 1.0:
                warnings.warn(
                    f"{key} = {value:g}: the sample's relative density is {dr:.4f}, outside "
                    f"[0, 1]: its e = {e:.4f} lies beyond the window [{limits.e_min:.4f}, "
                    f"{limits.e_max:.4f}] measured on this seed's packs, within the "
                    f"target's tolerance ({tol:g}) of an end"
                    + (
                        "; the servo measured its end at zero friction, and restoring the "
                        "material's friction moved this sample"
                        if method == "servo"
                        else ""
                    ),
                    DensityWindowWarning,
                    stacklevel=4,
                )
        return pack.with_record(
            StageRecord.from_table("density", record),
            wall_time=time.perf_counter() - t0,
        )

    # a pack measured for the window already meets the target: the nearest
    hit = _best_in_band(runs, lo, hi, phi_t) if scene.density_method != "servo" else None
    if hit is not None:
        pack, phi = runs.sample(hit)
        return finish(pack, phi, "deposition", hit)

    method = scene.density_method
    if method == "auto":
        method = "servo" if scene.consolidate is not None else "deposition"
    if method == "servo":
        phi0 = runs.servo[0] if runs.servo is not None else runs.phi.get(runs.p0)
        if scene.density_method == "servo" or phi0 is None or phi0 < phi_t:
            t = time.perf_counter()
            try:
                pack = _consolidated(
                    scene,
                    runs.deposit(runs.p0),
                    target_phi=phi_t,
                    density_tol=min(hi - phi_t, phi_t - lo),
                )
                phi = _measured_phi(pack, key, value)
                runs.history.append(
                    runs.entry(
                        runs.p0,
                        phi=phi,
                        method="servo",
                        seconds=time.perf_counter() - t,
                        phases=_consolidation_report(pack)["density"]["phases"],
                    )
                )
                return finish(pack, phi, "servo", runs.p0)
            except DensityTargetError as e:
                runs.history.append(
                    runs.entry(
                        runs.p0, phi=e.realised, method="servo", seconds=time.perf_counter() - t
                    )
                )
                # the servo's first equilibrium is the recipe's sample, bit for bit
                runs.phi.setdefault(runs.p0, float(e.phi_min))
                if math.isfinite(e.phi_max):
                    runs.servo = (float(e.phi_min), float(e.phi_max))
                if scene.density_method == "servo":
                    raise _renamed(e, key, value, phi_t) from None
    return _search(key, value, phi_t, lo, hi, runs, finish)


def _best_in_band(runs: _Runs, lo: float, hi: float, phi_t: float) -> Point | None:
    """The measured jam whose phi lies in [lo, hi], nearest the target."""
    inside = [p for p, phi in runs.phi.items() if lo <= phi <= hi]
    if not inside:
        return None
    return min(inside, key=lambda p: (abs(runs.phi[p] - phi_t), p))


def _search(key, value, phi_t, lo, hi, runs: _Runs, finish) -> Pack:
    """The secant search of the deposition friction in ln(mu + MU_SHIFT), from the
    recipe's friction or from the packs measured: inside the best bracket where the
    packs bracket the target, over the measured grid where they do not. For a material
    with a rolling model, a bracket among the rolling frictions of the grid (at the
    material's friction) is split the same way, in ln(mu_r + MU_SHIFT), where the
    deposition frictions give none."""
    extrapolations = 0
    while True:
        hit = _best_in_band(runs, lo, hi, phi_t)
        if hit is not None:
            pack, phi = runs.sample(hit)
            return finish(pack, phi, "deposition", hit)
        point, extrapolated = _next_friction(runs, phi_t, extrapolations)
        if point is None:
            break
        if runs.generations >= MAX_GENERATIONS:
            raise _not_reached(key, value, phi_t, runs, f"in {MAX_GENERATIONS} packs")
        extrapolations += extrapolated
        runs.sample(point)
    # every grid friction measured and no bracket left to split: out of the window that
    # every pack made spans, or phi jumps across the band
    (phi_min, loose_from), (phi_max, dense_from) = runs.window(every=True)
    if not phi_min <= phi_t <= phi_max:
        raise _out_of_window(key, value, phi_t, (phi_min, loose_from), (phi_max, dense_from))
    raise _not_reached(
        key,
        value,
        phi_t,
        runs,
        "in any pack: phi jumps across the band between neighbouring deposition frictions"
        + (
            ", and the servo did not reach it either"
            if runs.servo is not None and runs.servo[0] < phi_t <= runs.servo[1]
            else ""
        ),
        window=((phi_min, loose_from), (phi_max, dense_from)),
    )


def _bracket(
    pts: list[tuple[float, float]], phi_t: float
) -> tuple[tuple[float, float], tuple[float, float]] | None:
    """Among `pts` (knob, phi), sorted by the knob (mu_dep or mu_r), the bracket
    ((a, phi_a), (b, phi_b)) of the target where phi changes the least per unit of
    ln(knob + MU_SHIFT): the smooth part of the curve, rather than a jump (where
    splitting converges on the jump, never on the band); None without a bracket."""
    brackets = [
        (a, b)
        for a, b in zip(pts, pts[1:], strict=False)
        if (a[1] - phi_t) * (b[1] - phi_t) < 0 and _u(b[0]) - _u(a[0]) > MIN_BRACKET
    ]
    if not brackets:
        return None
    return min(brackets, key=lambda ab: abs(ab[1][1] - ab[0][1]) / (_u(ab[1][0]) - _u(ab[0][0])))


def _split(bracket, phi_t: float) -> tuple[float, bool]:
    """Regula falsi in ln(knob + MU_SHIFT), kept strictly inside `bracket`, and whether
    the bracket looks like a jump (STEEP)."""
    a, b = bracket
    ua, ub = _u(a[0]), _u(b[0])
    steep = abs(b[1] - a[1]) / (ub - ua) > STEEP
    u = ua + (phi_t - a[1]) * (ub - ua) / (b[1] - a[1])
    u = min(max(u, ua + 0.1 * (ub - ua)), ub - 0.1 * (ub - ua))
    return math.exp(u) - MU_SHIFT, steep


def _next_friction(runs: _Runs, phi_t: float, extrapolations: int) -> tuple[Point | None, int]:
    """The next jam to try, and 1 where it is an extrapolation (no bracket); None once
    the grid is measured and no bracket can be split. The deposition frictions (at the
    material's rolling friction) first; for a material with a rolling model, then the
    rolling frictions at the material's friction."""
    scene = runs.scene
    if not runs.phi:
        return runs.p0, 0
    untried = [p for p in _grid(scene) if p not in runs.phi]
    # the deposition frictions' line: the jams `_on_line` makes
    pts = sorted((p[0], phi) for p, phi in runs.phi.items() if p == _on_line(scene, p[0]))
    bracket = _bracket(pts, phi_t)
    if bracket is not None:
        mu, steep = _split(bracket, phi_t)
        if steep and untried:
            # a jump, by the look of it: the grid may hold a smoother bracket
            return _toward(runs, phi_t, untried), 0
        return _on_line(scene, mu), 0
    if runs.rolling:
        # the rolling frictions' line, at the material's friction
        rolls = sorted((p[1], phi) for p, phi in runs.phi.items() if p[0] == runs.mu0)
        bracket = _bracket(rolls, phi_t)
        if bracket is not None:
            mu_r, steep = _split(bracket, phi_t)
            if steep and untried:
                return _toward(runs, phi_t, untried), 0
            return (runs.mu0, mu_r), 0
    if extrapolations < MAX_EXTRAPOLATIONS and not runs.grid_measured():
        near = sorted(pts, key=lambda p: abs(p[1] - phi_t))
        if len(near) == 1:
            (mu, phi) = near[0]
            u = _u(mu) + (phi_t - phi) / SLOPE_GUESS
        else:
            (ma, pa), (mb, pb) = near[:2]
            ua, ub = _u(ma), _u(mb)
            # only along the falling slope that deposits have; any other points the
            # search to the grid
            u = ua + (phi_t - pa) * (ub - ua) / (pb - pa) if (pb - pa) * (ub - ua) < 0 else math.nan
        if math.isfinite(u):
            nxt = _on_line(scene, _mu(u))
            if nxt not in runs.phi:
                return nxt, 1
    if not untried:
        return None, 0
    return _toward(runs, phi_t, untried), 0


def _toward(runs: _Runs, phi_t: float, untried: list[Point]) -> Point:
    """The untried grid jam toward the side the target lies on: the frictionless end
    first for a target denser than every pack measured, the loosest end first otherwise
    (the largest rolling friction, for a material with a rolling model)."""
    denser = phi_t > max(runs.phi.values(), default=-1.0)
    return untried[0] if denser else untried[-1]


def _out_of_window(key, value, phi_t, loose, dense) -> DensityTargetError:
    (phi_min, loose_from), (phi_max, dense_from) = loose, dense
    return DensityTargetError(
        f"invalid {key} = {value:g} (phi = {phi_t:.4f}): out of reach; the packs this scene "
        f"and seed make go from phi = {phi_min:.4f} (the loosest: {loose_from}) to "
        f"{phi_max:.4f} (the densest: {dense_from}): the window is [{phi_min:.4f}, "
        f"{phi_max:.4f}], e in [{1 / phi_max - 1:.4f}, {1 / phi_min - 1:.4f}]",
        parameter=key,
        value=value,
        target_phi=phi_t,
        phi_min=phi_min,
        phi_max=phi_max,
    )


def _not_reached(key, value, phi_t, runs: _Runs, why: str, window=None) -> DensityTargetError:
    """The target lies between packs the search made, but no pack met it."""
    best_at = min(runs.phi, key=lambda p: abs(runs.phi[p] - phi_t))
    best = runs.phi[best_at]
    if window is None and runs.grid_measured():
        window = runs.window(every=True)
    if window is not None:
        (phi_min, _), (phi_max, _) = window
        where = f"; the packs made span the window [{phi_min:.4f}, {phi_max:.4f}]"
    else:
        phi_min = phi_max = math.nan
        where = (
            f"; the packs measured span phi = [{min(runs.phi.values()):.4f}, "
            f"{max(runs.phi.values()):.4f}]"
        )
    return DensityTargetError(
        f"{key} = {value:g} (phi = {phi_t:.4f}) not reached {why.lstrip('; ')} "
        f"(nearest: phi = {best:.4f} at {_jam(best_at, runs.rolling, '.4g')}){where}; phi changes "
        "between neighbouring deposition frictions by more than the tolerance here (the "
        "spread of phi between packs grows as the pack gets smaller): give a larger "
        "density_tol or a larger scene",
        parameter=key,
        value=value,
        target_phi=phi_t,
        phi_min=phi_min,
        phi_max=phi_max,
        realised=best,
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
