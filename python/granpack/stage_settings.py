"""The consolidation stage's settings: the modes, the walls each container has, and the
checks of a `[consolidate]` table (keys, types, ranges, the mode against the container),
for the scene, which checks its table when it is built, and for `consolidate`."""

from __future__ import annotations

import math
from numbers import Real

import numpy as np

from . import _core
from ._validate import as_int, as_real, short_repr
from .errors import InvalidParameterError, UnstableTimeStepError

#: The consolidation modes.
MODES = ("oedometric", "isotropic", "anisotropic")

#: The largest target stress any stage takes (Pa; N/m in 2D), whatever the material.
MAX_STRESS = 1e12

#: The smallest overlap, over the mean radius, that a stress target may ask of a mean
#: contact. Below it the overlap is lost in the rounding of the positions (1e-9 r is
#: still about 1e5 units in the last place of a centre a hundred radii from the origin,
#: but a stress a thousand times smaller needs 1e-11 r) and the servo cannot measure the
#: stress it drives; a subnormal target would even make the stage's step infinite.
MIN_OVERLAP_RATIO = 1e-9


def hertz_overlap(force: float, r_eff: float, e_star: float) -> float:
    """The overlap (m) at which a Hertz contact of effective radius `r_eff` carries
    `force`: F = 4/3 E* sqrt(R*) d^(3/2)."""
    return (3.0 * force / (4.0 * e_star * math.sqrt(r_eff))) ** (2.0 / 3.0)


def overlap_ratio(stress: float, dim: int, r_mean: float, e_star: float) -> float:
    """The overlap over the radius (-) that a mean contact of two mean spheres needs to
    carry `stress` (Pa; N/m in 2D): the force sigma (2 r)^(D-1) on a Hertz contact of
    R* = r / 2."""
    force = stress * (2.0 * r_mean) ** (dim - 1)
    return hertz_overlap(force, 0.5 * r_mean, e_star) / r_mean


def stress_range(
    dim: int, r_mean: float, e_star: float, max_overlap_ratio: float
) -> tuple[float, float]:
    """The stresses (Pa; N/m in 2D) a stage takes for particles of mean radius `r_mean`
    (m) of a material of effective modulus `e_star` (Pa): those whose mean contact needs
    an overlap between MIN_OVERLAP_RATIO and `max_overlap_ratio` of the radius, and at
    most MAX_STRESS."""

    def at(ratio: float) -> float:
        d = ratio * r_mean
        force = 4.0 / 3.0 * e_star * math.sqrt(0.5 * r_mean) * d**1.5
        return force / (2.0 * r_mean) ** (dim - 1)

    return at(MIN_OVERLAP_RATIO), min(at(max_overlap_ratio), MAX_STRESS)


def check_stresses(
    targets: dict[str, float],
    *,
    dim: int,
    r_mean: float,
    material,
    max_overlap_ratio: float,
    prefix: str = "",
) -> None:
    """Refuses a target stress the stage cannot drive, naming its own key (`stress` for
    the lid, `lateral` for the side walls, after `prefix`) and the range it may take:
    one whose mean contact overlaps beyond `max_overlap_ratio` of the radius (the Hertz
    law does not hold there) or less than MIN_OVERLAP_RATIO (the positions cannot
    resolve it)."""
    e_star = material.e_star
    lo, hi = stress_range(dim, r_mean, e_star, max_overlap_ratio)
    for wall, value in targets.items():
        key = prefix + ("stress" if wall == "lid" else "lateral")
        est = overlap_ratio(value, dim, r_mean, e_star)
        if est > max_overlap_ratio:
            why = (
                f"it needs overlaps of about {est:.3g} of the radius, beyond "
                f"max_overlap_ratio = {max_overlap_ratio:g}, where the Hertz law does not "
                "hold; lower the stress or stiffen the material"
            )
        elif est < MIN_OVERLAP_RATIO:
            why = (
                f"it needs overlaps of about {est:.3g} of the radius, below the "
                f"{MIN_OVERLAP_RATIO:g} that the positions resolve, so the servo could not "
                "measure it"
            )
        else:
            continue
        allowed = f"[{lo:.3g}, {hi:.3g}] Pa"
        raise InvalidParameterError(
            f"invalid {key} = {value:g} Pa: with E = {material.young:g} Pa and a mean radius "
            f"{r_mean:g} m {why}. It must lie in {allowed}",
            parameter=key,
            value=value,
            expected=allowed,
        )


