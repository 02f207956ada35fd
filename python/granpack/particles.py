"""The former home of :func:`read_particles`, kept so that existing scripts run unchanged:
every format now lives in `granpack.io`, one module per format family, behind one
registry. Import from `granpack.io` (or `granpack`) in new code."""

from .io import FORMATS, ParticleFile, detect_format, read_particles
from .io.yade import YADE_LAYOUTS

__all__ = ["FORMATS", "ParticleFile", "YADE_LAYOUTS", "detect_format", "read_particles"]
