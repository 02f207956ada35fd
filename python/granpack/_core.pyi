"""Type stubs for the native module `granpack._core` (Rust, PyO3).

Users call the documented Python layer (`granpack.Simulation`, `granpack.generate`,
`granpack.microstructure`); these are the raw entry points it wraps. Arrays are float64
(int64 for indices), C-contiguous; every error is a subclass of
`granpack.errors.GranpackError` (a `ValueError`). `mypy` and `stubtest granpack._core`
check these stubs in CI.
"""

from typing import Literal, Self, TypeAlias, TypedDict, final

import numpy as np
import numpy.typing as npt

__all__ = [
    "__version__",
    "MAX_STEPS_PER_CALL",
    "MAX_STEPS_PER_LAYER",
    "cpu_level",
    "cpu_levels",
    "Simulation",
    "LayerPacker",
    "find_contacts",
    "rayleigh_time_step",
]

__version__: str

MAX_STEPS_PER_CALL: int
"""Most steps one `Simulation.step` or `Simulation.run` call takes (1e10)."""
MAX_STEPS_PER_LAYER: float
"""Most DEM steps one layer's jamming run may take (settle_time / dt; 1e8)."""

Material: TypeAlias = tuple[float, float, float, float, float]
"""density (kg/m^3), young (Pa), poisson (-), damping (-), friction (-)."""
Box: TypeAlias = tuple[list[float], list[float]]
"""(lo, hi) corners (m); hi[vertical] may be inf (open top)."""
ContainerName: TypeAlias = Literal["box", "periodic", "cylinder"]
Inertia2D: TypeAlias = Literal["sphere", "disc"]
"""2D mass model: a sphere's mass and inertia, or a disc of unit thickness."""
RadiusLawName: TypeAlias = Literal["constant", "gaussian"]
CpuLevel: TypeAlias = Literal["x86-64", "x86-64-v2", "x86-64-v3", "x86-64-v4", "baseline"]

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
        material: Material,
        dt: float,
        gravity: list[float],
        drag: float,
        rotations: bool,
        walls: Box | None,
        skin_ratio: float = 0.2,
        max_overlap_ratio: float = 0.5,
        inertia_2d: Inertia2D = "sphere",
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

@final
class LayerPacker:
    """The layer loop of Algorithm 1 (see granpack.generate)."""

    def __new__(
        cls,
        dim: int,
        material: Material,
        dt: float,
        gravity: list[float],
        drag: float,
        rotations: bool,
        base: list[float],
        height: float,
        radii: tuple[RadiusLawName, float, float, float, float],  # law, mean, std, min, max
        h_layer: float,
        phi_layer: float,
        settle_time: float,
        seed: int,
        stream: int = 0,
        max_attempts: int = 1_000_000,
        max_layers: int = 10_000,
        skin_ratio: float = 0.2,
        max_overlap_ratio: float = 0.5,
        inertia_2d: Inertia2D = "sphere",
        adaptive_settle: float | None = None,
        freeze_depth: float | None = None,
        freeze_speed: float = 1e-3,
        freeze_force: float = 0.1,
        settle_dt: float | None = None,
        container: ContainerName = "box",
        cylinder_radius: float | None = None,
    ) -> Self: ...
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

def rayleigh_time_step(density: float, young: float, poisson: float, r_min: float) -> float:
    """pi r_min sqrt(rho / G) / (0.1631 nu + 0.8766) (s)."""

def cpu_level() -> CpuLevel:
    """The instruction-set level the hot kernels run at: the CPU's highest, or the one
    `GRANPACK_CPU_LEVEL` names."""

def cpu_levels() -> list[CpuLevel]:
    """The levels this CPU runs, lowest first."""
