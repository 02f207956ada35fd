"""granpack: dense random packs of discs and spheres, layer by layer, and their
microstructure.

The engine (spatial grid, DEM, random sequential addition, layer loop) is Rust
(`granpack._core`); this package is the thin Python layer over it.

``import granpack`` loads the extension and the error classes only; every other name of
the API, and numpy, polars and the rest with it, is imported on first use.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

from ._core import __version__ as __version__
from ._core import cpu_level, cpu_levels
from .errors import (
    BlowUpError,
    ConsolidationError,
    DensityTargetError,
    FileFormatError,
    GranpackError,
    InvalidParameterError,
    SaturationError,
    UnstableTimeStepError,
)

if TYPE_CHECKING:
    from .analysis import microstructure, radial_profiles, rdf, steinhardt
    from .analysis.profiles import profiles
    from .consolidation import consolidate, settle
    from .contacts import Contacts
    from .density import DensityWindowWarning, VoidRatioLimits, void_ratio_limits
    from .element import element_table, isotropic_compression, oedometer, triaxial
    from .ensemble_run import generate_ensemble
    from .generation import generate
    from .grading import Grading, realised_grading, target_grading
    from .history import StageRecord
    from .io import ContactFile, ParticleFile, read_contacts, read_particles, write
    from .pack import Pack, UnsettledPackWarning, load_pack
    from .scene import PRESETS, PackScene
    from .simulation import Material, Simulation
    from .tiling import tile

#: Where each name of the API loaded on first use lives.
_LAZY = {
    "microstructure": "analysis",
    "profiles": "analysis.profiles",
    "radial_profiles": "analysis",
    "rdf": "analysis",
    "steinhardt": "analysis",
    "consolidate": "consolidation",
    "settle": "consolidation",
    "Contacts": "contacts",
    "VoidRatioLimits": "density",
    "DensityWindowWarning": "density",
    "void_ratio_limits": "density",
    "triaxial": "element",
    "oedometer": "element",
    "isotropic_compression": "element",
    "element_table": "element",
    "Material": "simulation",
    "Simulation": "simulation",
    "Grading": "grading",
    "realised_grading": "grading",
    "target_grading": "grading",
    "ContactFile": "io",
    "ParticleFile": "io",
    "read_contacts": "io",
    "read_particles": "io",
    "write": "io",
    "Pack": "pack",
    "UnsettledPackWarning": "pack",
    "generate": "generation",
    "generate_ensemble": "ensemble_run",
    "StageRecord": "history",
    "load_pack": "pack",
    "PRESETS": "scene",
    "PackScene": "scene",
    "tile": "tiling",
}
#: The modules that ``import granpack`` loaded before the API was loaded on first use, still
#: reachable as attributes of the package (``granpack.analysis``) without their own import.
_SUBMODULES = frozenset(
    (
        "analysis",
        "consolidation",
        "contacts",
        "density",
        "grading",
        "history",
        "io",
        "pack",
        "scene",
        "simulation",
        "stages",
    )
    + ("tiling", "container_tag", "dem_input", "_validate")
)


def __getattr__(name: str):
    if name in _LAZY:
        value = getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
    elif name in _SUBMODULES:
        value = importlib.import_module(f".{name}", __name__)
    else:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__) | _SUBMODULES)


__all__ = [
    "GranpackError",
    "InvalidParameterError",
    "UnstableTimeStepError",
    "BlowUpError",
    "SaturationError",
    "FileFormatError",
    "ConsolidationError",
    "DensityTargetError",
    "Contacts",
    "Material",
    "Simulation",
    "Pack",
    "PackScene",
    "PRESETS",
    "generate",
    "generate_ensemble",
    "StageRecord",
    "load_pack",
    "tile",
    "consolidate",
    "settle",
    "triaxial",
    "oedometer",
    "isotropic_compression",
    "element_table",
    "void_ratio_limits",
    "VoidRatioLimits",
    "DensityWindowWarning",
    "read_particles",
    "write",
    "ParticleFile",
    "read_contacts",
    "ContactFile",
    "UnsettledPackWarning",
    "microstructure",
    "rdf",
    "steinhardt",
    "profiles",
    "radial_profiles",
    "realised_grading",
    "target_grading",
    "Grading",
    "__version__",
    "cpu_level",
    "cpu_levels",
]
