"""The DEM engine from Python: `Material` and `Simulation`."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from numbers import Integral

import numpy as np

from . import _core
from ._validate import InvalidParameterError, as_array, as_bool, as_real, short_repr
from .contacts import Contacts

__all__ = ["Material", "Simulation", "MAX_STEPS_PER_CALL"]

#: Most steps one `Simulation.step` or `Simulation.run` call takes.
MAX_STEPS_PER_CALL = _core.MAX_STEPS_PER_CALL
#: The contact laws `Material.contact_law` takes.
CONTACT_LAWS = ("hertz_mindlin", "linear")
#: The rolling-resistance models `Material.rolling` takes.
ROLLING_MODELS = ("none", "epsd")
_MODEL_DEFAULTS = {"contact_law": "hertz_mindlin", "rolling": "none"}
#: The contact-model keys of `Material`, in order (`to_dict` writes them only where they
#: differ from the default model).
MODEL_KEYS = (
    "contact_law",
    "normal_stiffness",
    "tangential_stiffness",
    "rolling",
    "rolling_friction",
    "rolling_stiffness",
    "rolling_damping",
)


@dataclass(frozen=True)
class Material:
    """Particle (and wall) material; SI units. Defaults are the paper's.

    Attributes
    ----------
    density : float
        Mass density rho (kg/m^3), > 0. Default 1000.
    young : float
        Young's modulus E (Pa), > 0. Default 1e8.
    poisson : float
        Poisson's ratio nu in (-1, 0.5). Default 0.25.
    damping : float
        Damping ratio xi of the normal and tangential dashpots, in [0, 1]
        (the paper's "damping rate"). Default 0.1.
    friction : float
        Coulomb friction coefficient mu >= 0 (particles and walls). Default 0.2.
    contact_law : str
        ``"hertz_mindlin"`` (default: Hertz normal, Mindlin tangential spring, from
        `young` and `poisson`) or ``"linear"`` (constant springs `normal_stiffness` and
        `tangential_stiffness`: PFC's ``linear``, LAMMPS ``hooke``, YADE's Cundall-Strack
        law). The dashpots keep the damping ratio `damping` in both.
    normal_stiffness : float or None
        Linear law only: normal spring k_n (N/m), > 0. Required with ``"linear"``.
    tangential_stiffness : float or None
        Linear law only: tangential spring k_t (N/m), > 0. Default k_n 2 (1 - nu) /
        (2 - nu), the ratio of the Hertz-Mindlin law's two stiffnesses.
    rolling : str
        Rolling resistance: ``"none"`` (default) or ``"epsd"``, the elastic-plastic
        spring-dashpot model (type C of Ai, Chen, Rotter and Ooi 2011; LAMMPS
        ``rolling sds``, LIGGGHTS ``epsd3``): a spring on the rolling displacement R*
        times the relative rotation, capped at mu_r R* F_n, with a dashpot.
    rolling_friction : float or None
        Rolling friction coefficient mu_r >= 0 (-). Required with ``"epsd"``.
    rolling_stiffness : float or None
        Rolling spring k_r (N/m) on the rolling displacement (LAMMPS ``k_roll``), > 0.
        Default 2.25 mu_r^2 k_n, with k_n the contact's current normal stiffness (Ai et
        al. 2011, after Iwashita and Oda 1998).
    rolling_damping : float or None
        Rolling dashpot gamma_r (N s/m) on the rolling velocity (LAMMPS ``gamma_roll``),
        >= 0. Default 0 (the spring and its cap alone, as Ai et al.'s type C without
        its optional dashpot).
    """

    density: float = 1000.0
    young: float = 1e8
    poisson: float = 0.25
    damping: float = 0.1
    friction: float = 0.2
    contact_law: str = "hertz_mindlin"
    normal_stiffness: float | None = None
    tangential_stiffness: float | None = None
    rolling: str = "none"
    rolling_friction: float | None = None
    rolling_stiffness: float | None = None
    rolling_damping: float | None = None

    def __post_init__(self) -> None:
        check = object.__setattr__
        check(self, "density", as_real("density", self.density, 0, lo_open=True, unit="kg/m^3"))
        check(self, "young", as_real("young", self.young, 0, lo_open=True, unit="Pa"))
        check(
            self, "poisson", as_real("poisson", self.poisson, -1, 0.5, lo_open=True, hi_open=True)
        )
        check(self, "damping", as_real("damping", self.damping, 0, 1))
        check(self, "friction", as_real("friction", self.friction, 0))
        if self.contact_law not in CONTACT_LAWS:
            raise InvalidParameterError(
                f"invalid contact_law = {short_repr(self.contact_law)}: must be one of "
                + ", ".join(repr(c) for c in CONTACT_LAWS),
                parameter="contact_law",
            )
        if self.rolling not in ROLLING_MODELS:
            raise InvalidParameterError(
                f"invalid rolling = {short_repr(self.rolling)}: must be one of "
                + ", ".join(repr(c) for c in ROLLING_MODELS),
                parameter="rolling",
            )
        linear = self.contact_law == "linear"
        for key in ("normal_stiffness", "tangential_stiffness"):
            value = getattr(self, key)
            if value is None:
                continue
            if not linear:
                raise InvalidParameterError(
                    f"invalid {key} = {short_repr(value)}: only the linear law takes it "
                    f"(contact_law = {self.contact_law!r})",
                    parameter=key,
                )
            check(self, key, as_real(key, value, 0, lo_open=True, unit="N/m"))
        if linear and self.normal_stiffness is None:
            raise InvalidParameterError(
                "missing normal_stiffness: the linear law needs k_n (N/m), > 0",
                parameter="normal_stiffness",
            )
        rolling = self.rolling != "none"
        for key, lo, lo_open, unit in (
            ("rolling_friction", 0, False, ""),
            ("rolling_stiffness", 0, True, "N/m"),
            ("rolling_damping", 0, False, "N s/m"),
        ):
            value = getattr(self, key)
            if value is None:
                continue
            if not rolling:
                raise InvalidParameterError(
                    f"invalid {key} = {short_repr(value)}: only a rolling model takes it "
                    "(rolling = 'none')",
                    parameter=key,
                )
            check(self, key, as_real(key, value, lo, lo_open=lo_open, unit=unit))
        if rolling and self.rolling_friction is None:
            raise InvalidParameterError(
                f"missing rolling_friction: rolling = {self.rolling!r} needs mu_r >= 0",
                parameter="rolling_friction",
            )

    @property
    def tangential_stiffness_or_default(self) -> float | None:
        """The linear law's k_t (N/m): as given, or k_n 2 (1 - nu) / (2 - nu); None for
        Hertz-Mindlin."""
        if self.contact_law != "linear" or self.normal_stiffness is None:
            return None
        if self.tangential_stiffness is not None:
            return self.tangential_stiffness
        nu = self.poisson
        return self.normal_stiffness * 2.0 * (1.0 - nu) / (2.0 - nu)

    def as_tuple(self) -> tuple[float, float, float, float, float]:
        return (self.density, self.young, self.poisson, self.damping, self.friction)

    def to_dict(self) -> dict[str, float | str]:
        """The constants as a table: the contact-model keys only where they differ from
        the default (Hertz-Mindlin without rolling), so that a default material's table,
        and every record made from it, is what it was before the keys existed."""
        out = asdict(self)
        for key in MODEL_KEYS:
            if out[key] is None or out[key] == _MODEL_DEFAULTS.get(key):
                del out[key]
        return out

    @property
    def e_star(self) -> float:
        """Effective modulus of a contact of two bodies of this material, E* = E / (2 (1 -
        nu^2)) (Pa), as the engine's Hertz law takes it (walls included)."""
        return self.young / (2.0 * (1.0 - self.poisson**2))

    def critical_time_step(self, r_min: float) -> float:
        """The critical time step for the smallest radius r_min (m), in s: the Rayleigh
        step pi r_min sqrt(rho/G) / (0.1631 nu + 0.8766) under Hertz-Mindlin, sqrt(m /
        max(k_n, k_t)) under the linear law (m the mass of a sphere of r_min), shortened
        by a rolling spring (see docs/contact_models.md)."""
        return _core.critical_time_step(self, float(r_min))


