"""Type stubs for the native module `granpack._core` (Rust, PyO3).

Users call the documented Python layer (`granpack.Simulation`, `granpack.generate`,
`granpack.microstructure`); these are the raw entry points it wraps. Arrays are float64
(int64 for indices), C-contiguous; every error is a `GranpackError` (a `ValueError`).
"""

from typing import Any

import numpy as np
import numpy.typing as npt

__version__: str

class GranpackError(ValueError):
    """Invalid input (naming the parameter and its range), unstable dt, blow-up, RSA
    saturation."""

Material = tuple[float, float, float, float, float]  # density, young, poisson, damping, friction
Box = tuple[list[float], list[float]]  # (lo, hi); hi[vertical] may be inf (open top)

class Simulation:
    """A DEM world in 2 or 3 dimensions (see granpack.Simulation)."""

    def __init__(
        self,
        dim: int,
        material: Material,
        dt: float,
        gravity: list[float],
        drag: float,
        rotations: bool,
        walls: Box | None,
        skin_ratio: float = 0.2,
        max_overlap_ratio: float = 0.5,
        inertia_2d: str = "sphere",
    ) -> None: ...
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
    def contacts(self) -> dict[str, npt.NDArray[Any]]:
        """Columns i, j, normal, overlap, force_normal, force_tangential, branch."""
    def __len__(self) -> int: ...

class LayerPacker:
    """The layer loop of Algorithm 1 (see granpack.generate)."""

    def __init__(
        self,
        dim: int,
        material: Material,
        dt: float,
        gravity: list[float],
        drag: float,
        rotations: bool,
        base: list[float],
        height: float,
        radii: tuple[str, float, float, float, float],  # law, mean, std, min, max
        h_layer: float,
        phi_layer: float,
        settle_time: float,
        seed: int,
        stream: int = 0,
        max_attempts: int = 1_000_000,
        max_layers: int = 10_000,
        skin_ratio: float = 0.2,
        max_overlap_ratio: float = 0.5,
        inertia_2d: str = "sphere",
        adaptive_settle: float | None = None,
        freeze_depth: float | None = None,
        freeze_speed: float = 1e-3,
        freeze_force: float = 0.1,
        settle_dt: float | None = None,
    ) -> None: ...
    @property
    def done(self) -> bool: ...
    @property
    def height(self) -> float: ...
    def next_layer(self) -> dict[str, float | int]:
        """One RSA layer and its jamming run (GIL released); the layer's report."""
    def state(self) -> dict[str, Any]:
        """positions, velocities, spins, radii, layer, time."""
    def contacts(self) -> dict[str, npt.NDArray[Any]]: ...

def find_contacts(
    positions: npt.NDArray[np.float64],
    radii: npt.NDArray[np.float64],
    walls: Box | None = None,
) -> dict[str, npt.NDArray[Any]]:
    """Geometric contacts (overlap > 0) from the cell grid; forces zero."""

def rayleigh_time_step(density: float, young: float, poisson: float, r_min: float) -> float:
    """pi r_min sqrt(rho / G) / (0.1631 nu + 0.8766) (s)."""
