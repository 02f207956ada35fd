"""The stages that make a pack, one module each, all of one shape.

`generate` runs the deposit (the layer loop, `granpack.stages.deposit`), then each stage
the scene lists, in the order of `STAGES`: the settling to rest (``rest_tol``,
`granpack.stages.rest`), the consolidation (``[consolidate]``,
`granpack.stages.consolidate`) and an element test on the consolidated sample
(``[triaxial]``, ``[oedometer]`` or ``[isotropic]``: `granpack.stages.triaxial`,
`granpack.stages.oedometer`, `granpack.stages.isotropic`). The tiling
(`granpack.stages.tile`) runs on a finished pack (``granpack tile``). A density target
(`granpack.density`) is no step of the list: it searches over the list up to the
consolidation, running it again with the deposit's friction (and rolling friction)
changed; the element test runs on the pack it finds.

Every module holds

- ``Spec``: the stage's settings as the scene resolves them;
- ``spec_of(scene)``: the scene's ``Spec`` for the stage, or None where the scene does
  not ask for it;
- ``run(pack, spec, progress) -> Pack`` (the deposit: ``run(scene, spec, progress)``, as
  it starts from the scene, not from a pack), which adds the stage's record to the
  pack's history (`granpack.history.StageRecord`).

A new stage is a module of that shape and a line in `STAGES`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from ..pack import Pack
from ..scene import PackScene
from . import consolidate, deposit, isotropic, oedometer, rest, tile, triaxial

__all__ = [
    "STAGES",
    "ELEMENT_STAGES",
    "Step",
    "plan",
    "replace_spec",
    "run",
    "run_step",
    "with_spec",
]

#: The stages by name, in the order they run after the deposit (which runs first).
#: The tiling's ``spec_of`` is always None: no scene asks for it.
STAGES = (
    ("deposit", deposit),
    ("rest", rest),
    ("consolidate", consolidate),
    ("triaxial", triaxial),
    ("oedometer", oedometer),
    ("isotropic", isotropic),
    ("tile", tile),
)
_MODULES = dict(STAGES)

#: The element tests: the stages that run on the consolidated sample (a scene asks for
#: one at most).
ELEMENT_STAGES = ("triaxial", "oedometer", "isotropic")


@dataclass(frozen=True)
class Step:
    """One stage to run: its name in `STAGES` and its settings."""

    stage: str
    spec: Any


def plan(scene: PackScene) -> tuple[Step, ...]:
    """The steps `scene` asks for: the deposit, then each stage of `STAGES` whose
    settings the scene gives, in that order."""
    steps = [Step("deposit", deposit.spec_of(scene))]
    for name, module in STAGES[1:]:
        spec = module.spec_of(scene)
        if spec is not None:
            steps.append(Step(name, spec))
    return tuple(steps)


def with_spec(steps: tuple[Step, ...], stage: str, spec: Any) -> tuple[Step, ...]:
    """`steps` with the spec of `stage` replaced by `spec` (added after the stages that
    run before it where `steps` lacks it; removed where `spec` is None)."""
    order = [name for name, _ in STAGES]
    kept = [s for s in steps if s.stage != stage]
    if spec is None:
        return tuple(kept)
    new = Step(stage, spec)
    at = next((k for k, s in enumerate(kept) if order.index(s.stage) > order.index(stage)), None)
    if at is None:
        return (*kept, new)
    return (*kept[:at], new, *kept[at:])


def run(
    scene: PackScene,
    steps: tuple[Step, ...],
    progress: bool | Callable[[dict], None] = False,
    *,
    _stacklevel: int = 2,
) -> Pack:
    """Runs `steps` (a deposit first) on `scene` and returns the pack, its history
    holding each stage's record. `progress` is `granpack.generate`'s."""
    first, *others = steps
    if first.stage != "deposit":
        raise ValueError(f"a stage list starts with the deposit, not {first.stage!r}")
    pack = deposit.run(scene, first.spec, progress, _stacklevel=_stacklevel + 1)
    for step in others:
        pack = run_step(pack, step, progress)
    return pack


def run_step(pack: Pack, step: Step, progress: bool | Callable[[dict], None] = False) -> Pack:
    """Runs one stage after the deposit, `step`, on `pack`."""
    if step.stage == "deposit":
        raise ValueError("the deposit starts from the scene, not from a pack: use run")
    return _MODULES[step.stage].run(pack, step.spec, progress)


def replace_spec(spec: Any, **changes: Any) -> Any:
    """A stage's spec with `changes`: a dataclass's fields, or a table's keys."""
    if dataclasses.is_dataclass(spec) and not isinstance(spec, type):
        return dataclasses.replace(spec, **changes)
    return {**spec, **changes}