def check_time_step(dt: float | None, material, r_min: float, prefix: str = "") -> None:
    """Refuses a stage's `dt` beyond the Rayleigh step of the smallest particle, naming
    it as `prefix` + ``dt``."""
    if dt is None:
        return
    crit = material.critical_time_step(r_min)
    if dt > crit:
        err = UnstableTimeStepError(
            f"invalid {prefix}dt = {dt:g} s: must lie in (0, {crit:.6g}] s, the critical "
            f"(Rayleigh) time step for r_min = {r_min:g} m",
            dt=dt,
            critical=crit,
            r_min=r_min,
        )
        err.parameter = prefix + "dt"
        raise err


def _wall_names(kind: str, dim: int) -> list[str]:
    """The walls of a container in the engine's order, the lid last."""
    if kind == "cylinder":
        return ["floor", "cylinder", "lid"]
    if kind == "periodic":
        return ["floor", "lid"]
    sides = ["x_lo", "x_hi"] + (["y_lo", "y_hi"] if dim == 3 else [])
    return ["floor", *sides, "lid"]


def _targets(
    mode: str, kind: str, dim: int, stress: float, lateral, prefix: str = ""
) -> dict[str, float]:
    names = _wall_names(kind, dim)
    if mode == "oedometric":
        if lateral is not None:
            raise InvalidParameterError(
                f"invalid {prefix}lateral: an oedometric stage controls the lid alone (the side "
                "walls stay where they are); give mode='anisotropic' for a lateral target",
                parameter=prefix + "lateral",
            )
        return {"lid": stress}
    if kind == "periodic":
        raise InvalidParameterError(
            f"invalid {prefix}mode = {mode!r}: a periodic cell has no lateral walls to control; "
            "use mode='oedometric'",
            parameter=prefix + "mode",
            value=mode,
            expected="oedometric (in a periodic cell)",
        )
    sides = [n for n in names if n not in ("floor", "lid")]
    if mode == "isotropic":
        if lateral is not None:
            raise InvalidParameterError(
                f"invalid {prefix}lateral: an isotropic stage gives every wall the same stress; "
                "give mode='anisotropic' for a separate lateral target",
                parameter=prefix + "lateral",
            )
        return {"lid": stress, **{n: stress for n in sides}}
    if lateral is None:
        raise InvalidParameterError(
            f"invalid {prefix}lateral = None: an anisotropic stage needs the lateral target stress "
            "(Pa): one value, or (sigma_xx, sigma_yy) in a 3D box",
            parameter=prefix + "lateral",
        )
    if isinstance(lateral, Real | np.floating | np.integer) and not isinstance(lateral, bool):
        values = [as_real(prefix + "lateral", lateral, 0, MAX_STRESS, lo_open=True, unit="Pa")] * (
            dim - 1
        )
    else:
        try:
            values = [
                as_real(prefix + "lateral", v, 0, MAX_STRESS, lo_open=True, unit="Pa")
                for v in lateral
            ]
        except TypeError:
            raise InvalidParameterError(
                f"invalid {prefix}lateral = {short_repr(lateral)}: expected a stress (Pa) or "
                "(sigma_xx, sigma_yy)",
                parameter=prefix + "lateral",
            ) from None
        if kind == "cylinder" and len(values) != 1:
            raise InvalidParameterError(
                f"invalid {prefix}lateral = {short_repr(lateral)}: a cylinder has one lateral "
                "stress, sigma_rr",
                parameter=prefix + "lateral",
            )
        if kind == "box" and len(values) != dim - 1:
            raise InvalidParameterError(
                f"invalid {prefix}lateral = {short_repr(lateral)}: a {dim}D box takes "
                f"{dim - 1} lateral stresses",
                parameter=prefix + "lateral",
            )
    out = {"lid": stress}
    for n in sides:
        out[n] = values[0] if (kind == "cylinder" or n.startswith("x")) else values[-1]
    return out


#: The keys of a scene's [consolidate] table: `consolidate`'s keyword arguments.
TABLE_KEYS = (
    "stress",
    "mode",
    "lateral",
    "gravity",
    "stress_tol",
    "unbalanced_tol",
    "hold",
    "check_every",
    "max_steps",
    "max_wall_speed",
    "gain",
    "local_damping",
    "dt",
)


