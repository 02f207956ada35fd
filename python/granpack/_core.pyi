"""Type stubs for the native module `granpack._core` (Rust, PyO3).

Users call the documented Python layer (`granpack.Simulation`, `granpack.generate`,
`granpack.microstructure`); these are the raw entry points it wraps. Arrays are float64
(int64 for indices), C-contiguous; every error is a subclass of
`granpack.errors.GranpackError` (a `ValueError`). `mypy` and `stubtest granpack._core`
check these stubs in CI.
"""

from collections.abc import Mapping
from typing import Any, Literal, Protocol, Self, TypeAlias, TypedDict, final

import numpy as np
import numpy.typing as npt

__all__ = [
    "__version__",
    "MAX_STEPS_PER_CALL",
    "MAX_STEPS_PER_LAYER",
    "MAX_ATTEMPTS",
    "MAX_LAYERS",
    "MAX_PARTICLES",
    "RSA_SATURATION",
    "CONTAINERS",
    "RADIUS_LAWS",
    "CONSOLIDATION_MODES",
    "CONSOLIDATE_KEYS",
    "TARGET_KEYS",
    "DENSITY_METHODS",
    "MAX_STRESS",
    "MAX_WALL_SPEED",
    "MIN_OVERLAP_RATIO",
    "DEFAULT_DENSITY_TOL",
    "DEFAULT_CONSOLIDATE",
    "DEFAULT_REST",
    "DEFAULT_DENSITY",
    "resolve_stage",
    "stress_range",
    "overlap_ratio",
    "cpu_level",
    "cpu_levels",
    "Simulation",
    "LayerPacker",
    "LayerPlacer",
    "find_contacts",
    "rayleigh_time_step",
    "critical_time_step",
    "resolve_scene",
    "number_fractions",
    "sample_radii",
]

__version__: str

MAX_STEPS_PER_CALL: int
"""Most steps one `Simulation.step` or `Simulation.run` call takes (1e10)."""
MAX_STEPS_PER_LAYER: float
"""Most DEM steps one layer's jamming run may take (settle_time / dt; 1e8)."""
MAX_ATTEMPTS: int
"""Most consecutive failed placements of a layer's RSA (`max_attempts`; 1e9)."""
MAX_LAYERS: int
"""Most layers of a pack (`max_layers`; 1e6)."""
MAX_PARTICLES: float
"""Most particles a scene may need, by its estimate (5e8)."""
RSA_SATURATION: tuple[float, float]
"""Solid fraction near which random sequential addition saturates, in 2D and 3D
(0.547, 0.384): a layer's `phi_layer` stays below it."""

"""density (kg/m^3), young (Pa), poisson (-), damping (-), friction (-)."""
Box: TypeAlias = tuple[list[float], list[float]]
"""(lo, hi) corners (m); hi[vertical] may be inf (open top)."""
ContainerName: TypeAlias = Literal["box", "periodic", "cylinder"]
Inertia2D: TypeAlias = Literal["sphere", "disc"]
"""2D mass model: a sphere's mass and inertia, or a disc of unit thickness."""
RadiusLawName: TypeAlias = Literal[
    "constant", "gaussian", "uniform", "lognormal", "discrete", "sieve"
]
CONTAINERS: tuple[ContainerName, ...]
"""The containers a scene may name (`PackScene.container`), the engine's list."""
RADIUS_LAWS: tuple[RadiusLawName, ...]
"""The radius laws a scene may name (`PackScene.radius_law`), the engine's list."""
ConsolidationMode: TypeAlias = Literal["oedometric", "isotropic", "anisotropic"]
DensityMethod: TypeAlias = Literal["auto", "deposition", "servo"]
TargetKey: TypeAlias = Literal["target_phi", "target_void_ratio", "target_relative_density"]
ConsolidateKey: TypeAlias = Literal[
    "stress",
    "mode",
    "lateral",
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
    "wall_friction",
]
CONSOLIDATION_MODES: tuple[ConsolidationMode, ...]
"""The consolidation modes (`granpack.consolidate`'s `mode`), the engine's list."""
CONSOLIDATE_KEYS: tuple[ConsolidateKey, ...]
"""The keys of a scene's `[consolidate]` table: `granpack.consolidate`'s settings."""
TARGET_KEYS: tuple[TargetKey, ...]
"""The density target keys of a scene, at most one given."""
DENSITY_METHODS: tuple[DensityMethod, ...]
"""How a density target is reached (`PackScene.density_method`)."""
MAX_STRESS: float
"""The largest target stress a consolidation takes (Pa; 1e12)."""
MAX_WALL_SPEED: float
"""The largest wall speed a consolidation takes (m/s; 1e6)."""
MIN_OVERLAP_RATIO: float
"""The smallest mean-contact overlap over the radius a stress target may ask (1e-9)."""
DEFAULT_DENSITY_TOL: float
"""A density target's default tolerance in phi (0.002)."""

