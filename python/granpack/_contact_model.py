"""The contact model of a material as the stages change it and as records name it.

A stage that runs a phase with another friction (the deposition friction of a density
target, the servo's lowered friction) builds that phase's material with `phase_material`;
the records and the reports name the model with `model_record` and `model_text`
(docs/contact_models.md).
"""

from __future__ import annotations

import dataclasses
from typing import Any

from .simulation import Material

__all__ = ["phase_material", "model_record", "model_text", "has_rolling"]

#: How the reports name each contact law.
LAW_NAMES = {"hertz_mindlin": "Hertz-Mindlin", "linear": "linear"}


def has_rolling(material: Material) -> bool:
    """Whether `material` has a rolling-resistance model (``rolling != "none"``)."""
    return material.rolling != "none"


def phase_material(
    material: Material,
    friction: float | None = None,
    rolling_friction: float | None = None,
) -> Material:
    """The material a stage runs one phase with: `material` with Coulomb friction
    `friction` (-; None: the material's) and rolling friction `rolling_friction` (mu_r,
    -; None: the material's rolling model unchanged, whatever its mu_r). A mu_r of 0 is
    no rolling resistance at all: the phase's material has ``rolling = "none"`` (the
    rolling spring and dashpot go with it); a mu_r > 0 on a material without a rolling
    model gives it the ``"epsd"`` model with that mu_r and the default spring and
    dashpot. The contact law, the springs and the damping ratio are the material's.
    Returns `material` itself where nothing changes, so that a phase at the material's
    own constants runs exactly as the material does."""
    changes: dict[str, Any] = {}
    if friction is not None and friction != material.friction:
        changes["friction"] = friction
    if rolling_friction is not None and rolling_friction != material.rolling_friction:
        if rolling_friction == 0.0:
            if has_rolling(material):
                changes.update(
                    rolling="none",
                    rolling_friction=None,
                    rolling_stiffness=None,
                    rolling_damping=None,
                )
        else:
            changes.update(rolling="epsd", rolling_friction=rolling_friction)
    return dataclasses.replace(material, **changes) if changes else material


def model_record(material: Material) -> dict[str, Any]:
    """The contact model of `material` as a record's flat keys: ``contact_law`` and
    ``rolling`` always, then the model's own constants where they apply: the linear
    law's ``normal_stiffness`` and ``tangential_stiffness`` (N/m; the default k_t
    resolved), the rolling model's ``rolling_friction`` (-), ``rolling_stiffness`` (N/m;
    None where it is the default 2.25 mu_r^2 k_n, which depends on each contact) and
    ``rolling_damping`` (N s/m; 0 where unset)."""
    out: dict[str, Any] = {"contact_law": material.contact_law, "rolling": material.rolling}
    if material.contact_law == "linear":
        out["normal_stiffness"] = material.normal_stiffness
        out["tangential_stiffness"] = material.tangential_stiffness_or_default
    if has_rolling(material):
        out["rolling_friction"] = material.rolling_friction
        out["rolling_stiffness"] = material.rolling_stiffness
        out["rolling_damping"] = (
            0.0 if material.rolling_damping is None else material.rolling_damping
        )
    return out


def model_text(material: Material) -> str:
    """One sentence naming the contact model of `material` and its constants, with units
    (the reports' line)."""
    m = material
    if m.contact_law == "linear":
        law = (
            f"linear (k_n = {m.normal_stiffness:g} N/m, k_t = "
            f"{m.tangential_stiffness_or_default:g} N/m"
        )
    else:
        law = f"Hertz-Mindlin (E = {m.young:g} Pa, nu = {m.poisson:g}"
    law += f", damping ratio {m.damping:g}, mu = {m.friction:g})"
    if not has_rolling(m):
        return f"Contact model: {law}, no rolling resistance."
    k_r = (
        "2.25 mu_r^2 k_n (the default)"
        if m.rolling_stiffness is None
        else f"{m.rolling_stiffness:g} N/m"
    )
    gamma_r = 0.0 if m.rolling_damping is None else m.rolling_damping
    return (
        f"Contact model: {law}, rolling resistance epsd (Ai et al. 2011 type C; LAMMPS "
        f"rolling sds): mu_r = {m.rolling_friction:g}, k_r = {k_r}, gamma_r = "
        f"{gamma_r:g} N s/m."
    )
