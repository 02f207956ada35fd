#!/usr/bin/env bash
# A periodic RVE of about 1e6 spheres end to end: example 4.3 with fast() in a
# 10.6 m x 10.6 m periodic cell, then `granpack analyze` and a LAMMPS export of the
# pack, each command under /usr/bin/time -v (wall time and peak RSS). The layer lines
# (N, height, seconds a layer) go to generate.log. Usage: run.sh OUT_DIR; with
# SETTINGS=paper, the paper's settings instead of fast().
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
out=${1:?usage: run.sh OUT_DIR}
mkdir -p "$out"
case "${SETTINGS:-fast}" in
    fast) fast=--fast ;;
    paper) fast= ;;
    *) echo "SETTINGS must be fast or paper, not ${SETTINGS}" >&2; exit 2 ;;
esac
/usr/bin/time -v -o "$out/generate.time" \
    granpack generate "$here/scene.toml" $fast --no-figures --out "$out/rve" \
    > "$out/generate.log" 2>&1
pack=$(ls "$out"/rve/packs/*.npz | head -1)
/usr/bin/time -v -o "$out/analyze.time" \
    granpack analyze "$pack" --json > "$out/analyze.json" 2> "$out/analyze.log"
/usr/bin/time -v -o "$out/export.time" \
    granpack export "$pack" --format lammps --out "$out/rve.data" > "$out/export.log" 2>&1
ls -l "$out" > "$out/files.txt"