class ConsolidateSettings(TypedDict):
    """Every setting of a consolidation but its stress, as the engine's defaults give
    them (None: the stage derives the value from the pack)."""

    mode: ConsolidationMode
    lateral: float | list[float] | None
    gravity: bool | None
    stress_tol: float
    unbalanced_tol: float
    hold: int
    check_every: int
    max_steps: int
    max_wall_speed: float | None
    gain: float
    local_damping: float
    dt: float | None

class RestSettings(TypedDict):
    """The settling to rest's settings (`granpack.settle`)."""

    unbalanced_tol: float
    hold: int
    check_every: int
    max_steps: int
    local_damping: float

class DensitySettings(TypedDict):
    """A density target's settings."""

    target_phi: float | None
    target_void_ratio: float | None
    target_relative_density: float | None
    density_tol: float | None
    density_method: DensityMethod

DEFAULT_CONSOLIDATE: Mapping[str, Any]
"""The consolidation's defaults (read-only; `ConsolidateSettings`' keys)."""
DEFAULT_REST: Mapping[str, Any]
"""The settling's defaults (read-only; `RestSettings`' keys)."""
DEFAULT_DENSITY: Mapping[str, Any]
"""The density target's defaults (read-only; `DensitySettings`' keys)."""
CpuLevel: TypeAlias = Literal["x86-64", "x86-64-v2", "x86-64-v3", "x86-64-v4", "baseline"]

class MaterialFields(Protocol):
    """What the engine reads from a `granpack.Material`, by attribute."""

    @property
    def density(self) -> float: ...
    @property
    def young(self) -> float: ...
    @property
    def poisson(self) -> float: ...
    @property
    def damping(self) -> float: ...
    @property
    def friction(self) -> float: ...
    @property
    def contact_law(self) -> str: ...
    @property
    def normal_stiffness(self) -> float | None: ...
    @property
    def tangential_stiffness(self) -> float | None: ...
    @property
    def rolling(self) -> str: ...
    @property
    def rolling_friction(self) -> float | None: ...
    @property
    def rolling_stiffness(self) -> float | None: ...
    @property
    def rolling_damping(self) -> float | None: ...

class RadiusLawFields(Protocol):
    """What the engine reads of a scene's radius law, by attribute (`PackScene`'s keys)."""

    @property
    def dim(self) -> int: ...
    @property
    def inertia_2d(self) -> str: ...
    @property
    def radius_law(self) -> str: ...
    @property
    def r_mean(self) -> float: ...
    @property
    def r_std(self) -> float: ...
    @property
    def r_min(self) -> float | None: ...
    @property
    def r_max(self) -> float | None: ...
    @property
    def radii(self) -> tuple[float, ...] | None: ...
    @property
    def fractions(self) -> tuple[float, ...] | None: ...
    @property
    def fractions_by(self) -> str: ...
    @property
    def sieve_sizes(self) -> tuple[float, ...] | None: ...
    @property
    def sieve_passing(self) -> tuple[float, ...] | None: ...

