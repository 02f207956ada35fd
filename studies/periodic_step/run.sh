#!/usr/bin/env bash
# The settled 3D step in a periodic cell against the same pack between walls: what the
# pair pass's minimum image (a rounding a periodic component, every pair, every step)
# costs. `profile_step` on the tiled 4.3 pack (TILES 2 and 8: 35 808 and 572 928
# spheres; an even TILES meets its mirror images across the cell's edges), the box and
# the periodic cell (PERIODIC=1) alternately, ROUNDS rounds, one thread, on core 1.
# Usage: bash studies/periodic_step/run.sh OUT [ROUNDS]
set -euo pipefail
out=${1:?results folder}
rounds=${2:-3}
mkdir -p "$out"
cargo build --release --example profile_step
step=target/release/examples/profile_step
for r in $(seq 1 "$rounds"); do
  for t in 2 8; do
    case $t in 2) s=400 ;; *) s=30 ;; esac
    for p in 0 1; do
      printf 'round %s TILES=%s PERIODIC=%s steps=%s: ' "$r" "$t" "$p" "$s"
      PERIODIC=$p TILES=$t taskset -c 1 "$step" "$s" 2>&1 | tr '\n' ' '
      echo
    done
  done
done > "$out/timings.txt"
