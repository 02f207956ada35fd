"""The former home of :func:`read_particles`: every format now lives in `granpack.io`, one
module per format family, behind one registry. Importing this module still works for one
release, with a `DeprecationWarning`; import from `granpack.io` (or `granpack`) in new
code."""

import warnings

from .io import FORMATS, ParticleFile, detect_format, read_particles
from .io.yade import YADE_LAYOUTS

__all__ = ["FORMATS", "ParticleFile", "YADE_LAYOUTS", "detect_format", "read_particles"]

warnings.warn(
    "granpack.particles is now granpack.io; import from granpack.io in new code: "
    "granpack.particles is removed in the next release",
    DeprecationWarning,
    stacklevel=2,
)
