"""glibc's allocator for the ``granpack`` command: one arena.

glibc gives each thread that allocates its own arena (up to 8 per core), and an arena
keeps what it frees. The engine's pair-list rebuilds free large arrays on the worker
threads at every rebuild, so with one arena per thread the generation's resident set
peaked at about 2.7 KB a particle, against 1.1 KB live (a 20 148-sphere periodic 4.3
`fast()` pack; `studies/memory_per_particle/allocator.py`). With one arena it peaked at
2.0 KB, in the same time or less. The command sets it for itself and for the worker
processes it starts; a library user sets ``MALLOC_ARENA_MAX=1`` in the environment.
"""

from __future__ import annotations

import ctypes
import os
import platform

#: ``M_ARENA_MAX`` of glibc's ``<malloc.h>``.
M_ARENA_MAX = -8


def one_arena() -> bool:
    """Limits glibc's malloc to one arena in this process (``mallopt``) and in the
    processes it starts (``MALLOC_ARENA_MAX=1`` in the environment). Leaves a
    ``MALLOC_ARENA_MAX`` that the environment already sets alone, and does nothing off
    glibc. Returns whether it set the limit. Call it before the engine's threads start:
    an arena a thread already has stays."""
    if "MALLOC_ARENA_MAX" in os.environ or platform.libc_ver()[0] != "glibc":
        return False
    try:
        done = ctypes.CDLL(None).mallopt(M_ARENA_MAX, 1)
    except (OSError, AttributeError):
        return False
    os.environ["MALLOC_ARENA_MAX"] = "1"
    return bool(done)
