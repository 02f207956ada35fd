"""The former home of `Material` and `Simulation`, now `granpack.simulation`: importing it
still works for one release, with a `DeprecationWarning`. Import from `granpack` or
`granpack.simulation` in new code."""

import warnings

from .simulation import MAX_STEPS_PER_CALL, Material, Simulation

__all__ = ["Material", "Simulation", "MAX_STEPS_PER_CALL"]

warnings.warn(
    "granpack.engine is now granpack.simulation; import from granpack.simulation in new"
    " code: granpack.engine is removed in the next release",
    DeprecationWarning,
    stacklevel=2,
)
