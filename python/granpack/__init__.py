"""granpack: dense random packs of discs and spheres, layer by layer, and their
microstructure.

The engine (spatial grid, DEM, random sequential addition, layer loop) is Rust
(`granpack._core`); this package is the thin Python layer over it.
"""

from ._core import __version__ as __version__
from ._core import cpu_level, cpu_levels
from .analysis import microstructure, profiles, radial_profiles, rdf, steinhardt
from .consolidation import ConsolidationError, consolidate, settle
from .contacts import Contacts
from .engine import Material, Simulation
from .errors import (
    BlowUpError,
    FileFormatError,
    GranpackError,
    InvalidParameterError,
    SaturationError,
    UnstableTimeStepError,
)
from .grading import Grading, realised_grading, target_grading
from .io import ContactFile, ParticleFile, read_contacts, read_particles
from .pack import Pack, UnsettledPackWarning, generate, load_pack
from .scene import PRESETS, PackScene
from .tile import tile

__all__ = [
    "GranpackError",
    "InvalidParameterError",
    "UnstableTimeStepError",
    "BlowUpError",
    "SaturationError",
    "FileFormatError",
    "ConsolidationError",
    "Contacts",
    "Material",
    "Simulation",
    "Pack",
    "PackScene",
    "PRESETS",
    "generate",
    "load_pack",
    "tile",
    "consolidate",
    "settle",
    "read_particles",
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
