#!/usr/bin/env bash
# The pair blocks' width: the settled 3D step and whole packs with the pair state stored
# in blocks of 128 to 4 096 pairs (the law runs on 128 at a time whatever the width).
# Builds profile_step and pack_profile from the commit's tree (git archive HEAD) with
# `BLOCK` set to each width, then:
# - timings.txt: the settled step on core 1 at 8 952, 80 568, 572 928 and 1 083 192
#   spheres (profile_step with TILES=1, 3, 8, 11), three rounds, the widths alternately;
# - packs.txt: pack_profile 2d, 2d fast and fast on two threads at 128 and the tree's
#   own width, three rounds alternately (wall time and the pack's checksum).
# Every build must print the same checksum for the same job. Run from the repository
# root (about 25 minutes):
#   bash studies/step_roofline/pair_block_width.sh studies/step_roofline/pair_block_width
set -euo pipefail
out=${1:?results folder}
mkdir -p "$out"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
own=$(sed -n 's/^pub const BLOCK: usize = .* else { \([0-9]*\) };/\1/p' src/dynamics/batched_law.rs)
widths="128 512 1024 2048 4096"
for b in $widths; do
  mkdir -p "$tmp/src_$b"
  git archive HEAD | tar -x -C "$tmp/src_$b"
  sed -i "s/^pub const BLOCK: usize = .*;/pub const BLOCK: usize = $b;/" \
    "$tmp/src_$b/src/dynamics/batched_law.rs"
  # one target folder: only granpack itself is built again for each width
  (cd "$tmp/src_$b" && CARGO_TARGET_DIR="$tmp/target" \
    cargo build --release --quiet --example profile_step --example pack_profile)
  cp "$tmp/target/release/examples/profile_step" "$tmp/profile_step_$b"
  cp "$tmp/target/release/examples/pack_profile" "$tmp/pack_profile_$b"
done
{
  for r in 1 2 3; do
    for t in 1 3 8 11; do
      case $t in 1) s=400 ;; 3) s=60 ;; *) s=20 ;; esac
      for b in $widths; do
        printf 'round %s BLOCK=%s TILES=%s steps=%s: ' "$r" "$b" "$t" "$s"
        TILES=$t taskset -c 1 "$tmp/profile_step_$b" "$s" 2>&1 | tr '\n' ' '
        echo
      done
    done
  done
} > "$out/timings.txt"
{
  for r in 1 2 3; do
    for job in "2d" "2d fast" "fast"; do
      for b in 128 "$own"; do
        t0=$(date +%s.%N)
        # shellcheck disable=SC2086
        sum=$("$tmp/pack_profile_$b" $job 2>&1 | tail -1 | grep -o 'checksum [0-9a-f]*')
        t1=$(date +%s.%N)
        printf 'round %s BLOCK=%s [%s]: %.2f s, %s\n' "$r" "$b" "$job" \
          "$(echo "$t1 - $t0" | bc)" "$sum"
      done
    done
  done
} > "$out/packs.txt"
python3 - "$out" "$widths" "$own" <<'EOF'
import json
import sys
from pathlib import Path

sys.path.insert(0, "studies/_common")
from manifest import manifest

out, widths, own = sys.argv[1:]
m = manifest(extra={"threads": "timings.txt: 1 (core 1); packs.txt: 2",
                    "widths": widths, "tree_block": int(own)})
m["command"] = f"bash studies/step_roofline/pair_block_width.sh {out}"
(Path(out) / "manifest.json").write_text(json.dumps(m, indent=2) + "\n")
EOF
