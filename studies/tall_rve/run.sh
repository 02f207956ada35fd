#!/usr/bin/env bash
# A periodic RVE of about 1e5 spheres, 1.5 m tall, with `--fast` as it is and with the
# bed frozen for good 0.4 m below the top, one after the other on all cores: each
# `granpack generate` under /usr/bin/time -v (wall time, peak RSS), its layer lines
# (N, height, seconds) in <variant>.log. Usage: run.sh OUT_DIR
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
out=${1:?usage: run.sh OUT_DIR}
mkdir -p "$out"
for v in fast rigid; do
    /usr/bin/time -v -o "$out/$v.time" \
        granpack generate "$here/$v.toml" --fast --no-figures --out "$out/$v" \
        > "$out/$v.log" 2>&1
    pack=$(ls "$out/$v"/packs/*.npz | head -1)
    granpack analyze "$pack" --json > "$out/$v.analyze.json" 2> "$out/$v.analyze.log"
done
python - "$here" "$out" "$0" "$@" <<'PY'
import json
import sys
from pathlib import Path

sys.path.insert(0, sys.argv[1] + "/../_common")
from manifest import manifest

m = manifest(seeds={"seed": 0, "stream": 0})
m["command"] = " ".join(["bash", *sys.argv[3:]])
(Path(sys.argv[2]) / "manifest.json").write_text(json.dumps(m, indent=2) + "\n")
PY
