#!/usr/bin/env bash
# The settled 3D step with the tiled pack stored in one Morton order against one
# row-major order (`geometry::row_major_order`), one build, profile_step's `ORDER`:
# - timings.txt: core 1 at TILES=1, 3, 8, 11 (8 952, 80 568, 572 928 and 1 083 192 of the
#   peers' spheres; granpack's own 7 470-sphere pack where ../shared is absent), three
#   rounds, the orders alternately;
# - timings_2threads.txt: TILES=11 on two threads, three rounds alternately.
# Each order must print the same checksum on one and two threads. Run from the
# repository root (about 8 minutes):
#   bash studies/row_order/step_order.sh studies/row_order/step
set -euo pipefail
out=${1:?results folder}
mkdir -p "$out"
cargo build --release --quiet --example profile_step
bin=target/release/examples/profile_step
{
  for r in 1 2 3; do
    for t in 1 3 8 11; do
      case $t in 1) s=400 ;; 3) s=60 ;; *) s=20 ;; esac
      for o in morton rows; do
        printf 'round %s ORDER=%s TILES=%s steps=%s: ' "$r" "$o" "$t" "$s"
        ORDER=$o TILES=$t taskset -c 1 "$bin" "$s" 2>&1 | tr '\n' ' '
        echo
      done
    done
  done
} > "$out/timings.txt"
{
  for r in 1 2 3; do
    for o in morton rows; do
      printf 'round %s ORDER=%s TILES=11 steps=20 threads=2: ' "$r" "$o"
      ORDER=$o TILES=11 RAYON_NUM_THREADS=2 "$bin" 20 2>&1 | tr '\n' ' '
      echo
    done
  done
} > "$out/timings_2threads.txt"
python3 - "$out" <<'PY'
import json
import sys
from pathlib import Path

sys.path.insert(0, "studies/_common")
from manifest import manifest

out = sys.argv[1]
m = manifest(extra={"threads": "timings.txt: 1 (core 1); timings_2threads.txt: 2"})
m["command"] = f"bash studies/row_order/step_order.sh {out}"
(Path(out) / "manifest.json").write_text(json.dumps(m, indent=2) + "\n")
PY
