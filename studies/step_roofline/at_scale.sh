#!/usr/bin/env bash
# The settled 3D step once its state leaves the last-level cache, on one core: where its
# memory traffic comes from (cachegrind's simulated caches, 32 KiB L1 and a 32 MiB last
# level, on 80 568 spheres: the difference of 20 and 0 steps after the same setup), and
# its wall time a particle-step at 8 952, 80 568 and 572 928 spheres (profile_step with
# TILES=1, 3, 8 on core 1, three rounds, alternately). Also records whether the kernel
# gives transparent huge pages. Run from the repository root:
#   bash studies/step_roofline/at_scale.sh studies/step_roofline/at_scale
set -euo pipefail
out=${1:?results folder}
mkdir -p "$out"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# line tables for cg_annotate, in a target folder of their own
CARGO_TARGET_DIR=target/lines CARGO_PROFILE_RELEASE_DEBUG=line-tables-only \
  cargo build --release --example profile_step
step=target/lines/release/examples/profile_step
for s in 0 20; do
  TILES=3 valgrind --tool=cachegrind --cache-sim=yes --LL=33554432,16,64 \
    --cachegrind-out-file="$tmp/cg_$s.out" "$step" "$s" > "$tmp/cg_$s.log" 2>&1
done
cg_diff "$tmp/cg_0.out" "$tmp/cg_20.out" > "$tmp/diff.out"
cg_annotate --show=Dr,D1mr,DLmr,Dw,D1mw,DLmw --sort=DLmr --auto=no "$tmp/diff.out" \
  | sed "s#$PWD/##; s#$tmp/##g" > "$out/cachegrind_80k.txt"
{
  for r in 1 2 3; do
    for t in 1 3 8; do
      case $t in 1) s=1000 ;; 3) s=130 ;; *) s=20 ;; esac
      printf 'round %s TILES=%s steps=%s: ' "$r" "$t" "$s"
      TILES=$t taskset -c 1 "$step" "$s" 2>&1 >/dev/null
    done
  done
} > "$out/timings.txt"
{
  echo "transparent_hugepage/enabled: $(cat /sys/kernel/mm/transparent_hugepage/enabled)"
  TILES=3 "$step" 400 > /dev/null 2>&1 &
  sleep 3
  echo "AnonHugePages during a TILES=3 run: $(grep AnonHugePages /proc/meminfo)"
  wait
} > "$out/huge_pages.txt"
