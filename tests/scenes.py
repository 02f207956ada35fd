"""Scenes the tests share (imported by the test modules; not a test module)."""

from __future__ import annotations

import granpack as gp


def small_scene(dim: int, **kw) -> gp.PackScene:
    """A small polydisperse pack of the paper's 4.2 (2D) or 4.4 (3D) radii that settles
    in seconds: a 0.2 m base, 0.08 or 0.1 m high, 0.5 s per layer, seed 11."""
    if dim == 2:
        base = gp.PackScene.preset("4.2").replace(base=(0.2,), height=0.08, settle_time=0.5)
    else:
        base = gp.PackScene.preset("4.4").replace(base=(0.2, 0.2), height=0.1, settle_time=0.5)
    return base.replace(seed=11, **kw)


def tiny_periodic_2d() -> gp.PackScene:
    """A periodic 2D cell 0.1 m wide of 1 cm discs, one loose layer of 0.04 m jammed for
    0.2 s: a pack in a fraction of a second, for the commands' checks before the work."""
    return gp.PackScene(
        dim=2,
        base=(0.1,),
        height=0.04,
        r_mean=0.01,
        h_layer=0.04,
        phi_layer=0.3,
        settle_time=0.2,
        container="periodic",
    )


def outputs_on_threads(script: str, *args: str) -> dict[str, list[str]]:
    """Runs `script` (Python source) in a fresh interpreter on one and on two rayon
    threads and returns the words it printed, by thread count."""
    import os
    import subprocess
    import sys

    out = {}
    for threads in ("1", "2"):
        env = {**os.environ, "RAYON_NUM_THREADS": threads}
        res = subprocess.run(
            [sys.executable, "-c", script, *args],
            env=env,
            capture_output=True,
            text=True,
            check=True,
        )
        out[threads] = res.stdout.split()
    return out
