"""How much memory this process may use: the checks that refuse work too large for the
machine (`granpack.pack.check_memory`, `granpack.tile`) take the smallest of the
physical memory, the address-space limit (``ulimit -v``, RLIMIT_AS) and the memory
limit of the process's control group (a container's or a batch job's), so that a run
under a limit is refused before the work instead of dying in an allocation."""

from __future__ import annotations

import os
from pathlib import Path
from typing import NamedTuple

__all__ = ["MemoryLimit", "memory_limit"]

#: The cgroup file systems' mount point.
CGROUP_ROOT = Path("/sys/fs/cgroup")
#: Limits at or above this are "none" (cgroup v1 writes 2^63 rounded down to a page).
_UNLIMITED = 2**60


class MemoryLimit(NamedTuple):
    """The memory this process may still use (bytes) and what sets it, in words."""

    bytes: float
    source: str


def _physical() -> MemoryLimit | None:
    try:
        total = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):  # not POSIX: cannot tell
        return None
    return MemoryLimit(float(total), "this machine's memory")


def _address_space(status: Path) -> MemoryLimit | None:
    """The room RLIMIT_AS leaves: the limit less the address space mapped already (the
    interpreter, its libraries and thread stacks count against it too)."""
    try:
        import resource
    except ImportError:  # not POSIX
        return None
    soft, _ = resource.getrlimit(resource.RLIMIT_AS)
    if soft == resource.RLIM_INFINITY or soft < 0 or soft >= _UNLIMITED:
        return None
    used = 0
    try:
        for line in status.read_text().splitlines():
            if line.startswith("VmSize:"):
                used = int(line.split()[1]) * 1024
                break
    except (OSError, ValueError, IndexError):
        pass
    room = max(float(soft - used), 0.0)
    what = f"the room the address-space limit RLIMIT_AS ({soft / 2**30:.2f} GiB) leaves"
    return MemoryLimit(room, what)


def _read_limit(path: Path) -> float | None:
    try:
        text = path.read_text().strip()
    except (OSError, UnicodeDecodeError):
        return None
    if text == "max":
        return None
    try:
        value = int(text)
    except ValueError:
        return None
    return float(value) if 0 <= value < _UNLIMITED else None


def _cgroup(proc_cgroup: Path, root: Path) -> MemoryLimit | None:
    """The smallest memory limit of this process's control group and those above it:
    cgroup v2's memory.max, v1's memory.limit_in_bytes (a container sees its own group
    at the mount's root, so the root's file counts too)."""
    try:
        lines = proc_cgroup.read_text().splitlines()
    except OSError:
        return None
    candidates: list[Path] = []
    for line in lines:
        parts = line.split(":", 2)
        if len(parts) != 3:
            continue
        _, controllers, rel = parts
        if controllers == "":  # v2: one unified hierarchy
            base, name = root, "memory.max"
            candidates.append(root / "unified" / name)
        elif "memory" in controllers.split(","):
            base, name = root / "memory", "memory.limit_in_bytes"
        else:
            continue
        here = base / rel.lstrip("/")
        while True:
            candidates.append(here / name)
            if here == base or base not in here.parents:
                break
            here = here.parent
        candidates.append(base / name)
    best: MemoryLimit | None = None
    for path in dict.fromkeys(candidates):
        value = _read_limit(path)
        if value is not None and (best is None or value < best.bytes):
            best = MemoryLimit(value, f"the control group's memory limit ({path})")
    return best


def memory_limit(
    *,
    proc_cgroup: Path = Path("/proc/self/cgroup"),
    cgroup_root: Path = CGROUP_ROOT,
    status: Path = Path("/proc/self/status"),
) -> MemoryLimit | None:
    """The smallest of the physical memory, the room RLIMIT_AS leaves and the control
    group's memory limit (bytes, with what sets it); None where none can be read. The
    paths are the system's; tests give others."""
    found = [
        m
        for m in (_physical(), _address_space(status), _cgroup(proc_cgroup, cgroup_root))
        if m is not None
    ]
    return min(found, key=lambda m: m.bytes) if found else None
