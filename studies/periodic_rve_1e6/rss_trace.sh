#!/usr/bin/env bash
# The resident set of `granpack generate` of scene.toml (--fast, one worker, no
# figures) through the layers: VmRSS every 2 s into OUT_DIR/rss.txt ("seconds since
# the start, MB"), the layer lines into OUT_DIR/generate.log, and the process's peak
# (VmHWM, kB) every second into OUT_DIR/hwm.txt ("unix seconds, kB"), so that the
# stage that sets the peak can be read off against the layer lines and the pack's
# file times. Usage: rss_trace.sh OUT_DIR
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
out=${1:?usage: rss_trace.sh OUT_DIR}
mkdir -p "$out"
granpack generate "$here/scene.toml" --fast --no-figures --workers 1 --out "$out/rve" \
    > "$out/generate.log" 2>&1 &
pid=$!
t0=$(date +%s)
n=0
while kill -0 "$pid" 2>/dev/null; do
    status=$(cat "/proc/$pid/status" 2>/dev/null) || break
    if (( n % 2 == 0 )); then
        awk -v t=$(( $(date +%s) - t0 )) '/^VmRSS/{print t, int($2 / 1024)}' <<< "$status" >> "$out/rss.txt"
    fi
    awk -v t="$(date +%s)" '/^VmHWM/{print t, $2}' <<< "$status" >> "$out/hwm.txt"
    n=$(( n + 1 ))
    sleep 1
done
wait "$pid"
