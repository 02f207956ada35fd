#!/usr/bin/env bash
# callgrind's cache simulation of the settled 3D step (40 steps of the peers' 4.3 pack,
# one thread, only inside World::step_n), with the first level and a last level the
# size of the second-level caches of the cores measured: 1 MiB (AMD EPYC family 25
# model 17) and 512 KiB (family 25 model 1). Misses of that last level are reads from
# the L3. Run from the repository root after a release build of profile_step:
#   cargo build --release --example profile_step
#   bash studies/step_limits/cache_sim.sh studies/step_limits/cache_sim.txt
set -euo pipefail
out=${1:?output file}
bin=target/release/examples/profile_step
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
{
  for ll in 1048576 524288; do
    echo "## D1 32 KiB, last level $((ll / 1024)) KiB (counts over 40 steps x 8 952 spheres)"
    RAYON_NUM_THREADS=1 valgrind --tool=callgrind --cache-sim=yes --D1=32768,8,64 \
      --LL=$ll,16,64 --callgrind-out-file="$tmp/cg.out" '--toggle-collect=*step_n*' \
      "$bin" 40 >/dev/null 2>&1
    callgrind_annotate --inclusive=no --show=Ir,DLmr,DLmw "$tmp/cg.out" \
      | grep -E "TOTALS|gather_each|pair_block|law_block|geometry_block|kick_drift|search_in" \
      | cut -c1-150
  done
} | tee "$out"
