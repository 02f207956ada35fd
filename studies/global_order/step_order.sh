#!/usr/bin/env bash
# The settled 3D step with the particles stored as a layer-by-layer pack stores them
# (bands of 0.045 m from the bottom up, each in its own Morton order: LAYERS=0.045) and
# in one Morton order over the whole pack (ORDER=morton: the benchmarks' order, and the
# layer loop's from RESORT_MIN_LAYER particles a layer, until the row-major order of
# studies/row_order/ replaced it), at 8 952, 35 808, 80 568, 223 800 and
# 572 928 spheres (profile_step TILES=1, 2, 3, 5, 8), on one and two threads, three
# rounds, the two orders alternately. Run from the repository root:
#   bash studies/global_order/step_order.sh studies/global_order/step
set -euo pipefail
out=${1:?results folder}
mkdir -p "$out"
cargo build --release --example profile_step
step=target/release/examples/profile_step
{
  for r in 1 2 3; do
    for t in 1 2 3 5 8; do
      case $t in 1) s=1000 ;; 2) s=300 ;; 3) s=150 ;; 5) s=60 ;; *) s=40 ;; esac
      for th in 1 2; do
        for order in layers morton; do
          layers=""
          morton=morton
          [ "$order" = layers ] && layers=0.045 && morton=
          printf 'round %s TILES=%s threads=%s order=%s steps=%s: ' "$r" "$t" "$th" "$order" "$s"
          ORDER=$morton LAYERS=$layers TILES=$t RAYON_NUM_THREADS=$th "$step" "$s" 2>&1 | tr '\n' ' '
          echo
        done
      done
    done
  done
} > "$out/timings.txt"
