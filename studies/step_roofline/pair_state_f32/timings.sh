#!/usr/bin/env bash
# The settled 3D step with its pair state stored in single precision, against double:
# profile_step built from four trees (A: this commit; B: the law run on a double copy of
# each block, copied in and out, every bit as A; C: B with the tangential history stored
# as f32; D: B with the whole pair state stored as f32), on core 1, alternately, three
# rounds, at 8 952, 80 568 and 572 928 spheres (TILES=1, 3, 8). B, C and D are
# pair_state_f32.patch (`git show 9e71e29:studies/step_roofline/pair_state_f32/pair_state_f32.patch`; studies/HISTORY.md) applied to this commit, C and D with the two aliases it names set
# to f32. Usage: [BUILDS="A_base E_fuse"] timings.sh BIN_DIR > timings.txt, BIN_DIR
# holding the builds named (by default A_base, B_copy64, C_h32 and D_all32).
set -euo pipefail
bins=${1:?folder of the profile_step builds}
for r in 1 2 3; do
  for t in 1 3 8; do
    case $t in 1) s=1000 ;; 3) s=130 ;; *) s=40 ;; esac
    for v in ${BUILDS:-A_base B_copy64 C_h32 D_all32}; do
      printf 'round %s TILES=%s steps=%s %s: ' "$r" "$t" "$s" "$v"
      TILES=$t taskset -c 1 "$bins/$v" "$s" 2>&1 >/dev/null | tr '\n' ' '
      echo
    done
  done
done
