#!/usr/bin/env bash
# The settled 3D step's cost a particle-step against N, on one core and on the machine's
# two, in one sitting: profile_step on the peers' 4.3 pack tiled TILES x TILES (1: 8 952,
# 3: 80 568, 11: 1 083 192 spheres; granpack's own 7 470-sphere pack where ../shared is
# absent), stored in rows of cells as the layer loop stores a large pack. Three rounds;
# in each, every size on one thread (pinned to core 1) and then on two, so that a drift
# of the machine reaches every figure alike. Each size must print one checksum on one
# and two threads. Run from the repository root (about a minute, the build aside):
#   bash studies/step_against_n/run.sh studies/step_against_n
set -euo pipefail
out=${1:?results folder}
mkdir -p "$out"
cargo build --release --quiet --example profile_step
bin=target/release/examples/profile_step
{
  for r in 1 2 3; do
    for t in 1 3 11; do
      case $t in 1) s=400 ;; 3) s=60 ;; *) s=20 ;; esac
      printf 'round %s TILES=%s steps=%s threads=1: ' "$r" "$t" "$s"
      TILES=$t RAYON_NUM_THREADS=1 taskset -c 1 "$bin" "$s" 2>&1 | tr '\n' ' '
      echo
      printf 'round %s TILES=%s steps=%s threads=2: ' "$r" "$t" "$s"
      TILES=$t RAYON_NUM_THREADS=2 "$bin" "$s" 2>&1 | tr '\n' ' '
      echo
    done
  done
} > "$out/timings.txt"
python3 - "$out" <<'PY'
import json
import re
import statistics
import sys
from collections import defaultdict
from pathlib import Path

sys.path.insert(0, "studies/_common")
from manifest import manifest

out = Path(sys.argv[1])
ns = defaultdict(list)
sums = defaultdict(set)
line_re = re.compile(
    r"TILES=\d+ steps=\d+ threads=(\d): ([\d.]+) ns a particle-step (\d+) particles"
    r".*checksum (\w+)"
)
for line in (out / "timings.txt").read_text().splitlines():
    m = line_re.search(line)
    if m is None:
        sys.exit(f"unexpected line: {line}")
    threads, t, n, digest = m.groups()
    ns[(int(n), int(threads))].append(float(t))
    sums[int(n)].add(digest)
bad = {n: d for n, d in sums.items() if len(d) != 1}
if bad:
    sys.exit(f"checksums differ between runs: {bad}")
sizes = sorted({n for n, _ in ns})
rows = ["| spheres | threads | rounds (ns a particle-step) | median | against the smallest |",
        "|---|---|---|---|---|"]
for threads in (1, 2):
    base = statistics.median(ns[(sizes[0], threads)])
    for n in sizes:
        med = statistics.median(ns[(n, threads)])
        rounds = ", ".join(f"{x:.1f}" for x in ns[(n, threads)])
        rows.append(f"| {n} | {threads} | {rounds} | {med:.1f} | {med / base:.2f}x |")
(out / "table.md").write_text("\n".join(rows) + "\n")
print("\n".join(rows))
m = manifest(extra={"threads": "1 (pinned to core 1) and 2, alternately"})
m["command"] = f"bash studies/step_against_n/run.sh {sys.argv[1]}"
(out / "manifest.json").write_text(json.dumps(m, indent=2) + "\n")
PY
