"""The pack's contact model (`granpack.Material`: the law, the linear stiffnesses, the
rolling resistance) in the terms of each code an export goes to.

granpack's model (docs/physics.md): Hertz-Mindlin or a linear spring-dashpot law with
damping ratio xi, c = 2 xi sqrt(m* k); rolling resistance ``"epsd"`` (type C of Ai et al.
2011, LAMMPS ``rolling sds``): a spring k_r on the rolling displacement, a dashpot
gamma_r, the force capped at mu_r F_n, the torque R* n x f_r. When `rolling_stiffness` is
None, k_r = 2.25 mu_r^2 k_n with k_n the contact's current normal stiffness (Hertz:
2 E* sqrt(R* d), linear: k_n).

Most codes take one number where granpack's value varies from contact to contact (a
Hertz contact's k_n, a pair's reduced mass): those are evaluated at the pack's *mean
contact*, `mean_contact` (the means over its particle-particle contacts of R*, the
overlap d and m*), and the files say so. A default material (Hertz-Mindlin, no rolling)
adds nothing to any export: its files are what they were before the model keys existed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..simulation import MODEL_KEYS

if TYPE_CHECKING:
    from ..pack import Pack
    from ..simulation import Material

__all__ = [
    "MeanContact",
    "mean_contact",
    "is_default_model",
    "model_words",
    "normal_stiffness_at_mean",
    "rolling_stiffness_at_mean",
    "rolling_stiffness_words",
    "linear_restitution",
]

#: The overlap (as a fraction of the mean radius) of the mean contact of a pack without
#: particle-particle contacts.
EMPTY_OVERLAP_RATIO = 1e-3


@dataclass(frozen=True)
class MeanContact:
    """The pack's mean particle-particle contact.

    Attributes
    ----------
    r_star : float
        Mean R* = r_i r_j / (r_i + r_j) (m).
    overlap : float
        Mean overlap d (m).
    m_star : float
        Mean m* = m_i m_j / (m_i + m_j) (kg; per metre for 2D discs).
    m_star_range : (float, float)
        The smallest and largest m* over the contacts (kg).
    count : int
        The number of particle-particle contacts the means are over (0: two particles of
        the mean radius at `EMPTY_OVERLAP_RATIO` of it).
    """

    r_star: float
    overlap: float
    m_star: float
    m_star_range: tuple[float, float]
    count: int


def _masses(pack: Pack) -> np.ndarray:
    s = pack.scene
    r = np.asarray(pack.radii, dtype=np.float64)
    rho = float(s.material.density)
    if s.dim == 2 and s.inertia_2d == "disc":
        return rho * math.pi * r**2
    return rho * 4.0 / 3.0 * math.pi * r**3


def mean_contact(pack: Pack) -> MeanContact:
    """The means of R*, the overlap and m* over the pack's particle-particle contacts
    (`MeanContact`)."""
    pairs = pack.contacts.particle_pairs()
    r = np.asarray(pack.radii, dtype=np.float64)
    m = _masses(pack)
    if len(pairs) == 0:
        r_mean = float(r.mean()) if len(r) else float(pack.scene.r_mean)
        m_mean = float(m.mean()) if len(m) else 0.0
        return MeanContact(
            r_mean / 2.0, EMPTY_OVERLAP_RATIO * r_mean, m_mean / 2.0, (m_mean / 2, m_mean / 2), 0
        )
    i = np.asarray(pairs.i, dtype=np.int64)
    j = np.asarray(pairs.j, dtype=np.int64)
    r_star = r[i] * r[j] / (r[i] + r[j])
    m_star = m[i] * m[j] / (m[i] + m[j])
    return MeanContact(
        float(r_star.mean()),
        float(np.asarray(pairs.overlap).mean()),
        float(m_star.mean()),
        (float(m_star.min()), float(m_star.max())),
        len(pairs),
    )


def is_default_model(material: Material) -> bool:
    """Whether the material's contact model is the default one (Hertz-Mindlin without
    rolling resistance), which the exports write as they always did."""
    return material.contact_law == "hertz_mindlin" and material.rolling == "none"


def model_words(material: Material) -> str:
    """The contact-model keys that differ from the default, ``key=value`` with full
    precision (empty for the default model): the comment lines' record of the model."""
    table = material.to_dict()
    words = []
    for key in MODEL_KEYS:
        if key in table:
            value = table[key]
            words.append(f"{key}={value if isinstance(value, str) else repr(float(value))}")
    if material.contact_law == "linear" and material.tangential_stiffness is None:
        kt = material.tangential_stiffness_or_default
        assert kt is not None
        words.append(f"(tangential_stiffness={kt!r}, k_n 2(1-nu)/(2-nu))")
    return " ".join(words)


def normal_stiffness_at_mean(pack: Pack) -> float:
    """k_n (N/m) of the pack's mean contact: the linear law's k_n, or Hertz's current
    normal stiffness 2 E* sqrt(R* d) at the mean R* and mean overlap (`mean_contact`)."""
    m = pack.scene.material
    if m.contact_law == "linear":
        assert m.normal_stiffness is not None
        return float(m.normal_stiffness)
    mc = mean_contact(pack)
    return 2.0 * m.e_star * math.sqrt(mc.r_star * mc.overlap)


def rolling_stiffness_at_mean(pack: Pack) -> float:
    """The constant rolling stiffness k_r (N/m) for a code that takes one: the material's
    `rolling_stiffness`, or 2.25 mu_r^2 k_n with k_n of the mean contact
    (`normal_stiffness_at_mean`; exact for the linear law)."""
    m = pack.scene.material
    if m.rolling_stiffness is not None:
        return float(m.rolling_stiffness)
    assert m.rolling_friction is not None
    return 2.25 * m.rolling_friction**2 * normal_stiffness_at_mean(pack)


def rolling_stiffness_words(pack: Pack) -> str:
    """Where `rolling_stiffness_at_mean` comes from, for a comment line."""
    m = pack.scene.material
    if m.rolling_stiffness is not None:
        return "the material's rolling_stiffness"
    if m.contact_law == "linear":
        return "2.25 mu_r^2 k_n (the linear law's k_n: exact)"
    mc = mean_contact(pack)
    return (
        "2.25 mu_r^2 k_n with k_n = 2 E* sqrt(R* d) at the pack's mean contact "
        f"(R* = {mc.r_star:.6g} m, d = {mc.overlap:.6g} m, over {mc.count} contacts): "
        "granpack takes each contact's current k_n"
    )


def linear_restitution(damping: float) -> float:
    """The restitution e of a linear spring-dashpot contact of damping ratio xi:
    exp(-pi xi / sqrt(1 - xi^2)) (0 at xi >= 1)."""
    if damping >= 1.0:
        return 0.0
    return math.exp(-math.pi * damping / math.sqrt(1.0 - damping * damping))
