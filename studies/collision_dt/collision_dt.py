"""How well a time step resolves the collisions of a landing layer.

A new layer falls through its slab (h_layer) before it lands, so its particles hit the
bed at about v = sqrt(2 g h_layer). Two equal spheres of a preset collide at that
speed, head-on and at 45 degrees, with a range of dt (the discs of the 2D presets
have the mass of a sphere by default and collide in the same way). The script reports
how many steps the contact lasts and how far the normal restitution e_n and the rebound
spin move from a reference run at dt = 1e-6 s: the mean over 8 phases of the first
touch within a step, and the largest (with a few steps in contact the error depends on
where in a step the contact begins).

The stable-step estimate (Rayleigh) bounds dt by the elastic wave speed; it says
nothing about how many steps a collision at the landing speed gets. That number is what
limits dt when the statistics of a pack must not change (docs/performance.md, "The fast settings").

    python studies/collision_dt/collision_dt.py --preset 4.3 --out studies/collision_dt
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import polars as pl

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "_common"))
from manifest import write_manifest  # noqa: E402

import granpack as gp  # noqa: E402
from granpack.pack import atomic_write  # noqa: E402

#: First-touch phases per step (see `collide`) over which the errors are averaged.
PHASES = 8


def collide(
    scene: gp.PackScene,
    dt: float,
    angle_deg: float,
    v0: float,
    phase: float = 0.0,
) -> dict[str, float]:
    """One collision of two spheres of radius r_min, the first at rest; returns steps in
    contact, normal restitution and the spin of the moving sphere after it. `phase` (in
    [0, 1)) moves the first touch by that fraction of a step."""
    r = scene.r_min
    sim = gp.Simulation(
        dim=3,
        material=scene.material,
        dt=dt,
        gravity=(0.0, 0.0, 0.0),
        box=None,
        rotations=scene.rotations,
    )
    a = np.radians(angle_deg)
    n = np.array([np.sin(a), 0.0, np.cos(a)])  # centre 0 -> centre 1 at first touch
    x0 = np.array([0.0, 0.0, 1.0])
    gap = 2.0 * r * 1e-4 + phase * v0 * dt * n[2]
    sim.add_particles([x0, x0 + (2.0 * r + gap) * n], [r, r], velocities=[[0, 0, 0], [0, 0, -v0]])
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
    fast_dt = scene.fast().dt
    if fast_dt != scene.dt:
        steps["fast()"] = fast_dt
    rows = []
    ref = {angle: collide(scene, 1e-6, angle, v0) for angle in (0.0, 45.0)}
    phases = np.arange(PHASES) / PHASES
    for label, dt in steps.items():
        for angle in (0.0, 45.0):
            runs = [collide(scene, dt, angle, v0, ph) for ph in phases]
            e_err = np.array([c["e_n"] / ref[angle]["e_n"] - 1.0 for c in runs])
            # head-on: no spin to compare
            s_err = np.array([c["spin"] / ref[angle]["spin"] - 1.0 if angle else 0.0 for c in runs])
            rows.append(
                {
                    "preset": a.preset,
                    "dt_label": label,
                    "dt": dt,
                    "angle_deg": angle,
                    "landing_speed": v0,
                    "steps_in_contact": runs[0]["steps_in_contact"],
                    "e_n": float(np.mean([c["e_n"] for c in runs])),
                    "spin": float(np.mean([c["spin"] for c in runs])),
                    "e_n_error": float(e_err.mean()),
                    "e_n_error_max": float(e_err[np.argmax(np.abs(e_err))]),
                    "spin_error": float(s_err.mean()),
                    "spin_error_max": float(s_err[np.argmax(np.abs(s_err))]),
                }
            )
    df = pl.DataFrame(rows)
    a.out.mkdir(parents=True, exist_ok=True)
    atomic_write(a.out / f"collision_dt_{a.preset}.csv", df.write_csv().encode())
    write_manifest(
        a.out,
        extra={"phases_of_first_touch": PHASES},
        name=f"manifest_{a.preset}.json",
    )
    with pl.Config(tbl_rows=-1, tbl_cols=-1, float_precision=4):
        print(f"landing speed {v0:.3f} m/s, Rayleigh step {rayleigh:.3g} s")
        print(df.drop("preset", "landing_speed"))


if __name__ == "__main__":
    main()
