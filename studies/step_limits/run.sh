#!/usr/bin/env bash
# The settled 3D step's limits on one core, from throwaway builds: each patch (kept in
# commit f2dd79d, under studies/step_limits/patches/, and applying to c2776a5) is applied
# to a clean worktree of HEAD (or of REV=c2776a5), profile_step is built, and the
# builds are timed against the unpatched one in turn (studies/_common/alternate.py), on
# the peers' 4.3 pack (8 952 spheres). Needs ../shared beside the repository, valgrind
# for the instruction and branch counts. Run from the repository root (about 25 minutes):
#   bash studies/step_limits/run.sh studies/step_limits
set -euo pipefail
arg=${1:?results folder}
out=$(realpath -m "$arg")
mkdir -p "$out"
tmp=$(mktemp -d)
trap 'git worktree remove --force "$tmp/wt" >/dev/null 2>&1 || true; rm -rf "$tmp"' EXIT
git worktree add --detach "$tmp/wt" "${REV:-HEAD}" >/dev/null
# the patches, from the commit that holds them
mkdir -p "$tmp/patches"
for p in law_without_divider sweep_always prefetch_second_particle slide_chunks \
         timed_force_plan phase_timers; do
  git show "f2dd79d:studies/step_limits/patches/$p.patch" > "$tmp/patches/$p.patch"
done
# the benches find the peers' packs at ../shared from the crate's root
[ -d ../shared ] && ln -s "$(realpath ../shared)" "$tmp/shared"
mkdir -p "$tmp/bin"
build() {  # build NAME [PATCH]
  if [ -n "${2:-}" ]; then git -C "$tmp/wt" apply "$tmp/patches/$2"; fi
  (cd "$tmp/wt" && CARGO_TARGET_DIR="$tmp/target" cargo build --release --quiet --example profile_step)
  cp "$tmp/target/release/examples/profile_step" "$tmp/bin/$1"
  git -C "$tmp/wt" checkout -q -- . && git -C "$tmp/wt" clean -fdq
}
build base
for p in law_without_divider sweep_always prefetch_second_particle slide_chunks \
         timed_force_plan phase_timers; do
  build "$p" "$p.patch"
done
b=$tmp/bin
# a failed measurement is reported in its place; the others still run
set +e
# ab BUILD ROUNDS STEPS [2d]: BUILD against the unpatched one, alternately, pinned to
# the cores in CPUS (default 1), on T threads (default 1); the ratio is BUILD / base
ab() {
  local cmd="taskset -c ${CPUS:-1} env RAYON_NUM_THREADS=${T:-1}"
  python3 studies/_common/alternate.py --rounds "$2" --pattern '([0-9.]+) ns a particle-step' \
    --run base "$cmd $b/base $3 ${4:-}" --run "$(basename "$1")" "$cmd $1 $3 ${4:-}"
}
{
  echo "## checksums (200 steps; 3D on 1 and 2 threads, 2D)"
  # (the build without the divider changes the physics: its own checksums)
  for x in base sweep_always prefetch_second_particle slide_chunks timed_force_plan; do
    s1=$(RAYON_NUM_THREADS=1 "$b/$x" 200 2>/dev/null) || s1=failed
    s2=$(RAYON_NUM_THREADS=2 "$b/$x" 200 2>/dev/null) || s2=failed
    s3=$(RAYON_NUM_THREADS=2 "$b/$x" 200 2d 2>/dev/null) || s3=failed
    echo "$x: ${s1##* } ${s2##* } ${s3##* }"
  done
  echo "## clock"
  gcc -O2 -o "$tmp/freq" studies/step_roofline/freq.c && taskset -c 1 "$tmp/freq"
  echo "## phases (ns a particle-step, 1 000 steps, one thread, seven runs)"
  for r in 1 2 3 4 5 6 7; do RAYON_NUM_THREADS=1 taskset -c 1 "$b/phase_timers" 1000 2>&1 | grep phases; done
  echo "## law without divider against base"; ab "$b/law_without_divider" 15 1000
  echo "## sweep always against base, one thread"; ab "$b/sweep_always" 15 1000
  echo "## sweep always against base, two threads"; T=2 CPUS=0,1 ab "$b/sweep_always" 15 1000
  echo "## sweep always against base, 2D, one thread"; ab "$b/sweep_always" 15 2000 2d
  echo "## prefetch (PFW=7, 16 pairs ahead) against base"; PFW=7 ab "$b/prefetch_second_particle" 15 1000
  echo "## prefetch patch with no prefetch (PFW=0) against base"; PFW=0 ab "$b/prefetch_second_particle" 15 1000
  echo "## slide chunks against base"; ab "$b/slide_chunks" 9 1000
  echo "## timed force plan against base"; ab "$b/timed_force_plan" 15 1000
  if command -v valgrind >/dev/null; then
    echo "## callgrind, base, 40 steps, one thread (x86-64-v3: valgrind has no AVX-512)"
    RAYON_NUM_THREADS=1 valgrind --tool=callgrind --branch-sim=yes \
      --callgrind-out-file="$tmp/cg.out" '--toggle-collect=*step_n*' "$b/base" 40 >/dev/null 2>&1
    callgrind_annotate --inclusive=no "$tmp/cg.out" | grep -E "TOTALS|gather_each|pair_block|law_block|geometry_block|kick_drift|search_in" | cut -c1-170
  fi
} | tee "$out/timings.txt"
python3 - "$out" "$arg" <<'PY'
import json
import sys
from pathlib import Path

sys.path.insert(0, "studies/_common")
from manifest import manifest

out = Path(sys.argv[1])
m = manifest(extra={"pack": "the peers' 4.3 pack, 8 952 spheres", "threads": "1 pinned to core 1, and 2"})
m["command"] = f"bash studies/step_limits/run.sh {sys.argv[2]}"
(out / "manifest.json").write_text(json.dumps(m, indent=2) + "\n")
PY
