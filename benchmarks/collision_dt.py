"""How well a time step resolves the collisions of a landing layer.

A new layer falls through its slab (h_layer) before it lands, so its particles hit the
bed at about v = sqrt(2 g h_layer). Two equal spheres of a preset collide at that
speed, head-on and at 45 degrees, with a range of dt (the discs of the 2D presets
have the mass of a sphere by default and collide in the same way). The script reports how many steps
the contact lasts and how far the normal restitution e_n and the rebound spin move from
a reference run at dt = 1e-6 s.

The stable-step estimate (Rayleigh) bounds dt by the elastic wave speed; it says
nothing about how many steps a collision at the landing speed gets. That number is what
limits dt when the statistics of a pack must not change (see the README, "Speed").

Each step is run with both integrators: plain velocity Verlet (the dashpots see the
half-step velocity; `predict_velocity=False`, the default) and with the velocity
predictor (`predict_velocity=True`, as in `PackScene.fast()`), both against the same
reference (plain Verlet at 1e-6 s; the two agree there to 1e-6).

    python benchmarks/collision_dt.py --preset 4.3 --out benchmarks/results
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import polars as pl

import granpack as gp
from granpack.pack import atomic_write


def collide(
    scene: gp.PackScene, dt: float, angle_deg: float, v0: float, predict: bool = False
) -> dict[str, float]:
    """One collision of two spheres of radius r_min, the first at rest; returns steps in
    contact, normal restitution and the spin of the moving sphere after it."""
    r = scene.r_min
    sim = gp.Simulation(
        dim=3,
        material=scene.material,
        dt=dt,
        gravity=(0.0, 0.0, 0.0),
        box=None,
        rotations=scene.rotations,
        predict_velocity=predict,
    )
    a = np.radians(angle_deg)
    n = np.array([np.sin(a), 0.0, np.cos(a)])  # centre 0 -> centre 1 at first touch
    x0 = np.array([0.0, 0.0, 1.0])
    sim.add_particles(
        [x0, x0 + 2.0 * r * (1.0 + 1e-4) * n], [r, r], velocities=[[0, 0, 0], [0, 0, -v0]]
    )
    v_in = -v0 * n[2]  # approach speed along the normal (negative: closing)
    steps = 0
    touching = 0
    while steps < 10_000_000:
        sim.step(1)
        steps += 1
        if len(sim.contacts().i):
            touching += 1
        elif touching:
            break
    v = sim.velocities
    return {
        "steps_in_contact": touching,
        "e_n": float(-((v[1] - v[0]) @ n) / v_in),
        "spin": float(np.linalg.norm(sim.spins[1])),
    }


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--preset", default="4.3")
    ap.add_argument("--out", type=Path, default=Path("bench-collision-dt"))
    a = ap.parse_args(argv)
    scene = gp.PackScene.preset(a.preset)
    v0 = float(np.sqrt(2.0 * scene.gravity * scene.h_layer))
    rayleigh = scene.material.critical_time_step(scene.r_min)
    steps = {
        "reference 1e-6 s": 1e-6,
        "paper": scene.dt,
        "0.5 Rayleigh": 0.5 * rayleigh,
        "0.9 Rayleigh": 0.9 * rayleigh,
    }
    if 2.0 * scene.dt < 0.9 * rayleigh:
        steps["2 x paper"] = 2.0 * scene.dt
    rows = []
    ref = {angle: collide(scene, 1e-6, angle, v0) for angle in (0.0, 45.0)}
    for label, dt in steps.items():
        for predict, angle in ((p, ang) for p in (False, True) for ang in (0.0, 45.0)):
            c = collide(scene, dt, angle, v0, predict)
            rows.append(
                {
                    "preset": a.preset,
                    "integrator": "predictor" if predict else "verlet",
                    "dt_label": label,
                    "dt": dt,
                    "angle_deg": angle,
                    "landing_speed": v0,
                    **c,
                    "e_n_error": c["e_n"] / ref[angle]["e_n"] - 1.0,
                    "spin_error": (c["spin"] / ref[angle]["spin"] - 1.0) if angle else 0.0,
                }
            )
    df = pl.DataFrame(rows)
    a.out.mkdir(parents=True, exist_ok=True)
    atomic_write(a.out / f"collision_dt_{a.preset}.csv", df.write_csv().encode())
    with pl.Config(tbl_rows=-1, tbl_cols=-1, float_precision=4):
        print(f"landing speed {v0:.3f} m/s, Rayleigh step {rayleigh:.3g} s")
        print(df.drop("preset", "landing_speed"))


if __name__ == "__main__":
    main()