class SceneFields(RadiusLawFields, Protocol):
    """What the engine reads of a `granpack.PackScene`, by attribute: every key the
    layer loop needs, under the scene's own names (errors name them so)."""

    @property
    def base(self) -> tuple[float, ...]: ...
    @property
    def container(self) -> str: ...
    @property
    def cylinder_radius(self) -> float | None: ...
    @property
    def height(self) -> float: ...
    @property
    def h_layer(self) -> float: ...
    @property
    def phi_layer(self) -> float: ...
    @property
    def material(self) -> MaterialFields: ...
    @property
    def dt(self) -> float: ...
    @property
    def settle_time(self) -> float: ...
    @property
    def gravity(self) -> float: ...
    @property
    def drag(self) -> float: ...
    @property
    def rotations(self) -> bool: ...
    @property
    def seed(self) -> int: ...
    @property
    def stream(self) -> int: ...
    @property
    def skin_ratio(self) -> float: ...
    @property
    def max_overlap_ratio(self) -> float: ...
    @property
    def max_attempts(self) -> int: ...
    @property
    def max_layers(self) -> int: ...
    @property
    def settle_tol(self) -> float | None: ...
    @property
    def settle_dt(self) -> float | None: ...
    @property
    def freeze_depth(self) -> float | None: ...
    @property
    def freeze_speed(self) -> float: ...
    @property
    def freeze_force(self) -> float: ...
    @property
    def trim(self) -> bool: ...
    @property
    def rest_tol(self) -> float | None: ...
    @property
    def target_phi(self) -> float | None: ...
    @property
    def target_void_ratio(self) -> float | None: ...
    @property
    def target_relative_density(self) -> float | None: ...
    @property
    def density_tol(self) -> float | None: ...
    @property
    def density_method(self) -> str: ...
    @property
    def consolidate(self) -> object | None: ...

Float64Array: TypeAlias = npt.NDArray[np.float64]
Int64Array: TypeAlias = npt.NDArray[np.int64]

class ContactArrays(TypedDict):
    """One row per contact; j < 0 is a wall (-1 the floor)."""

    i: Int64Array
    j: Int64Array
    normal: Float64Array
    overlap: Float64Array
    force_normal: Float64Array
    force_tangential: Float64Array
    branch: Float64Array

class LayerReport(TypedDict):
    """What one layer of the layer loop did."""

    layer: int
    added: int
    total: int
    phi_rsa: float
    height: float
    steps: int
    kinetic_energy: float
    wall_seconds: float
    frozen: int

class TrimReport(TypedDict):
    """What LayerPacker.trim did: particles removed, relax steps, the final top (m)."""

    removed: int
    steps: int
    height: float

class PackerState(TypedDict):
    """The particle arrays of a layer loop, and its clock (s)."""

    positions: Float64Array
    velocities: Float64Array
    spins: Float64Array
    radii: Float64Array
    layer: Int64Array
    time: float

@final
class Simulation:
    """A DEM world in 2 or 3 dimensions (see granpack.Simulation)."""

    def __new__(
        cls,
        dim: int,
        material: MaterialFields,
        dt: float,
        gravity: list[float],
        drag: float,
        rotations: bool,
        walls: Box | None,
        skin_ratio: float = 0.2,
        max_overlap_ratio: float = 0.5,
        inertia_2d: Inertia2D = "disc",
        container: ContainerName = "box",
        cylinder_radius: float | None = None,
    ) -> Self: ...
    @property
    def dim(self) -> int: ...
    def add_particles(
        self,
        positions: npt.NDArray[np.float64],
        radii: npt.NDArray[np.float64],
        velocities: npt.NDArray[np.float64] | None = None,
        spins: npt.NDArray[np.float64] | None = None,
    ) -> None: ...
    def step(self, n: int) -> None:
        """n steps, GIL released."""
    def run(self, seconds: float) -> None:
        """`seconds` of simulated time, GIL released."""
    @property
    def time(self) -> float: ...
    @property
    def steps(self) -> int: ...
    @property
    def rebuilds(self) -> int: ...
    @property
    def positions(self) -> npt.NDArray[np.float64]: ...
    @property
    def velocities(self) -> npt.NDArray[np.float64]: ...
    @velocities.setter
    def velocities(self, v: npt.NDArray[np.float64]) -> None: ...
    @property
    def spins(self) -> npt.NDArray[np.float64]: ...
    @spins.setter
    def spins(self, w: npt.NDArray[np.float64]) -> None: ...
    @property
    def radii(self) -> npt.NDArray[np.float64]: ...
    @property
    def masses(self) -> npt.NDArray[np.float64]: ...
    def kinetic_energy(self) -> float: ...
    def potential_energy(self) -> float: ...
    def elastic_energy(self) -> float: ...
    def critical_time_step(self) -> float: ...
    def contacts(self) -> ContactArrays:
        """Columns i, j, normal, overlap, force_normal, force_tangential, branch."""
    def __len__(self) -> int: ...
    # The consolidation stage's methods.
    def add_lid(self, z: float) -> int:
        """Adds the lid, a plane facing down at height z (m), after the container's walls;
        returns its index in the wall list."""
    def walls(self) -> _Walls:
        """Each wall's position (m), area (m^2; NaN for a side wall before the lid), the
        force the particles put on it along its outward normal (N), its contacts'
        stiffness (N/m) and count."""
    def force_balance(self) -> _Balance:
        """The balance of forces: YADE's unbalanced ratio and PFC's maximum ratio."""
    def consolidate(
        self,
        targets: list[tuple[int, float]],
        *,
        stress_tol: float,
        unbalanced_tol: float,
        hold: int,
        check_every: int,
        max_steps: int,
        max_wall_speed: float,
        gain: float,
        local_damping: float,
    ) -> _ServoReport:
        """The consolidation stage on (wall index, target stress) pairs; GIL released."""
    def set_friction(self, friction: float) -> None:
        """Sets the Coulomb friction coefficient (-) of particles and walls from the next
        step on (finite, >= 0)."""
    def set_rolling_friction(self, rolling_friction: float) -> None:
        """Sets mu_r (-) from the next step on; refused without a rolling model."""
    def set_wall_friction(self, friction: float | None = None) -> None:
        """Gives the walls their own mu (-) from the next step on; None: the material's."""
    def shear(
        self,
        axial: int,
        axial_speed: float,
        lateral: list[int],
        *,
        confining: float | None = None,
        mean_stress: float | None = None,
        steps: int,
        max_wall_speed: float,
        gain: float,
        local_damping: float,
    ) -> None:
        """The triaxial drive: the lid in at axial_speed (m/s), the side walls' servo at
        confining (Pa) or at the mean stress; `steps` steps, GIL released."""
    def clone(self) -> Simulation:
        """A copy of the engine's whole state: stepping it gives the original's bits."""

