"""Brings the two packs of `run.sh` to rest (`granpack.settle`: YADE's unbalanced-force
ratio under 1e-4, local damping 0.4) and says what it took: a bed frozen for good feels
the weight of the layers above it only once the final relax thaws it, so its pack may
end further from rest than `fast()`'s.

    python studies/tall_rve/settle.py OUT_DIR   (the folder run.sh wrote)

Writes OUT_DIR/settle.json: per variant the speeds at the end of generate, then the
steps, seconds, phi and Z of the settled pack.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "_common"))
from manifest import write_manifest  # noqa: E402

import granpack as gp  # noqa: E402


def main(out: Path) -> None:
    result = {}
    for variant in ("fast", "rigid"):
        pack = gp.load_pack(next((out / variant / "packs").glob("*.npz")))
        speed = np.linalg.norm(pack.velocities, axis=1)
        t0 = time.perf_counter()
        rest = gp.settle(pack)
        seconds = time.perf_counter() - t0
        m = gp.microstructure(rest)
        result[variant] = {
            "n": len(pack),
            "moving_faster_than_0.01_m_s": int((speed > 0.01).sum()),
            "median_speed_m_s": float(np.median(speed)),
            "settle_steps": rest.record("rest").steps,
            "settle_seconds": seconds,
            "unbalanced": rest.record("rest").report["unbalanced"],
            "phi_before": pack.phi,
            "phi_after": rest.phi,
            "z_before": gp.microstructure(pack).z,
            "z_after": m.z,
        }
        print(variant, result[variant], flush=True)
    (out / "settle.json").write_text(json.dumps(result, indent=2) + "\n")
    write_manifest(out, seeds={"seed": 0, "stream": 0}, name="manifest_settle.json")


if __name__ == "__main__":
    main(Path(sys.argv[1]))
