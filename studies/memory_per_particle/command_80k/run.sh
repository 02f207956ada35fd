#!/usr/bin/env bash
# The whole `granpack generate` of an 80 580-sphere periodic 4.3 cell (fast(), its
# microstructure and tables included) under /usr/bin/time -v, for two installs of
# granpack, one after the other: peak resident set and wall time of the command as a
# user runs it. Usage: run.sh OUT_DIR VENV_BEFORE VENV_AFTER
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
out=${1:?usage: run.sh OUT_DIR VENV_BEFORE VENV_AFTER}
mkdir -p "$out"
for side in before after; do
    if [ "$side" = before ]; then venv=${2:?}; else venv=${3:?}; fi
    env -u MALLOC_ARENA_MAX /usr/bin/time -v -o "$out/$side.time.txt" \
        "$venv/bin/granpack" generate "$here/scene.toml" --fast --no-figures \
        --out "$out/$side" > "$out/$side.log" 2>&1
done
