"""What the element-test stages share: a scene's ``[triaxial]``, ``[oedometer]`` or
``[isotropic]`` table checked when the scene is built, by the tests' own checks
(`granpack.element.run`), and the stage run on a consolidated pack."""

from __future__ import annotations

import inspect
import math
from collections.abc import Callable, Mapping
from typing import Any

from .._validate import short_repr
from ..element import run as element
from ..errors import InvalidParameterError

__all__ = ["TESTS", "FUNCTIONS", "keys_of", "check_table", "check_scene_tables"]

#: The element tests a scene may ask for, by their table's name (and their record's
#: stage), in the order of `granpack.stages.STAGES`.
TESTS = ("triaxial", "oedometer", "isotropic")

#: Each test's function; its keyword arguments are the table's keys, its signature
#: holds their defaults.
FUNCTIONS: dict[str, Callable[..., Any]] = {
    "triaxial": element.triaxial,
    "oedometer": element.oedometer,
    "isotropic": element.isotropic_compression,
}

#: The keys whose None (the function's default) a table may give: it is the same as
#: leaving the key out, and the scene drops it (TOML has no None).
_NONE_IS_DEFAULT = ("confining", "gravity", "dt")

#: The table's keys a test needs.
_REQUIRED = {"triaxial": (), "oedometer": ("stresses",), "isotropic": ("stresses",)}


def keys_of(test: str) -> tuple[str, ...]:
    """The keys of the ``[test]`` table: the test function's arguments after the pack."""
    return tuple(inspect.signature(FUNCTIONS[test]).parameters)[1:]


def _defaults(test: str) -> dict[str, Any]:
    return {
        k: p.default
        for k, p in inspect.signature(FUNCTIONS[test]).parameters.items()
        if p.default is not inspect.Parameter.empty
    }


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
            checked = element._triaxial_values(
                **{k: settings[k] for k in inspect.signature(element._triaxial_values).parameters}
            )
        else:
            checked = element._path_values(
                scene,
                **{
                    k: settings[k]
                    for k in inspect.signature(element._path_values).parameters
                    if k != "scene"
                },
            )
        if "gravity" in given and not isinstance(given["gravity"], bool):
            raise element._fail(
                "gravity", given["gravity"], "true or false, or left out (the consolidation's)"
            )
        if "dt" in given:
            checked["dt"] = element._real("dt", given["dt"], 0.0, math.inf, hi_open=True)
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
        from .. import _core

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
