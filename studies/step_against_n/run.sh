#!/usr/bin/env bash
# The settled 3D step's cost a particle-step against N, on one core and on the machine's
# two, in one sitting: profile_step on the peers' 4.3 pack tiled TILES x TILES (1: 8 952,
# 3: 80 568, 11: 1 083 192 spheres; granpack's own 7 470-sphere pack where ../shared is
# absent), stored in rows of cells as the layer loop stores a large pack. Three rounds
# (ROUNDS=n for more); in each, every size on one thread (pinned to core 1) and then on
# two, so that a drift of the machine reaches every figure alike. Each size must print
# one checksum on one and two threads. Run from the repository root (about a minute,
# the build aside):
#   bash studies/step_against_n/run.sh studies/step_against_n
# With BEFORE=<commit>, that commit's profile_step (built in a worktree) runs before
# HEAD's in every round, the table gives both and their ratio round by round, and the
# two must print the same checksums (a change that keeps the bits):
#   BEFORE=2e8d57b bash studies/step_against_n/run.sh studies/step_against_n/zen4
set -euo pipefail
out=${1:?results folder}
mkdir -p "$out"
cargo build --release --quiet --example profile_step
builds=("after=target/release/examples/profile_step")
tmp=$(mktemp -d)
trap 'git worktree remove --force "$tmp/wt" >/dev/null 2>&1 || true; rm -rf "$tmp"' EXIT
if [ -n "${BEFORE:-}" ]; then
  git worktree add --detach "$tmp/wt" "$BEFORE" >/dev/null
  # the example finds the peers' packs at ../shared from the crate's root
  [ -d ../shared ] && ln -s "$(realpath ../shared)" "$tmp/shared"
  (cd "$tmp/wt" && CARGO_TARGET_DIR="$tmp/target" cargo build --release --quiet --example profile_step)
  builds=("before=$tmp/target/release/examples/profile_step" "${builds[@]}")
fi
{
  for r in $(seq "${ROUNDS:-3}"); do
    for t in 1 3 11; do
      case $t in 1) s=400 ;; 3) s=60 ;; *) s=20 ;; esac
      for th in 1 2; do
        pin=""
        [ "$th" = 1 ] && pin="taskset -c 1"
        for b in "${builds[@]}"; do
          printf 'round %s build=%s TILES=%s steps=%s threads=%s: ' "$r" "${b%%=*}" "$t" "$s" "$th"
          TILES=$t RAYON_NUM_THREADS=$th $pin "${b#*=}" "$s" 2>&1 | tr '\n' ' '
          echo
        done
      done
    done
  done
} > "$out/timings.txt"
python3 - "$out" <<'PY'
import json
import os
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
    r"build=(\w+) TILES=\d+ steps=\d+ threads=(\d): ([\d.]+) ns a particle-step (\d+) particles"
    r".*checksum (\w+)"
)
for line in (out / "timings.txt").read_text().splitlines():
    m = line_re.search(line)
    if m is None:
        sys.exit(f"unexpected line: {line}")
    build, threads, t, n, digest = m.groups()
    ns[(build, int(n), int(threads))].append(float(t))
    sums[int(n)].add(digest)
bad = {n: d for n, d in sums.items() if len(d) != 1}
if bad:
    sys.exit(f"checksums differ between runs or builds: {bad}")
sizes = sorted({n for _, n, _ in ns})
paired = ("before", sizes[0], 1) in ns
rows = ["| spheres | threads | rounds (ns a particle-step) | median | against the smallest |"
        + (" before: rounds | before: median | after / before, by round: median (range) |"
           if paired else ""),
        "|---|---|---|---|---|" + ("---|---|---|" if paired else "")]
for threads in (1, 2):
    base = statistics.median(ns[("after", sizes[0], threads)])
    for n in sizes:
        after = ns[("after", n, threads)]
        med = statistics.median(after)
        rounds = ", ".join(f"{x:.1f}" for x in after)
        row = f"| {n} | {threads} | {rounds} | {med:.1f} | {med / base:.2f}x |"
        if paired:
            before = ns[("before", n, threads)]
            ratios = [a / b for a, b in zip(after, before)]
            row += (f" {', '.join(f'{x:.1f}' for x in before)} | {statistics.median(before):.1f} |"
                    f" {statistics.median(ratios):.3f} ({min(ratios):.3f}-{max(ratios):.3f}) |")
        rows.append(row)
(out / "table.md").write_text("\n".join(rows) + "\n")
print("\n".join(rows))
extra = {"threads": "1 (pinned to core 1) and 2, alternately"}
if paired:
    extra["before"] = os.environ["BEFORE"]
m = manifest(extra=extra)
m["command"] = (f"BEFORE={os.environ['BEFORE']} " if paired else "") + (
    f"bash studies/step_against_n/run.sh {sys.argv[1]}")
(out / "manifest.json").write_text(json.dumps(m, indent=2) + "\n")
PY