class Simulation:
    """A DEM world of discs (dim=2) or spheres (dim=3).

    Parameters
    ----------
    dim : int
        2 or 3.
    material : Material
        Default ``Material()`` (the paper's).
    dt : float
        Time step (s), default 1e-4; must not exceed the Rayleigh estimate of the
        smallest particle (checked on the first step).
    gravity : sequence of D floats, optional
        Body acceleration (m/s^2). Default 2 m/s^2 along -y (2D) or -z (3D).
    drag : float
        Linear drag c_D (N s/m), f = -c_D v. Default 0.
    box : ((lo...), (hi...)) or None
        Floor at lo[vertical], side walls at lo and hi on the horizontal axes; the
        top is open (hi[vertical] may be inf). None: no walls.
    rotations : bool
        Integrate spins. Default True; False keeps spins at zero.
    skin_ratio : float
        Verlet skin over the smallest radius. Default 0.2.
    max_overlap_ratio : float
        Overlap, as a fraction of the smaller radius, at which a run stops as
        unstable. Default 0.5.
    inertia_2d : {"sphere", "disc"}
        2D mass model: a unit-thickness disc (default, m = pi r^2 rho per metre) or a
        sphere confined to the plane (m = 4/3 pi r^3 rho).
    container : str
        One of `granpack.scene.CONTAINERS`: what bounds the particles laterally inside `box` (needed
        for the other two): side walls (default), periodic horizontal axes with periods hi - lo, or
        (3D) a vertical cylinder of radius `cylinder_radius` with its axis through lo + (R, R) (the
        box's sides must then be 2R). See docs/physics.md, "Containers".
    cylinder_radius : float or None
        Radius of the cylinder (m); only with container="cylinder".
    """

    dim: int
    material: Material
    _inertia_2d: str
    _sim: _core.Simulation

    def __init__(
        self,
        dim: int = 3,
        material: Material | None = None,
        dt: float = 1e-4,
        gravity=None,
        drag: float = 0.0,
        box=None,
        rotations: bool = True,
        *,
        skin_ratio: float = 0.2,
        max_overlap_ratio: float = 0.5,
        inertia_2d: str = "disc",
        container: str = "box",
        cylinder_radius: float | None = None,
    ) -> None:
        if isinstance(dim, bool) or not isinstance(dim, Integral) or dim not in (2, 3):
            raise InvalidParameterError(f"invalid dim = {dim!r}: must be 2 or 3", parameter="dim")
        dim = int(dim)
        if not isinstance(inertia_2d, str) or inertia_2d not in ("sphere", "disc"):
            raise InvalidParameterError(
                f"invalid inertia_2d = {inertia_2d!r}: must be 'sphere' or 'disc'",
                parameter="inertia_2d",
            )
        material = Material() if material is None else material
        if not isinstance(material, Material):
            raise InvalidParameterError(
                f"invalid material = {material!r}: must be a granpack.Material",
                parameter="material",
            )
        if not isinstance(container, str) or container not in _core.CONTAINERS:
            raise InvalidParameterError(
                f"invalid container = {short_repr(container)}: must be one of "
                + ", ".join(repr(c) for c in _core.CONTAINERS),
                parameter="container",
                value=container,
                expected="box | periodic | cylinder",
            )
        if cylinder_radius is not None:
            cylinder_radius = as_real("cylinder_radius", cylinder_radius, unit="m")
        dt = as_real("dt", dt, 0, lo_open=True, unit="s")
        if gravity is None:
            gravity = [0.0] * dim
            gravity[dim - 1] = -2.0
        gravity = as_array("gravity", gravity, (dim,))
        drag = as_real("drag", drag, 0, unit="N s/m")
        rotations = as_bool("rotations", rotations)
        walls = None
        if box is not None:
            try:
                lo, hi = box
                lo = [float(v) for v in lo]
                hi = [float(v) for v in hi]
            except (TypeError, ValueError):
                raise InvalidParameterError(
                    f"invalid box = {box!r}: expected ((lo_1..lo_D), (hi_1..hi_D))", parameter="box"
                ) from None
            if len(lo) != dim or len(hi) != dim:
                raise InvalidParameterError(
                    f"invalid box = {box!r}: corners need {dim} coordinates", parameter="box"
                )
            for k in range(dim):
                if not math.isfinite(lo[k]) or (
                    k != dim - 1 and not (math.isfinite(hi[k]) and hi[k] > lo[k])
                ):
                    raise InvalidParameterError(
                        f"invalid box = {box!r}: axis {k} needs finite lo < hi "
                        "(the top may be inf)",
                        parameter="box",
                    )
            walls = (lo, hi)
        self.dim = dim
        self.material = material
        self._inertia_2d = inertia_2d
        self._sim = _core.Simulation(
            dim,
            material,
            dt,
            list(gravity),
            drag,
            rotations,
            walls,
            skin_ratio=as_real("skin_ratio", skin_ratio, 0, 10),
            max_overlap_ratio=as_real("max_overlap_ratio", max_overlap_ratio, 0, 1, lo_open=True),
            inertia_2d=inertia_2d,
            container=container,
            cylinder_radius=cylinder_radius,
        )

    def add_particles(self, positions, radii, velocities=None, spins=None) -> None:
        """Adds N particles: positions (N, D) m, radii (N,) m > 0, velocities (N, D) m/s,
        spins (N,) rad/s in 2D or (N, 3) in 3D."""
        x = as_array("positions", positions, (None, self.dim))
        r = as_array("radii", radii, (x.shape[0],))
        if np.any(r <= 0):
            k = int(np.argmax(r <= 0))
            raise InvalidParameterError(
                f"invalid radii[{k}] = {r[k]}: must be > 0 (m)", parameter=f"radii[{k}]"
            )
        # The engine divides by mass and moment of inertia: both must be finite and > 0.
        rho = self.material.density
        with np.errstate(over="ignore", under="ignore"):
            disc = self.dim == 2 and self._inertia_2d == "disc"
            m = np.pi * r * r * rho if disc else 4.0 / 3.0 * np.pi * r * r * r * rho
            inertia = (0.5 if disc else 0.4) * m * r * r
        bad = ~(np.isfinite(m) & (m > 0) & np.isfinite(inertia) & (inertia > 0))
        if np.any(bad):
            k = int(np.argmax(bad))
            raise InvalidParameterError(
                f"invalid radii[{k}] = {r[k]}: with density = {rho} kg/m^3 the mass "
                f"{m[k]:.3g} kg or moment of inertia {inertia[k]:.3g} kg m^2 is not a finite "
                "number > 0",
                parameter=f"radii[{k}]",
            )
        v = (
            None
            if velocities is None
            else as_array("velocities", velocities, (x.shape[0], self.dim))
        )
        w = None
        if spins is not None:
            shape = (x.shape[0],) if self.dim == 2 else (x.shape[0], 3)
            w = as_array("spins", spins, shape)
        self._sim.add_particles(x, r, v, w)

    def step(self, n: int = 1) -> None:
        """Advances n steps, at most `MAX_STEPS_PER_CALL` (1e10) per call. The GIL is
        released meanwhile; Ctrl-C stops the run within about 0.1 s (KeyboardInterrupt,
        with the steps taken so far kept)."""
        limit = _core.MAX_STEPS_PER_CALL
        if isinstance(n, bool) or not isinstance(n, int | np.integer) or not 0 <= n <= limit:
            raise InvalidParameterError(
                f"invalid n = {short_repr(n)}: must be an integer in [0, {limit}] "
                "(steps per call; call again to go on)",
                parameter="n",
            )
        self._sim.step(int(n))

    def run(self, seconds: float) -> None:
        """Advances `seconds` of simulated time, rounded to whole steps; refused when
        that is more than `MAX_STEPS_PER_CALL` steps (a tiny dt). Ctrl-C stops it as in
        `step`."""
        self._sim.run(as_real("seconds", seconds, 0, unit="s"))

    @property
    def time(self) -> float:
        """Simulated time (s)."""
        return self._sim.time

    @property
    def steps(self) -> int:
        """Steps taken."""
        return self._sim.steps

    @property
    def positions(self) -> np.ndarray:
        """(N, D) positions (m); a fresh copy."""
        return self._sim.positions

    @property
    def velocities(self) -> np.ndarray:
        """(N, D) velocities (m/s); assignable."""
        return self._sim.velocities

    @velocities.setter
    def velocities(self, v) -> None:
        self._sim.velocities = as_array("velocities", v, (len(self), self.dim))

    @property
    def spins(self) -> np.ndarray:
        """Angular velocities (rad/s): (N,) in 2D, (N, 3) in 3D; assignable."""
        return self._sim.spins

    @spins.setter
    def spins(self, w) -> None:
        shape = (len(self),) if self.dim == 2 else (len(self), 3)
        self._sim.spins = as_array("spins", w, shape)

    @property
    def radii(self) -> np.ndarray:
        """(N,) radii (m)."""
        return self._sim.radii

    @property
    def masses(self) -> np.ndarray:
        """(N,) masses (kg)."""
        return self._sim.masses

    def kinetic_energy(self) -> float:
        """Translational plus rotational kinetic energy (J)."""
        return self._sim.kinetic_energy()

    def potential_energy(self) -> float:
        """Gravitational potential energy -sum m g.x (J)."""
        return self._sim.potential_energy()

    def elastic_energy(self) -> float:
        """Elastic energy stored in the contacts (J): Hertz 8/15 E* sqrt(R*) d^{5/2} (1/2
        k_n d^2 under the linear law) plus the tangential springs 1/2 k_t |xi_t|^2, at the
        last force evaluation; the rolling springs are left out."""
        return self._sim.elastic_energy()

    def critical_time_step(self) -> float:
        """The critical step for the current smallest particle (s): the Rayleigh step, or
        the linear law's (see `Material.critical_time_step`)."""
        return self._sim.critical_time_step()

    def contacts(self) -> Contacts:
        """The contacts in force at the last force evaluation."""
        return Contacts.from_dict(self._sim.contacts())

    def __len__(self) -> int:
        return len(self._sim)