def _settings(prefix: str, table: dict) -> dict:
    """Every setting typed and in its range (errors name `prefix` + the key); what
    depends on the pack (the overlap at the target, the wall speed's cap) is checked by
    `consolidate`."""
    stress, mode, lateral, gravity = (table[k] for k in ("stress", "mode", "lateral", "gravity"))
    max_wall_speed, dt = table["max_wall_speed"], table["dt"]
    stress = as_real(prefix + "stress", stress, 0, MAX_STRESS, lo_open=True, unit="Pa")
    if not isinstance(mode, str) or mode not in MODES:
        raise InvalidParameterError(
            f"invalid {prefix}mode = {short_repr(mode)}: must be one of {', '.join(MODES)}",
            parameter=prefix + "mode",
        )
    if gravity is not None and not isinstance(gravity, bool | np.bool_):
        raise InvalidParameterError(
            f"invalid {prefix}gravity = {short_repr(gravity)}: must be true or false",
            parameter=prefix + "gravity",
        )
    if lateral is not None and not (
        isinstance(lateral, Real | np.floating | np.integer) and not isinstance(lateral, bool)
    ):
        try:
            lateral = tuple(lateral)
        except TypeError:
            raise InvalidParameterError(
                f"invalid {prefix}lateral = {short_repr(lateral)}: expected a stress (Pa) "
                "or (sigma_xx, sigma_yy)",
                parameter=prefix + "lateral",
            ) from None
    return {
        "stress": stress,
        "mode": mode,
        "lateral": lateral,
        "gravity": None if gravity is None else bool(gravity),
        "stress_tol": as_real(prefix + "stress_tol", table["stress_tol"], 1e-9, 1, hi_open=True),
        "unbalanced_tol": as_real(
            prefix + "unbalanced_tol", table["unbalanced_tol"], 1e-9, 1, hi_open=True
        ),
        "hold": as_int(prefix + "hold", table["hold"], 1, 1000),
        "check_every": as_int(prefix + "check_every", table["check_every"], 1, 1_000_000),
        "max_steps": as_int(
            prefix + "max_steps", table["max_steps"], 1, int(_core.MAX_STEPS_PER_CALL)
        ),
        "max_wall_speed": None
        if max_wall_speed is None
        else as_real(
            prefix + "max_wall_speed", table["max_wall_speed"], 0, lo_open=True, unit="m/s"
        ),
        "gain": as_real(prefix + "gain", table["gain"], 0, 1, lo_open=True),
        "local_damping": as_real(
            prefix + "local_damping", table["local_damping"], 0, 1, hi_open=True
        ),
        "dt": None
        if dt is None
        else as_real(prefix + "dt", table["dt"], 0, lo_open=True, unit="s"),
    }


_DEFAULTS = {
    "mode": "oedometric",
    "lateral": None,
    "gravity": None,
    "stress_tol": 1e-3,
    "unbalanced_tol": 1e-4,
    "hold": 5,
    "check_every": 100,
    "max_steps": 2_000_000,
    "max_wall_speed": None,
    "gain": 0.5,
    "local_damping": 0.4,
    "dt": None,
}


def check_table(table, dim: int, container: str) -> dict:
    """A scene's [consolidate] table checked (keys, types, ranges, the mode against the
    container); returns it with the keys given, as numbers (what `generate` passes to
    `consolidate`). Errors name the key as ``consolidate.KEY``."""
    if not isinstance(table, dict):
        raise InvalidParameterError(
            f"invalid consolidate = {short_repr(table)}: expected a table of consolidation "
            f"settings ({', '.join(TABLE_KEYS)})",
            parameter="consolidate",
        )
    unknown = sorted(set(table) - set(TABLE_KEYS))
    if unknown:
        raise InvalidParameterError(
            f"invalid consolidate: unknown key {unknown[0]!r}; known: {', '.join(TABLE_KEYS)}",
            parameter=f"consolidate.{unknown[0]}",
        )
    if "stress" not in table:
        raise InvalidParameterError(
            "invalid consolidate: the table needs its target stress (Pa)",
            parameter="consolidate.stress",
        )
    s = _settings("consolidate.", {**_DEFAULTS, **table})
    _targets(s["mode"], container, dim, s["stress"], s["lateral"], prefix="consolidate.")
    out = {k: s[k] for k in table}
    if isinstance(out.get("lateral"), tuple):
        out["lateral"] = list(out["lateral"])
    return out


def check_scene_table(table: dict, scene) -> None:
    """The checks of a scene's [consolidate] table that need the scene's resolved radii
    and material: every target stress within `stress_range` and the stage's ``dt``
    within the Rayleigh step, so that a scene that is built does not fail in its
    consolidation after the deposit has been made. Errors name ``consolidate.KEY``. The
    stage checks again against the pack it gets (its own mean and smallest radius)."""
    s = _settings("consolidate.", {**_DEFAULTS, **table})
    prefix = "consolidate."
    targets = _targets(s["mode"], scene.container, scene.dim, s["stress"], s["lateral"], prefix)
    check_stresses(
        targets,
        dim=scene.dim,
        r_mean=scene.r_mean,
        material=scene.material,
        max_overlap_ratio=scene.max_overlap_ratio,
        prefix=prefix,
    )
    check_time_step(s["dt"], scene.material, scene.r_min, prefix)
