#!/usr/bin/env bash
# The settled 3D step against the machine's limits, on one core: the core's clock (a
# chain of dependent register adds), the bandwidth of a STREAM triad and copy at three
# working sets (inside L2/L3, inside L3, in memory), the step's instructions (callgrind on
# profile_step 100 and 300, which run 120 and 320 steps: the difference is 200 steps) and
# its wall time (profile_step 300 and 1300 on core 1, three times each: 1 000 steps apart).
# Run from the repository root: bash studies/step_roofline/roofline.sh
set -euo pipefail
here=studies/step_roofline
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
gcc -O2 -o "$tmp/freq" "$here/freq.c"
gcc -O3 -march=native -o "$tmp/triad" "$here/triad.c"
cargo build --release --example profile_step
step=target/release/examples/profile_step
taskset -c 1 "$tmp/freq"
for b in 1500000 12000000 768000000; do taskset -c 1 "$tmp/triad" "$b"; done
for s in 100 300; do
  valgrind --tool=callgrind --callgrind-out-file="$tmp/cg_$s.out" "$step" "$s" 2>&1 | grep -E "checksum|refs"
done
for r in 1 2 3; do
  for s in 300 1300; do
    /usr/bin/time -f "$s steps: %e s" taskset -c 1 "$step" "$s" > /dev/null
  done
done
