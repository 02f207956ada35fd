#!/usr/bin/env bash
# The pair state's rows padded by one cache line (BLOCK_ROW, LANES_ROW), against the
# unpadded layout of BEFORE (default 2e8d57b), on the peers' 4.3 pack (8 952 spheres):
# the checksums of both builds in every configuration that profile_step has, the step
# timed alternately (studies/_common/alternate.py), each padding alone, the phases
# (the phase timers of commit f2dd79d applied to both), and cachegrind's first-level
# misses by function. Needs ../shared beside the repository, valgrind for the misses.
# Run from the repository root (about 15 minutes):
#   bash studies/column_padding/run.sh studies/column_padding
set -euo pipefail
arg=${1:?results folder}
out=$(realpath -m "$arg")
mkdir -p "$out"
before=${BEFORE:-2e8d57b}
tmp=$(mktemp -d)
trap 'for w in "$tmp"/wt_*; do git worktree remove --force "$w" >/dev/null 2>&1 || true; done; rm -rf "$tmp"' EXIT
git show f2dd79d:studies/step_limits/patches/phase_timers.patch > "$tmp/phase_timers.patch"
# the example finds the peers' packs at ../shared from the crate's root
[ -d ../shared ] && ln -s "$(realpath ../shared)" "$tmp/shared"
mkdir -p "$tmp/bin"
lib=src/dynamics/batched_law.rs
build() {  # build NAME REV [SED-EXPRESSION|phases]
  git worktree add --detach "$tmp/wt_$1" "$2" >/dev/null
  case "${3:-}" in
    "") ;;
    phases) git -C "$tmp/wt_$1" apply "$tmp/phase_timers.patch" ;;
    *) sed -i -E "$3" "$tmp/wt_$1/$lib"
       # a constant renamed since would leave the build unchanged, and its timing a lie
       if git -C "$tmp/wt_$1" diff --quiet; then echo "build $1: '$3' changed nothing" >&2; exit 1; fi ;;
  esac
  (cd "$tmp/wt_$1" && CARGO_TARGET_DIR="$tmp/target" cargo build --release --quiet --example profile_step)
  cp "$tmp/target/release/examples/profile_step" "$tmp/bin/$1"
}
build before "$before"
build after HEAD
build block_only HEAD 's/^pub const LANES_ROW: usize = .*;/pub const LANES_ROW: usize = LANES;/'
build scratch_only HEAD 's/^pub const BLOCK_ROW: usize = .*;/pub const BLOCK_ROW: usize = BLOCK;/'
build before_phases "$before" phases
build after_phases HEAD phases
b=$tmp/bin
# a failed measurement is reported in its place; the others still run
set +e
# ab ROUNDS ARGS NAME...: the builds NAME alternately, the first the reference, pinned
# to the cores in CPUS (default 1), on T threads (default 1), with the settings in ENVS
ab() {
  local rounds=$1 args=$2
  shift 2
  local runs=()
  for n in "$@"; do
    runs+=(--run "$n" "taskset -c ${CPUS:-1} env RAYON_NUM_THREADS=${T:-1} ${ENVS:-} $b/$n $args")
  done
  python3 studies/_common/alternate.py --rounds "$rounds" \
    --pattern '([0-9.]+) ns a particle-step' "${runs[@]}"
}
{
  echo "## checksums (before | after)"
  for cfg in "1 200" "2 200" "1 200 2d" "2 200 2d" "2 1000" "TILES=3 2 30" "ROLLING=0.1 2 200" \
             "LINEAR=1e6 2 200" "PERIODIC=1 TILES=2 2 30" "GRANPACK_CPU_LEVEL=x86-64 1 100" \
             "GRANPACK_CPU_LEVEL=x86-64-v2 1 100" "GRANPACK_CPU_LEVEL=x86-64-v3 1 100"; do
    read -r -a w <<< "$cfg"
    envs=()
    while [[ ${w[0]} == *=* ]]; do envs+=("${w[0]}"); w=("${w[@]:1}"); done
    s1=$(env "${envs[@]}" RAYON_NUM_THREADS="${w[0]}" "$b/before" "${w[@]:1}" 2>/dev/null)
    s2=$(env "${envs[@]}" RAYON_NUM_THREADS="${w[0]}" "$b/after" "${w[@]:1}" 2>/dev/null)
    same=differ
    [ "${s1##* }" = "${s2##* }" ] && [ -n "${s1##* }" ] && same=same
    echo "$cfg threads/steps: ${s1##* } | ${s2##* } $same"
  done
  echo "## clock"
  gcc -O2 -o "$tmp/freq" studies/step_roofline/freq.c && taskset -c 1 "$tmp/freq"
  echo "## 3D, one thread, 1 000 steps: before, after, each padding alone"
  ab 15 1000 before after block_only scratch_only
  echo "## 3D, two threads, 1 000 steps"
  T=2 CPUS=0,1 ab 10 1000 before after
  echo "## 2D (1 397 discs), one thread, 2 000 steps"
  ab 10 "2000 2d" before after
  echo "## 3D with rolling resistance, one thread, 1 000 steps"
  ENVS=ROLLING=0.1 ab 10 1000 before after
  echo "## 3D, 80 568 spheres (tiles 3 x 3), one thread, 100 steps"
  ENVS=TILES=3 ab 6 100 before after
  echo "## phases (ns a particle-step, 1 000 steps, one thread, seven runs each, alternately)"
  for r in 1 2 3 4 5 6 7; do
    for n in before_phases after_phases; do
      printf '%s ' "$n"
      RAYON_NUM_THREADS=1 taskset -c 1 "$b/$n" 1000 2>&1 | grep phases
    done
  done
  if command -v valgrind >/dev/null; then
    echo "## cachegrind, 40 steps, one thread, D1 32 KiB 8 ways, LL 1 MiB 16 ways (x86-64-v3: valgrind has no AVX-512)"
    for n in before after; do
      RAYON_NUM_THREADS=1 valgrind --tool=cachegrind --cache-sim=yes --D1=32768,8,64 \
        --LL=1048576,16,64 --cachegrind-out-file="$tmp/cg_$n.out" "$b/$n" 40 >/dev/null 2>&1
      echo "### $n (Ir Dr D1mr DLmr Dw D1mw DLmw)"
      cg_annotate --show=Ir,Dr,D1mr,DLmr,Dw,D1mw,DLmw "$tmp/cg_$n.out" 2>/dev/null \
        | grep -E "PROGRAM TOTALS|gather_each|pair_block|law_block|geometry_block|kick_drift_chunk" \
        | sed -E 's/\([ 0-9.]+%\)//g; s/  +/ /g' | cut -c1-200
    done
  fi
} | tee "$out/timings.txt"
python3 - "$out" "$arg" "$before" <<'PY'
import json
import sys
from pathlib import Path

sys.path.insert(0, "studies/_common")
from manifest import manifest

out, arg, before = Path(sys.argv[1]), sys.argv[2], sys.argv[3]
m = manifest(extra={"before": before, "pack": "the peers' settled 4.3 pack, 8 952 spheres"})
m["command"] = f"bash studies/column_padding/run.sh {arg}"
(out / "manifest.json").write_text(json.dumps(m, indent=2) + "\n")
PY
