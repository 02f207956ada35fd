"""The generation's peak memory and time under glibc's allocator settings: one periodic
4.3 `fast()` cell, generated in a fresh process per setting, the settings alternated
over rounds (this machine's speed drifts, see DEVELOPERS.md).

The peak a generation adds to the resident set is about four times the engine's state
(`results.md`). Most of the difference is memory that glibc keeps after the pair-list
rebuilds free it, so this measures, per setting: the peak, the resident set after the
generation, the resident set after ``malloc_trim(0)`` (what is live: the engine is
gone by then, so this is the pack and the interpreter), and the wall time.

    python studies/memory_per_particle/allocator.py --base 1.5 --rounds 2 \\
        --out studies/memory_per_particle/allocator

Writes ``results.json`` and ``results.md`` with a manifest. Linux with glibc only.
"""

from __future__ import annotations

import argparse
import ctypes
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "_common"))

from manifest import write_manifest  # noqa: E402
from memory import _kib, _reset_peak  # noqa: E402  (this folder's memory.py)

# name -> environment (glibc reads these at the process's first allocation)
SETTINGS: dict[str, dict[str, str]] = {
    "default": {},
    "MALLOC_ARENA_MAX=1": {"MALLOC_ARENA_MAX": "1"},
    "MALLOC_MMAP_THRESHOLD_=131072": {"MALLOC_MMAP_THRESHOLD_": "131072"},
    "MALLOC_MMAP_THRESHOLD_=1048576": {"MALLOC_MMAP_THRESHOLD_": "1048576"},
    "MALLOC_ARENA_MAX=1 MALLOC_TRIM_THRESHOLD_=1048576": {
        "MALLOC_ARENA_MAX": "1",
        "MALLOC_TRIM_THRESHOLD_": "1048576",
    },
}

_MIB = 2**20


def measure(base: float, seed: int) -> dict:
    """One generation in this process (MiB above the resident set before it)."""
    import granpack as gp

    scene = gp.PackScene.preset("4.3").replace(container="periodic", base=(base, base), seed=seed)
    start = _reset_peak()
    t = time.perf_counter()
    pack = gp.generate(scene.fast())
    out = {
        "n": len(pack),
        "seconds": time.perf_counter() - t,
        "peak_mib": (_kib("VmHWM:") - start) / _MIB,
        "after_mib": (_kib("VmRSS:") - start) / _MIB,
    }
    ctypes.CDLL("libc.so.6").malloc_trim(0)
    out["after_trim_mib"] = (_kib("VmRSS:") - start) / _MIB
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--base", type=float, default=1.5, help="side of the periodic cell (m)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--out", type=Path, default=HERE / "allocator")
    ap.add_argument(
        "--settings", nargs="+", choices=list(SETTINGS), default=list(SETTINGS), metavar="NAME"
    )
    ap.add_argument("--one", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.one:
        print(json.dumps(measure(args.base, args.seed)))
        return
    runs: dict[str, list[dict]] = {name: [] for name in args.settings}
    for r in range(args.rounds):
        for name in args.settings:
            env = SETTINGS[name]
            cmd = [sys.executable, __file__, "--one", "--base", str(args.base)]
            cmd += ["--seed", str(args.seed)]
            done = subprocess.run(
                cmd, capture_output=True, text=True, check=True, env={**os.environ, **env}
            )
            runs[name].append(json.loads(done.stdout.strip().splitlines()[-1]))
            d = runs[name][-1]
            print(f"round {r}: {name}: {d['peak_mib']:.1f} MiB, {d['seconds']:.1f} s")
    n = next(iter(runs.values()))[0]["n"]
    lines = [
        f"# The generation's memory under glibc's allocator settings ({n} spheres)\n",
        f"Periodic 4.3 cell of {args.base:g} m, `fast()`, seed {args.seed}; each setting in a "
        f"fresh process, {args.rounds} rounds, alternately. Bytes a particle above the "
        "resident set before the generation (median over the rounds); seconds by round.\n",
        "| setting | peak | after | after malloc_trim | seconds |",
        "|---|---|---|---|---|",
    ]
    for name, rs in runs.items():

        def per(key: str, rs: list[dict] = rs) -> float:
            return statistics.median(d[key] for d in rs) * 2**20 / n

        secs = " / ".join(f"{d['seconds']:.1f}" for d in rs)
        lines.append(
            f"| `{name}` | {per('peak_mib'):.0f} | {per('after_mib'):.0f} | "
            f"{per('after_trim_mib'):.0f} | {secs} |"
        )
    text = "\n".join(lines) + "\n"
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "results.json").write_text(json.dumps(runs, indent=1) + "\n")
    (args.out / "results.md").write_text(text)
    write_manifest(args.out, seeds=[args.seed])
    print(text)


if __name__ == "__main__":
    main()
