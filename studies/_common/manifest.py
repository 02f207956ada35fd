"""Where a benchmark result came from: the manifest every results folder carries.

A timing or an ensemble mean is only worth keeping with the commit that made it, the CPU
it ran on, when, the command line and the seeds. Every script under studies/ that
writes results calls `write_manifest` on its output folder (its scripts find this module
by putting studies/_common on sys.path).
"""

from __future__ import annotations

import datetime as _dt
import json
import os
import platform
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def _git(*args: str) -> str:
    try:
        out = subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True)
    except OSError:
        return ""
    return out.stdout.strip() if out.returncode == 0 else ""


def cpu_model() -> str:
    """The CPU's model name with its family and model numbers, as /proc/cpuinfo gives them
    (virtual machines often report a bare "Intel Xeon Processor"; the numbers tell the
    generations apart). platform's guess elsewhere."""
    try:
        info = {}
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            key, _, value = line.partition(":")
            if not key.strip():
                break  # the first processor is enough
            info.setdefault(key.strip(), value.strip())
        if "model name" in info:
            return (
                f"{info['model name']} (family {info.get('cpu family')}, model {info.get('model')})"
            )
    except OSError:
        pass
    return platform.processor() or platform.machine()


def manifest(seeds=None, extra: dict | None = None, argv: list[str] | None = None) -> dict:
    """The manifest of a run made now, from this checkout."""
    commit = _git("rev-parse", "HEAD")
    dirty = bool(_git("status", "--porcelain", "--untracked-files=no"))
    try:
        import granpack

        version = granpack.__version__
    except ImportError:
        version = None
    return {
        "commit": commit + ("-dirty" if dirty and commit else ""),
        "date": _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "cpu_model": cpu_model(),
        "cpus": os.cpu_count(),
        "command": " ".join([Path(sys.executable).name, *(sys.argv if argv is None else argv)]),
        "seeds": seeds,
        "granpack_version": version,
        "python": platform.python_version(),
        # other work on the machine slows a timing down: say how busy it was at the end
        "load_average_1_5_15_min": [round(x, 2) for x in os.getloadavg()],
        **(extra or {}),
    }


def write_manifest(
    folder: str | Path, seeds=None, extra: dict | None = None, name: str = "manifest.json"
) -> Path:
    """Writes the manifest into `folder` (created if need be) and returns its path. Runs
    that share a folder (one per preset) pass their own `name`."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / name
    path.write_text(json.dumps(manifest(seeds, extra), indent=2) + "\n")
    return path
