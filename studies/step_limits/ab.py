"""Paired timing of two profile_step builds: A and B run in turn, RUNS times, each
pinned to one core, and the ratio A/B is taken pair by pair, so that a drift of the
machine reaches both alike. Prints each build's median and range of ns a
particle-step (profile_step's own figure, set-up excluded), its checksums, and the
median and range of the paired ratios.

    python ab.py A_BIN B_BIN RUNS STEPS [2d]

The environment's T (threads, default 1) and CPUS (the cores for taskset, default 1)
apply to both builds.
"""

from __future__ import annotations

import os
import re
import statistics
import subprocess
import sys


def run(binary: str, steps: str, extra: list[str], env: dict[str, str]) -> tuple[float, str]:
    cmd = ["taskset", "-c", os.environ.get("CPUS", "1"), binary, steps, *extra]
    out = subprocess.run(cmd, env=env, capture_output=True, text=True, check=True)
    ns = re.search(r"([\d.]+) ns a particle-step", out.stderr)
    digest = re.search(r"checksum (\w+)", out.stdout)
    if ns is None or digest is None:
        sys.exit(f"unexpected output of {binary}: {out.stdout} {out.stderr}")
    return float(ns.group(1)), digest.group(1)


def main() -> None:
    a, b, runs, steps, *extra = sys.argv[1:]
    env = dict(os.environ, RAYON_NUM_THREADS=os.environ.get("T", "1"))
    times: dict[str, list[float]] = {a: [], b: []}
    sums: dict[str, set[str]] = {a: set(), b: set()}
    ratios = []
    for _ in range(int(runs)):
        pair = []
        for x in (a, b):
            ns, digest = run(x, steps, extra, env)
            times[x].append(ns)
            sums[x].add(digest)
            pair.append(ns)
        ratios.append(pair[0] / pair[1])
    for x in (a, b):
        t = times[x]
        print(
            f"{os.path.basename(x)}: median {statistics.median(t):.1f} ns "
            f"(min {min(t):.1f}, max {max(t):.1f}), checksum {' '.join(sorted(sums[x]))}"
        )
    print(
        f"ratio A/B: median {statistics.median(ratios):.3f} "
        f"(min {min(ratios):.3f}, max {max(ratios):.3f}) over {runs} pairs"
    )


if __name__ == "__main__":
    main()
