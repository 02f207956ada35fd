"""A pack's history: one record per stage that made it (`Pack.history`).

Every stage after the layer loop (the flat top, the settling to rest, the consolidation,
the density target, the tiling) adds one `StageRecord`: its name, the settings it ran
with, what it measured, its wall-clock seconds and its time steps. Pack files written by
granpack 0.1.0 kept these as five separate tables (``trim``, ``rest``,
``consolidation``, ``density``, ``tiled``); `StageRecord.from_table` reads each into a
record and `StageRecord.table` gives that table back.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field
from typing import Any

__all__ = ["StageRecord", "STAGE_NAMES", "TABLE_NAMES", "stage_table"]

#: The stages a pack's history can hold, in the order `generate` runs them (the tiling
#: is `granpack.tile`'s, on a finished pack).
STAGE_NAMES = (
    "trim",
    "rest",
    "consolidate",
    "density",
    "tile",
    "triaxial",
    "oedometer",
    "isotropic",
)

#: Each stage's table in a 0.1.0 pack file (and its `Pack` attribute then).
TABLE_NAMES = {
    "trim": "trim",
    "rest": "rest",
    "consolidate": "consolidation",
    "density": "density",
    "tile": "tiled",
}

#: Per stage: the keys of its 0.1.0 table that are settings (the rest is the report),
#: and whether that table held ``steps`` and ``seconds``.
_LAYOUT: dict[str, tuple[tuple[str, ...], bool, bool]] = {
    "trim": ((), True, False),
    "rest": (("unbalanced_tol", "hold", "check_every", "local_damping"), True, True),
    "consolidate": (
        (
            "mode",
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
            "targets",
        ),
        True,
        True,
    ),
    "density": (("target", "target_phi", "density_tol"), False, True),
    "tile": (("counts",), False, False),
    # the element tests came after 0.1.0: their tables are their records' settings and
    # report together
    "triaxial": ((), True, True),
    "oedometer": ((), True, True),
    "isotropic": ((), True, True),
}


@dataclass(frozen=True)
class StageRecord:
    """What one stage did to a pack.

    Attributes
    ----------
    stage : str
        The stage: "trim", "rest", "consolidate", "density", "tile", or an element
        test: "triaxial", "oedometer" or "isotropic".
    settings : dict
        What it ran with (its settings, the defaults it chose included).
    report : dict
        What it measured (JSON values: numbers, strings, lists, tables).
    seconds : float
        Wall-clock seconds it took (0 where a 0.1.0 file did not record them).
    steps : int
        Time steps it ran (0 for a stage that runs none, or where a 0.1.0 file did not
        record them).
    """

    stage: str
    settings: dict[str, Any] = field(default_factory=dict)
    report: dict[str, Any] = field(default_factory=dict)
    seconds: float = 0.0
    steps: int = 0

    def __post_init__(self) -> None:
        if self.stage not in STAGE_NAMES:
            raise ValueError(f"unknown stage {self.stage!r}; expected one of {STAGE_NAMES}")

    @classmethod
    def from_table(cls, stage: str, table: dict[str, Any]) -> StageRecord:
        """The record of a stage's table as granpack 0.1.0 kept it (``Pack.consolidation``
        and the like): its settings keys to `settings`, ``steps`` and ``seconds`` to their
        fields, the rest to `report`."""
        keys, _, _ = _LAYOUT[stage]
        rest = {k: v for k, v in table.items() if k not in ("steps", "seconds")}
        return cls(
            stage=stage,
            settings={k: rest.pop(k) for k in keys if k in rest},
            report=rest,
            seconds=float(table.get("seconds", 0.0)),
            steps=int(table.get("steps", 0)),
        )

    def table(self) -> dict[str, Any]:
        """The stage's table as granpack 0.1.0 kept it (a copy): the settings, the
        report, and ``steps`` and ``seconds`` where that table held them."""
        _, has_steps, has_seconds = _LAYOUT[self.stage]
        out = copy.deepcopy({**self.settings, **self.report})
        if has_steps:
            out["steps"] = self.steps
        if has_seconds:
            out["seconds"] = self.seconds
        return out

    def to_json(self) -> dict[str, Any]:
        """The record as the pack file keeps it."""
        return {
            "stage": self.stage,
            "settings": self.settings,
            "report": self.report,
            "seconds": self.seconds,
            "steps": self.steps,
        }

    @classmethod
    def from_json(cls, value: object) -> StageRecord:
        """A record of a pack file; a ValueError names what is wrong with a damaged one."""
        if not isinstance(value, dict):
            raise ValueError(f"a history record is {type(value).__name__}, expected a table")
        stage = value["stage"]
        if stage not in STAGE_NAMES:
            raise ValueError(f"a history record names the unknown stage {stage!r}")
        settings, report = value["settings"], value["report"]
        if not isinstance(settings, dict) or not isinstance(report, dict):
            raise ValueError(f"the {stage} record's settings and report must be tables")
        seconds = float(value["seconds"])
        steps = value["steps"]
        if isinstance(steps, bool) or not isinstance(steps, int) or steps < 0:
            raise ValueError(f"the {stage} record's steps is {steps!r}, expected an int >= 0")
        if not math.isfinite(seconds):
            raise ValueError(f"the {stage} record's seconds is not finite")
        return cls(stage=stage, settings=settings, report=report, seconds=seconds, steps=steps)


def stage_table(pack: object, stage: str) -> dict[str, Any] | None:
    """The table of `stage` in a pack's history (`StageRecord.table`: settings, report,
    steps and seconds in one dict), or None for a pack where that stage did not run and
    for an object that is not a pack (a particle file read from another code)."""
    record = getattr(pack, "record", None)
    if not callable(record):
        return None
    rec = record(stage)
    return None if rec is None else rec.table()