@final
class LayerPlacer:
    """The layer loop's placement alone (RSA of one loose layer), seeded as LayerPacker
    is, for an engine outside granpack that jams each layer (`granpack.mpi`)."""

    def __new__(cls, scene: SceneFields) -> Self: ...
    @property
    def layers(self) -> int: ...
    def place(
        self,
        positions: npt.NDArray[np.float64],
        radii: npt.NDArray[np.float64],
        height: float,
    ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        """The next layer on the particles beneath (height max(z + r), m): its
        positions (M, D) and radii (M,), in Morton order."""

@final
class LayerPacker:
    """The layer loop of Algorithm 1 (see granpack.generate)."""

    def __new__(cls, scene: SceneFields) -> Self:
        """The layer loop of a scene (read by attribute, validated)."""
    @property
    def done(self) -> bool: ...
    @property
    def height(self) -> float: ...
    def next_layer(self) -> LayerReport:
        """One RSA layer and its jamming run (GIL released); the layer's report."""
    def trim(self, height: float) -> TrimReport:
        """After the last layer: removes every particle whose top lies above `height`
        (m) and relaxes the rest as the final relax does (GIL released)."""
    def state(self) -> PackerState:
        """positions, velocities, spins, radii, layer, time."""
    def contacts(self) -> ContactArrays: ...
    def finish(self) -> tuple[PackerState, ContactArrays]:
        """The finished pack, as state() and contacts() give it, with the packer spent
        to make it (the pair state freed as the contacts are written); every later
        call raises RuntimeError."""
    def memory(self) -> dict[str, int]:
        """Bytes of the engine's state by group (particles, wall_contacts, pair_list,
        incidence) and of the layer loop's (layers), with particles_count and
        pairs_count."""

def find_contacts(
    positions: npt.NDArray[np.float64],
    radii: npt.NDArray[np.float64],
    walls: Box | None = None,
    periodic: list[bool] | tuple[bool, ...] | None = None,
    cylinder: float | None = None,
) -> ContactArrays:
    """Geometric contacts (overlap > 0) from the cell grid; forces zero. `periodic`:
    one flag per horizontal axis of `walls` (minimum image, no walls there);
    `cylinder`: a radius R (3D), the side walls replaced by a vertical cylinder with
    its axis through lo + (R, R)."""

def critical_time_step(material: MaterialFields, r_min: float) -> float:
    """The critical time step (s) of a material for the smallest radius r_min (m)."""

def rayleigh_time_step(density: float, young: float, poisson: float, r_min: float) -> float:
    """pi r_min sqrt(rho / G) / (0.1631 nu + 0.8766) (s)."""

class ResolvedScene(TypedDict):
    """What a valid scene resolves to."""

    r_min: float
    r_max: float
    r_mean: float
    r_std: float
    base: list[float]
    cylinder_radius: float | None
    critical_dt: float
    estimated_particles: float
    consolidate: dict[str, Any] | None
    stages: ResolvedStages

class ConsolidateStage(ConsolidateSettings):
    """A consolidation's settings, resolved."""

    stress: float

class ResolvedConsolidation(ConsolidateStage):
    """A consolidation's settings checked against a pack: with the container's walls
    (the engine's order, the lid last) and each controlled wall's target (Pa)."""

    walls: list[str]
    targets: list[tuple[str, float]]

class TrimSettings(TypedDict):
    height: float | None

class ResolvedStages(TypedDict):
    """The stages a scene lists, with their settings; None where it does not run one."""

    trim: TrimSettings | None
    rest: RestSettings | None
    density: DensitySettings | None
    consolidate: ConsolidateStage | None

def resolve_stage(
    stage: Literal["consolidate", "rest", "density", "tile"],
    scene: SceneFields,
    settings: dict[str, Any],
    *,
    r_mean: float | None = None,
    r_min: float | None = None,
) -> Any:
    """The engine's one check of a stage's settings as its function gets them (the
    scene's table meets the same), against the scene's container and material and, for
    the consolidation, the pack's mean and smallest radius (m; the scene's without
    them); returns every setting with the defaults filled in (`ResolvedConsolidation`,
    `RestSettings`, `DensitySettings`, or {"counts": ...} for "tile"). Errors name the
    key as the scene does (`consolidate.max_wall_speed`)."""

def stress_range(
    dim: int, r_mean: float, e_star: float, max_overlap_ratio: float
) -> tuple[float, float]:
    """The stresses (Pa; N/m in 2D) a consolidation takes for particles of mean radius
    `r_mean` (m) and effective modulus `e_star` (Pa): those whose mean contact overlaps
    between MIN_OVERLAP_RATIO and `max_overlap_ratio` of the radius, at most MAX_STRESS."""

def overlap_ratio(stress: float, dim: int, r_mean: float, e_star: float) -> float:
    """The overlap over the radius (-) that a mean contact of two mean particles needs to
    carry `stress` (Pa; N/m in 2D): a Hertz contact of R* = r / 2."""

def resolve_scene(scene: SceneFields) -> ResolvedScene:
    """The scene's one validator: every range and cross-field rule of a whole scene
    (those `LayerPacker(scene)` runs and those of the keys the Python layer runs), the
    error naming the scene key; returns what the scene resolves to: the radius law's
    r_min, r_max and, by number, r_mean and r_std (m; the parameters before truncation
    for gaussian and lognormal), the base (m; a cylinder's is (2R, 2R)), the cylinder's
    radius (m), the critical step of r_min (s) and the estimated particle count; the
    `[consolidate]` table as given, its values typed; and the stages the scene lists,
    their settings resolved (`ResolvedStages`), in the same call."""

def number_fractions(scene: RadiusLawFields) -> list[float] | None:
    """Number fractions of a discrete law's radii or a sieve law's classes, after any
    conversion from mass; None for the other laws."""

def sample_radii(
    scene: RadiusLawFields, n: int, seed: int = 0, stream: int = 0
) -> npt.NDArray[np.float64]:
    """n radii (m) from the scene's law with the engine's sampler (n <= 1e8), from the
    generator of (seed, stream); GIL released."""

def cpu_level() -> CpuLevel:
    """The instruction-set level the hot kernels run at: the CPU's highest, or the one
    `GRANPACK_CPU_LEVEL` names."""

def cpu_levels() -> list[CpuLevel]:
    """The levels this CPU runs, lowest first."""

class _Walls(TypedDict):
    position: npt.NDArray[np.float64]
    area: npt.NDArray[np.float64]
    force: npt.NDArray[np.float64]
    stiffness: npt.NDArray[np.float64]
    contacts: npt.NDArray[np.int64]
    lid: bool

class _Balance(TypedDict):
    mean_net: float
    max_net: float
    mean_contact: float
    contacts: int
    unbalanced: float
    max_ratio: float

class _ServoHistory(TypedDict):
    step: npt.NDArray[np.int64]
    stress_error: npt.NDArray[np.float64]
    unbalanced: npt.NDArray[np.float64]
    max_ratio: npt.NDArray[np.float64]
    stress: npt.NDArray[np.float64]

class _ServoReport(TypedDict):
    converged: bool
    steps: int
    max_speed: float
    history: _ServoHistory
