#!/usr/bin/env bash
# Whole packs by two builds' pack_profile (BEFORE_BIN and AFTER_BIN: folders holding
# one each), one after the other, two threads: rebuilds, their seconds, the run's
# seconds and the state checksum of each.
# - small scenes: 4.3 fast in the 1 m box, 4.3 with the paper's settings (3 layers),
#   4.1 (2D) fast, 4.3 fast in a 4 m periodic cell (3 layers);
# - the million's 10.6 m periodic cell, fast, LAYERS layers, and AFTER again with the
#   widest skin at 0.3 and 0.4 of the radius instead of 0.2.
# Run from the repository root:
#   bash studies/rebuild_criterion/run.sh BEFORE_BIN AFTER_BIN OUT [LAYERS]
set -euo pipefail
before=${1:?folder with the build before: pack_profile}
after=${2:?folder with the build after: pack_profile}
out=${3:?results folder}
layers=${4:-3}
mkdir -p "$out"
one() { # name build env...
  local name=$1 build=$2
  shift 2
  local bin=$before
  [ "$build" = after ] && bin=$after
  {
    echo "== $name, build $build"
    env RAYON_NUM_THREADS=2 "$@" "$bin/pack_profile" "${ARGS[@]}"
  } >> "$out/packs.txt"
}
for build in before after; do
  ARGS=(fast); one "box 1 m fast" $build
  ARGS=(3); one "box 1 m paper, 3 layers" $build
  ARGS=(2d fast); one "2D box fast" $build
  ARGS=(fast 3); one "periodic 4 m fast, 3 layers" $build PERIODIC=1 BASE=4
done
ARGS=(fast "$layers")
one "periodic 10.6 m fast, $layers layers" before PERIODIC=1 BASE=10.6
one "periodic 10.6 m fast, $layers layers" after PERIODIC=1 BASE=10.6
one "periodic 10.6 m fast, $layers layers, SKIN 0.3" after PERIODIC=1 BASE=10.6 SKIN=0.3
one "periodic 10.6 m fast, $layers layers, SKIN 0.4" after PERIODIC=1 BASE=10.6 SKIN=0.4
