"""The consolidation stage's settings: the modes, the walls each container has, and the
checks of a `[consolidate]` table (keys, types, ranges, the mode against the container),
for the scene, which checks its table when it is built, and for `consolidate`."""

from __future__ import annotations

from numbers import Real

import numpy as np

from . import _core
from ._validate import as_int, as_real, short_repr
from .errors import InvalidParameterError

#: The consolidation modes.
MODES = ("oedometric", "isotropic", "anisotropic")


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
        values = [as_real(prefix + "lateral", lateral, 0, 1e12, lo_open=True, unit="Pa")] * (
            dim - 1
        )
    else:
        try:
            values = [
                as_real(prefix + "lateral", v, 0, 1e12, lo_open=True, unit="Pa") for v in lateral
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
    stress = as_real(prefix + "stress", stress, 0, 1e12, lo_open=True, unit="Pa")
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
