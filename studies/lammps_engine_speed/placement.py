"""The layer placement alone (`granpack._core.LayerPlacer`, what rank 0 runs for every
layer of the LAMMPS engine while the other ranks wait), timed on one thread as the MPI
job runs it (RAYON_NUM_THREADS=1 a rank).

For each base side (m) of the million-sphere RVE's periodic scene: the first layer on an
empty floor, then a second on the first one's particles near its top (those the engine
gathers: top above the height less 2 r_max). Seconds and microseconds a sphere.

    RAYON_NUM_THREADS=1 taskset -c 1 python studies/lammps_engine_speed/placement.py \
        [--sides 10.6,33.52]

Writes ``placement.json`` and ``manifest_placement.json``.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
sys.path.insert(0, str(HERE.parent / "_common"))
from manifest import write_manifest  # noqa: E402


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", default=str(HERE))
    p.add_argument("--sides", default="10.6,33.52")
    args = p.parse_args()
    warnings.simplefilter("ignore")
    import granpack as gp
    from granpack import _core

    up = lambda: subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()  # noqa: E731
    rows = []
    for side in (float(s) for s in args.sides.split(",")):
        scene = gp.PackScene.from_toml(ROOT / "studies" / "periodic_rve_1e6" / "scene.toml")
        scene = scene.replace(base=(side, side))
        placer = _core.LayerPlacer(scene)
        before = up()
        t = time.perf_counter()
        x, r = placer.place(np.zeros((0, 3)), np.zeros(0), 0.0)
        t0 = time.perf_counter() - t
        h = float(np.max(x[:, 2] + r))
        near = x[:, 2] + r > h - 2.0 * float(r.max())
        xn, rn = np.ascontiguousarray(x[near]), np.ascontiguousarray(r[near])
        t = time.perf_counter()
        x2, r2 = placer.place(xn, rn, h)
        t1 = time.perf_counter() - t
        row = {
            "base_side_m": side,
            "layer0_spheres": len(r),
            "layer0_s": t0,
            "layer0_us_per_sphere": 1e6 * t0 / len(r),
            "layer1_spheres": len(r2),
            "layer1_below": int(near.sum()),
            "layer1_s": t1,
            "layer1_us_per_sphere": 1e6 * t1 / len(r2),
            "gathered_bytes_layer1": int(near.sum()) * 32,
            "broadcast_bytes_layer1": len(r2) * 32,
            "uptime_before": before,
            "uptime_after": up(),
        }
        print(json.dumps(row), flush=True)
        rows.append(row)
    out = Path(args.out)
    (out / "placement.json").write_text(json.dumps(rows, indent=1) + "\n")
    write_manifest(out, name="manifest_placement.json", extra={"sides_m": args.sides})


if __name__ == "__main__":
    main()
