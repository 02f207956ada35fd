"""The element tests' settings, checked before any work: the checks of `granpack.triaxial`,
`granpack.oedometer` and `granpack.isotropic_compression` that do not depend on the
pack, and a scene's ``[triaxial]``, ``[oedometer]`` or ``[isotropic]`` table checked by
them when the scene is built (`granpack.PackScene`). It sits low, beside the other
checks of input, so that the scene reaches it without importing the tests themselves
(`granpack.element`); `TRIAXIAL_DEFAULTS` and `PATH_DEFAULTS` are the functions'
defaults, which tests/element/test_settings.py holds to their signatures."""

from __future__ import annotations

import inspect
import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from . import _core
from ._validate import short_repr
from .errors import InvalidParameterError

__all__ = [
    "TESTS",
    "TRIAXIAL_DEFAULTS",
    "PATH_DEFAULTS",
    "MAX_INERTIAL_NUMBER",
    "DEFAULT_INERTIAL_NUMBER",
    "MAX_CHECKS",
    "keys_of",
    "check_table",
    "check_scene_tables",
]

_C = _core.DEFAULT_CONSOLIDATE

#: The largest inertial number a test may run at: above 0.1 the flow is dense but no
#: longer quasi-static (GDR MiDi 2004), and a lab quantity measured there is the rate's.
MAX_INERTIAL_NUMBER = 0.1

#: The triaxial's default inertial number: the quasi-static limit of GDR MiDi (2004).
#: docs/element_tests.md gives what a tenth of it changes.
DEFAULT_INERTIAL_NUMBER = 1e-3

#: Most rows (checks) a test records.
MAX_CHECKS = 100_000


def _fail(key: str, value: Any, expected: str, why: str = "") -> InvalidParameterError:
    return InvalidParameterError(
        f"invalid {key} = {short_repr(value)}: must be {expected}{why}",
        parameter=key,
        value=value,
        expected=expected,
    )


def _real(key: str, value: Any, lo: float, hi: float, lo_open=True, hi_open=False) -> float:
    """`value` as a float within (lo, hi] (the brackets as given), or a typed error."""
    lo_b, hi_b = "(" if lo_open else "[", ")" if hi_open else "]"
    expected = f"a number in {lo_b}{lo:g}, {hi:g}{hi_b}"
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
        raise _fail(key, value, expected)
    v = float(value)
    if not math.isfinite(v):
        raise _fail(key, value, expected)
    if (v <= lo if lo_open else v < lo) or (v >= hi if hi_open else v > hi):
        raise _fail(key, value, expected)
    return v


