#!/usr/bin/env bash
# The pair search in a periodic cell against the same pack searched as bounded, by the
# build before the search skipped the minimum image away from the periodic edges
# (BEFORE_BIN: a folder with its search_profile and pack_profile) and by this checkout,
# alternately:
# - search_profile on profile_step's tiled pack of 4.3 (TILES 1, 3, 8: 8 952, 80 568 and
#   572 928 spheres), bounded and periodic, on 1 and 2 threads, ROUNDS rounds
#   (search.txt);
# - pack_profile fast in the million's 10.6 m periodic cell, LAYERS layers (83 825
#   spheres a layer), two threads, PACK_ROUNDS rounds (packs.txt).
# Run from the repository root:
#   bash studies/periodic_search/run.sh BEFORE_BIN OUT [ROUNDS] [LAYERS] [PACK_ROUNDS]
set -euo pipefail
before=${1:?folder with the build before: search_profile and pack_profile}
out=${2:?results folder}
rounds=${3:-3}
layers=${4:-4}
pack_rounds=${5:-1}
mkdir -p "$out"
cargo build --release --example search_profile --example pack_profile
after=target/release/examples
for r in $(seq 1 "$rounds"); do
  for tiles in 1 3 8; do
    for periodic in 0 1; do
      for threads in 1 2; do
        for build in before after; do
          bin=$before
          [ "$build" = after ] && bin=$after
          line=$(RAYON_NUM_THREADS=$threads TILES=$tiles PERIODIC=$periodic "$bin/search_profile" | tail -n 1)
          echo "round $r tiles $tiles periodic $periodic threads $threads build $build: $line" >> "$out/search.txt"
        done
      done
    done
  done
done
for r in $(seq 1 "$pack_rounds"); do
  for build in before after; do
    bin=$before
    [ "$build" = after ] && bin=$after
    {
      echo "== round $r BASE=10.6 layers=$layers build=$build"
      BASE=10.6 PERIODIC=1 /usr/bin/time -f "%e s wall, %M kB peak" "$bin/pack_profile" fast "$layers" 2>&1 | tail -n $((layers + 2))
    } >> "$out/packs.txt"
  done
done
