#!/usr/bin/env bash
# Cachegrind's instructions and last-level traffic of the four profile_step builds
# (see timings.sh), the difference of STEPS and 0 steps after the same setup, at
# TILES=k. Usage: [BUILDS="A_base E_fuse"] cachegrind.sh BIN_DIR TILES STEPS OUT_DIR
# (BUILDS: the binaries of BIN_DIR to run, by default the four); then, for each build,
# cg_diff OUT/<build>_0.out OUT/<build>_STEPS.out > diff.out and
# cg_annotate --show=Ir,Dr,Dw,DLmr,DLmw --auto=no diff.out.
set -euo pipefail
bins=${1:?folder of the builds}; tiles=${2:?TILES}; steps=${3:?STEPS}; out=${4:?output folder}
mkdir -p "$out"
for v in ${BUILDS:-A_base B_copy64 C_h32 D_all32}; do
  [ -x "$bins/$v" ] || continue
  for s in 0 "$steps"; do
    TILES=$tiles valgrind --tool=cachegrind --cache-sim=yes --LL=33554432,16,64 \
      --cachegrind-out-file="$out/${v}_$s.out" "$bins/$v" "$s" > "$out/${v}_$s.log" 2>&1
  done
done
