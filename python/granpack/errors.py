"""The exceptions granpack raises, one class per kind of failure.

Every one is a `GranpackError`, which is a `ValueError`, so `except ValueError` and
`except GranpackError` keep catching everything. Catch a subclass to handle one kind,
and read its attributes rather than its message::

    try:
        pack = gp.generate(scene)
    except gp.BlowUpError as e:
        print(e.kind, e.step, e.time, e.particle)
    except gp.SaturationError as e:
        print(f"layer {e.layer} reached only {e.reached:.3f}")

The engine's errors (Rust) are mapped onto these classes in one place, the bindings'
`From<Error> for PyErr`; the Python layer raises the same classes.
"""

from __future__ import annotations

import re

__all__ = [
    "GranpackError",
    "InvalidParameterError",
    "UnstableTimeStepError",
    "BlowUpError",
    "SaturationError",
    "FileFormatError",
    "ConsolidationError",
    "DensityTargetError",
    "BLOWUP_KINDS",
]

#: The values of `BlowUpError.kind`, one per guard that can stop a run.
BLOWUP_KINDS = ("overlap", "wall_overlap", "energy", "non_finite", "speed", "wall_crossed")

# "invalid NAME = ..." or "invalid NAME: ...", the form of every parameter message
_NAMED = re.compile(r"invalid ([A-Za-z_][\w.\[\]-]*)")


class GranpackError(ValueError):
    """Any granpack error. Its subclasses name the kind; the message says what to do.

    Every class pickles with its attributes, so an error raised in a worker process
    reaches the parent whole.
    """

    def __reduce__(self):
        return (_restore, (type(self), str(self), dict(self.__dict__)))

    def with_prefix(self, prefix: str) -> GranpackError:
        """The same error (class and attributes) with `prefix` before its message."""
        return _restore(type(self), prefix + str(self), dict(self.__dict__))


def _restore(cls: type[GranpackError], message: str, state: dict) -> GranpackError:
    e = cls.__new__(cls, message)
    Exception.__init__(e, message)
    e.__dict__.update(state)
    return e


class InvalidParameterError(GranpackError):
    """A parameter outside its allowed range, or of the wrong type or shape.

    Attributes:
        parameter: the parameter's name as the user spells it (`"dt"`, `"material.young"`,
            `"--packs"`), or None where the message names no single one.
        value: the offending value as given (from the engine: as text), or None.
        expected: the allowed range or form, as text, or None.
    """

    def __init__(
        self,
        message: str,
        *,
        parameter: str | None = None,
        value: object = None,
        expected: str | None = None,
    ) -> None:
        super().__init__(message)
        if parameter is None:
            m = _NAMED.match(message)
            parameter = m.group(1) if m else None
        self.parameter = parameter
        self.value = value
        self.expected = expected


class UnstableTimeStepError(InvalidParameterError):
    """`dt` above the critical (Rayleigh) time step of the smallest particle.

    Attributes:
        dt: the step asked for (s).
        critical: the estimated critical step (s); a `dt` at or below it is accepted.
        r_min: the radius the estimate used (m).
        parameter: always `"dt"`.
    """

    def __init__(self, message: str, *, dt: float, critical: float, r_min: float) -> None:
        super().__init__(
            message, parameter="dt", value=dt, expected=f"must not exceed {critical:e} s"
        )
        self.dt = dt
        self.critical = critical
        self.r_min = r_min


class BlowUpError(GranpackError):
    """A run that blew up, stopped instead of returning garbage.

    Attributes:
        step: the step counter when it was detected.
        time: the simulated time (s).
        particle: the index of the particle concerned.
        kind: which guard fired, one of `BLOWUP_KINDS`: `"overlap"` (a pair overlap
            beyond `max_overlap_ratio` of the smaller radius), `"wall_overlap"`,
            `"energy"` (energy grew with gravity the only source), `"non_finite"`,
            `"speed"` (more than half a radius per step) or `"wall_crossed"`.
    """

    def __init__(self, message: str, *, step: int, time: float, particle: int, kind: str) -> None:
        super().__init__(message)
        self.step = step
        self.time = time
        self.particle = particle
        self.kind = kind


class SaturationError(GranpackError):
    """Random sequential addition saturated below the layer's target fraction.

    Attributes:
        layer: the layer (0-based).
        reached: the solid fraction it reached (-).
        target: the fraction asked for, `phi_layer` (-).
        attempts: the failed placements in a row that stopped it.
    """

    def __init__(
        self, message: str, *, layer: int, reached: float, target: float, attempts: int
    ) -> None:
        super().__init__(message)
        self.layer = layer
        self.reached = reached
        self.target = target
        self.attempts = attempts


class FileFormatError(GranpackError):
    """A file that is not what it should be: not a pack (or scene, or data file), a
    damaged one, or one written by a version of granpack that this one cannot read.

    Attributes:
        path: the file, as given.
        reason: what is wrong with it (the message without the path).
    """

    def __init__(self, message: str, *, path: object = None, reason: str | None = None) -> None:
        super().__init__(message)
        self.path = path
        self.reason = reason if reason is not None else message


class ConsolidationError(GranpackError):
    """The stage used its step budget (`max_steps`) without reaching equilibrium.

    Attributes:
        steps: the steps taken.
        stress: each controlled wall's stress at the end (Pa; N/m in 2D), by wall name.
        stress_error: the largest relative stress error at the end (-).
        unbalanced: YADE's unbalanced-force ratio at the end (-).
    """

    def __init__(
        self,
        message: str,
        *,
        steps: int,
        stress: dict[str, float],
        stress_error: float,
        unbalanced: float,
    ) -> None:
        super().__init__(message)
        self.steps = steps
        self.stress = stress
        self.stress_error = stress_error
        self.unbalanced = unbalanced


class DensityTargetError(InvalidParameterError):
    """A density target outside the window this scene can reach, or one the search did
    not reach within its budget.

    Attributes:
        parameter: the target's key (`"target_phi"`, `"target_void_ratio"`,
            `"target_relative_density"`).
        target_phi: the target as a packing fraction (-).
        phi_min, phi_max: the window of packing fractions this scene reaches, loosest and
            densest, as the stage measured them (NaN where it did not measure one end).
        realised: the packing fraction nearest the target that was reached (-), or NaN.
    """

    def __init__(
        self,
        message: str,
        *,
        parameter: str,
        value: float,
        target_phi: float,
        phi_min: float,
        phi_max: float,
        realised: float = float("nan"),
    ) -> None:
        super().__init__(
            message,
            parameter=parameter,
            value=value,
            expected=f"a packing fraction in [{phi_min:.4f}, {phi_max:.4f}]",
        )
        self.target_phi = target_phi
        self.phi_min = phi_min
        self.phi_max = phi_max
        self.realised = realised