def _count(key: str, value: Any, lo: int, hi: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not lo <= value <= hi:
        raise _fail(key, value, f"an integer in [{lo}, {hi}]")
    return int(value)


def _wall_friction(value: Any) -> float | None:
    if value is None:
        return None
    return _real("wall_friction", value, 0.0, math.inf, lo_open=False, hi_open=True)


def _flag(key: str, value: Any) -> bool:
    if not isinstance(value, bool):
        raise _fail(key, value, "True or False")
    return value


def _triaxial_values(
    *,
    confining: Any,
    axial_strain: Any,
    inertial_number: Any,
    constant_p: Any,
    checks: Any,
    local_damping: Any,
    gain: Any,
    wall_friction: Any,
) -> dict[str, Any]:
    """`triaxial`'s checks of the settings that do not depend on the pack, each value
    typed (`confining` None stays None: the pack's consolidation gives it); a bad one is
    an InvalidParameterError naming its key."""
    return {
        "confining": None
        if confining is None
        else _real("confining", confining, 0.0, _core.MAX_STRESS),
        "axial_strain": _real("axial_strain", axial_strain, 0.0, 1.0, hi_open=True),
        "inertial_number": _real("inertial_number", inertial_number, 0.0, MAX_INERTIAL_NUMBER),
        "constant_p": _flag("constant_p", constant_p),
        "checks": _count("checks", checks, 2, MAX_CHECKS),
        "local_damping": _real(
            "local_damping", local_damping, 0.0, 1.0, lo_open=False, hi_open=True
        ),
        "gain": _real("gain", gain, 0.0, 1.0),
        "wall_friction": _wall_friction(wall_friction),
    }


def _stresses(stresses: Any) -> list[float]:
    if isinstance(stresses, (str, bytes)) or not isinstance(stresses, Sequence | np.ndarray):
        raise _fail("stresses", stresses, "a list of stresses in (0, 1e12] Pa")
    if len(stresses) == 0:
        raise InvalidParameterError(
            "invalid stresses = []: give at least one stress (Pa) to load the sample to",
            parameter="stresses",
            value=[],
            expected="a non-empty list of stresses in (0, 1e12] Pa",
        )
    return [_real(f"stresses[{k}]", s, 0.0, _core.MAX_STRESS) for k, s in enumerate(stresses)]


def _path_values(
    scene: Any,
    *,
    stresses: Any,
    stress_tol: Any,
    unbalanced_tol: Any,
    hold: Any,
    check_every: Any,
    max_steps: Any,
    gain: Any,
    local_damping: Any,
    wall_friction: Any,
) -> dict[str, Any]:
    """`oedometer`'s and `isotropic_compression`'s checks of the settings that do not
    depend on the pack, each value typed; a bad one is an InvalidParameterError naming
    its key. `scene`: the pack's (its dim and container)."""
    stresses = _stresses(stresses)
    # the consolidation's checks of its own settings, by the same names
    checked = dict(
        _core.resolve_stage(
            "rest",
            scene,
            {
                "unbalanced_tol": unbalanced_tol,
                "hold": hold,
                "check_every": check_every,
                "max_steps": max_steps,
                "local_damping": local_damping,
            },
        )
    )
    return {
        "stresses": stresses,
        "stress_tol": _real("stress_tol", stress_tol, 1e-9, 1.0, lo_open=False, hi_open=True),
        **checked,
        "gain": _real("gain", gain, 0.0, 1.0),
        "wall_friction": _wall_friction(wall_friction),
    }


#: The element tests a scene may ask for, by their table's name (and their record's
#: stage), in the order of `granpack.stages.STAGES`.
TESTS = ("triaxial", "oedometer", "isotropic")

#: `granpack.triaxial`'s keyword arguments after the pack, and their defaults.
TRIAXIAL_DEFAULTS: dict[str, Any] = {
    "confining": None,
    "axial_strain": 0.25,
    "inertial_number": DEFAULT_INERTIAL_NUMBER,
    "constant_p": False,
    "checks": 100,
    "gravity": None,
    "local_damping": _C["local_damping"],
    "gain": _C["gain"],
    "wall_friction": 0.0,
    "dt": None,
}

#: `granpack.oedometer`'s and `granpack.isotropic_compression`'s keyword arguments
#: after the pack, and their defaults (``stresses`` has none).
PATH_DEFAULTS: dict[str, Any] = {
    "stresses": None,
    "stress_tol": _C["stress_tol"],
    "unbalanced_tol": _C["unbalanced_tol"],
    "hold": _C["hold"],
    "check_every": _C["check_every"],
    "max_steps": _C["max_steps"],
    "gain": _C["gain"],
    "local_damping": _C["local_damping"],
    "gravity": None,
    "wall_friction": 0.0,
    "dt": None,
}

_DEFAULTS = {"triaxial": TRIAXIAL_DEFAULTS, "oedometer": PATH_DEFAULTS, "isotropic": PATH_DEFAULTS}

#: The keys whose None (the function's default) a table may give: it is the same as
#: leaving the key out, and the scene drops it (TOML has no None).
_NONE_IS_DEFAULT = ("confining", "gravity", "dt")

#: The table's keys a test needs.
_REQUIRED = {"triaxial": (), "oedometer": ("stresses",), "isotropic": ("stresses",)}


def keys_of(test: str) -> tuple[str, ...]:
    """The keys of the ``[test]`` table: the test function's arguments after the pack."""
    return tuple(_DEFAULTS[test])


def _defaults(test: str) -> dict[str, Any]:
    return {k: v for k, v in _DEFAULTS[test].items() if k != "stresses"}


def _named(test: str, exc: InvalidParameterError) -> InvalidParameterError:
    """`exc` (a check's error, naming the function's argument) naming the table's key as
    the scene writes it: ``triaxial.axial_strain``."""
    text = str(exc)
    for word in ("invalid ", "missing "):
        if text.startswith(word):
            text = word + f"{test}." + text[len(word) :]
            break
    return InvalidParameterError(
        text, parameter=f"{test}.{exc.parameter}", value=exc.value, expected=exc.expected
    )


def check_table(test: str, table: Any, scene: Any) -> dict[str, Any]:
    """The ``[test]`` table of `scene` (a `granpack.PackScene`, its own keys resolved)
    checked by the test's own checks of its settings: every key known, every value in
    its range. Returns the table as the scene keeps it: the keys given, in their order,
    each value typed; a None that means the default is dropped. What depends on the
    consolidated pack (the time step's bound, the consolidation's gravity and lateral
    stress) is checked when the test runs.

    Raises
    ------
    InvalidParameterError
        Naming the key as ``<test>.<key>``: an unknown key (listing the known ones), a
        value out of range, a missing ``stresses``; naming ``<test>`` for a table that is
        not a table.
    """
    known = keys_of(test)
    if not isinstance(table, Mapping):
        raise InvalidParameterError(
            f"invalid {test} = {short_repr(table)}: expected a table of the {test} test's "
            f"settings ({', '.join(known)})",
            parameter=test,
            value=table,
            expected="a table",
        )
    for key in table:
        if not isinstance(key, str) or key not in known:
            raise InvalidParameterError(
                f"invalid {test}.{short_repr(key) if not isinstance(key, str) else key}: "
                f"unknown key of the [{test}] table; known: {', '.join(known)}",
                parameter=f"{test}.{key}",
                value=table[key],
                expected=" | ".join(known),
            )
    for key in _REQUIRED[test]:
        if key not in table:
            raise InvalidParameterError(
                f"missing {test}.{key}: the [{test}] table needs its {key} (Pa), the "
                "stresses to hold the sample at in turn, e.g. [50e3, 100e3, 200e3, 100e3]",
                parameter=f"{test}.{key}",
                expected="a non-empty list of stresses in (0, 1e12] Pa",
            )
    given = {k: v for k, v in table.items() if not (v is None and k in _NONE_IS_DEFAULT)}
    if given.get("wall_friction", 0.0) is None:
        raise InvalidParameterError(
            f"invalid {test}.wall_friction = None: a scene's table is written as TOML, which "
            "has no None; give the walls' friction as a number >= 0 (the material's "
            f"friction is {scene.material.friction:g})",
            parameter=f"{test}.wall_friction",
            value=None,
            expected="a number >= 0",
        )
    settings = {**_defaults(test), **given}
    try:
        if test == "triaxial":
            checked = _triaxial_values(
                **{k: settings[k] for k in inspect.signature(_triaxial_values).parameters}
            )
        else:
            checked = _path_values(
                scene,
                **{
                    k: settings[k]
                    for k in inspect.signature(_path_values).parameters
                    if k != "scene"
                },
            )
        if "gravity" in given and not isinstance(given["gravity"], bool):
            raise _fail(
                "gravity", given["gravity"], "true or false, or left out (the consolidation's)"
            )
        if "dt" in given:
            checked["dt"] = _real("dt", given["dt"], 0.0, math.inf, hi_open=True)
    except InvalidParameterError as exc:
        raise _named(test, exc) from None
    return {k: checked.get(k, v) for k, v in given.items()}


def check_scene_tables(scene: Any) -> dict[str, dict[str, Any] | None]:
    """Every element table of `scene` checked (`check_table`), and what they ask of the
    scene: a ``[consolidate]`` table (the tests start from a consolidated sample), one
    test at most, and a container with side walls where the test needs them. Returns
    each test's table (None where the scene gives none)."""
    asked = [t for t in TESTS if getattr(scene, t) is not None]
    out: dict[str, dict[str, Any] | None] = {t: None for t in TESTS}
    for test in asked:
        out[test] = check_table(test, getattr(scene, test), scene)
    if not asked:
        return out
    test = asked[0]
    if len(asked) > 1:
        raise InvalidParameterError(
            f"invalid {asked[1]}: the scene gives both [{asked[0]}] and [{asked[1]}]; a scene "
            "runs one element test on its consolidated sample (run another on the pack file: "
            f"granpack {asked[1]} PACK ...)",
            parameter=asked[1],
            expected="one element table at most",
        )
    if scene.consolidate is None:
        raise InvalidParameterError(
            f"invalid {test}: the [{test}] table needs a [consolidate] table, as the {test} "
            "test starts from a sample consolidated at rest under its lid; add one, e.g. "
            '[consolidate] stress = 1e5, mode = "isotropic"',
            parameter=test,
            expected="a scene with a [consolidate] table",
        )
    if test != "oedometer" and scene.container == "periodic":
        raise InvalidParameterError(
            f"invalid {test}: a periodic cell has no side walls to hold the lateral stress; "
            f"give the scene a box or a cylinder, or ask for an [oedometer]",
            parameter=test,
            value=scene.container,
            expected="container 'box' or 'cylinder'",
        )
    if test == "triaxial" and "confining" not in (out[test] or {}):
        mode = scene.consolidate.get("mode", _core.DEFAULT_CONSOLIDATE["mode"])
        if mode == "oedometric":
            raise InvalidParameterError(
                "missing triaxial.confining: the sample is consolidated oedometrically "
                "([consolidate] mode) and has no lateral target to take as sigma_3; give "
                "confining (Pa), or consolidate in mode 'isotropic' or 'anisotropic'",
                parameter="triaxial.confining",
                expected="a number in (0, 1e+12] Pa",
            )
    return out
