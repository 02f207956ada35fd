#!/usr/bin/env bash
# Whole packs with the fast settings in wide periodic cells (pack_profile: 4.3, BASE=6,
# 26 858 spheres a layer, 5 layers; BASE=8, 47 747 a layer, 4 layers), two threads, by
# the build that re-sorts the pack after each layer (this checkout) and by BEFORE, the
# pack_profile of the build before it, alternately in ROUNDS rounds. CASES="10.6 5" runs
# other cells ("side layers" pairs) into OUT/packs_<side>m.txt instead. Run from the
# repository root:
#   bash studies/global_order/pack_order.sh BEFORE OUT [ROUNDS]
set -euo pipefail
before=${1:?pack_profile of the build before}
out=${2:?results folder}
rounds=${3:-1}
mkdir -p "$out"
cargo build --release --example pack_profile
after=target/release/examples/pack_profile
cases=${CASES:-"6 5;8 4"}
file=packs.txt
[ -n "${CASES:-}" ] && file=packs_$(echo "$cases" | cut -d' ' -f1)m.txt
for r in $(seq 1 "$rounds"); do
  IFS=';' read -ra list <<< "$cases"
  for case in "${list[@]}"; do
    set -- $case
    for build in before after; do
      bin=$before
      [ "$build" = after ] && bin=$after
      {
        echo "== round $r BASE=$1 layers=$2 build=$build"
        BASE=$1 PERIODIC=1 /usr/bin/time -f "%e s wall, %M kB peak" "$bin" fast "$2" 2>&1 | tail -n $(($2 + 2))
      } >> "$out/$file"
    done
  done
done
