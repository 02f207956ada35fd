"""What the element-test stages share: the stage run on a consolidated pack. A scene's
``[triaxial]``, ``[oedometer]`` or ``[isotropic]`` table is checked when the scene is
built, by `granpack.element_settings`."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from ..element import run as element
from ..element_settings import TESTS, check_scene_tables, check_table, keys_of

__all__ = ["TESTS", "FUNCTIONS", "keys_of", "check_table", "check_scene_tables"]

#: Each test's function; its keyword arguments are the table's keys, its signature
#: holds their defaults.
FUNCTIONS: dict[str, Callable[..., Any]] = {
    "triaxial": element.triaxial,
    "oedometer": element.oedometer,
    "isotropic": element.isotropic_compression,
}
