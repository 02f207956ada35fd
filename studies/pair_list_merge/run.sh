#!/usr/bin/env bash
# The pair list's rebuild in the million's 10.6 m periodic cell of example 4.3 with the
# fast settings, two builds side by side on this machine: where a rebuild's time goes
# (phases.txt: the builds with phase_timers.patch applied, `pack_profile fast 3`; each
# line is the mean over the last 200 rebuilds, which may straddle two layers) and the
# whole run (packs.txt: `pack_profile fast LAYERS`, ROUNDS rounds, the builds
# alternately, each under /usr/bin/time).
# BEFORE and AFTER: folders, each with `pack_profile` and `pack_profile_phases` (the
# same checkout built again with phase_timers.patch applied:
#   git apply <(git show ec5eb5a:studies/pair_list_merge/phase_timers.patch) &&
#   cargo build --release --example pack_profile).
# Usage: bash studies/pair_list_merge/run.sh BEFORE AFTER OUT [ROUNDS] [LAYERS]
set -euo pipefail
before=${1:?folder of the build before}
after=${2:?folder of the build after}
out=${3:?results folder}
rounds=${4:-2}
layers=${5:-4}
mkdir -p "$out"
for b in before after; do
  dir=$before
  [ "$b" = after ] && dir=$after
  echo "== BASE=10.6 PERIODIC=1 fast 3, build=$b"
  BASE=10.6 PERIODIC=1 "$dir/pack_profile_phases" fast 3 2>&1
done > "$out/phases.txt"
for r in $(seq 1 "$rounds"); do
  for b in before after; do
    dir=$before
    [ "$b" = after ] && dir=$after
    echo "== round $r BASE=10.6 PERIODIC=1 layers=$layers build=$b"
    BASE=10.6 PERIODIC=1 /usr/bin/time -f "%e s wall, %M kB peak" "$dir/pack_profile" fast "$layers" 2>&1
  done
done > "$out/packs.txt"
