"""Two-sphere impacts whose outcome the pair state carries: a head-on restitution at
the paper's time step (8 phases of the first touch within a step), an oblique impact
that slides throughout (mu = 0.3, v_t / v_n = 3) and one that sticks for most of the
contact (v_t / v_n = 0.2), both at dt = 1e-6 s. Prints one JSON object: the outcomes
to 17 digits, so that two builds of granpack (double and single precision pair state)
can be compared number by number. Run with the granpack to measure on the path:
    python impacts.py > impacts_<build>.json
"""

from __future__ import annotations

import json

import numpy as np

import granpack as gp

R, RHO = 0.02, 1000.0


def collide(mat: gp.Material, dt: float, vn: float, vt: float, gap: float) -> gp.Simulation:
    """Sphere 1 approaches sphere 0 along -x at vn, sliding along +y at vt; steps until
    the contact opens."""
    sim = gp.Simulation(dim=3, material=mat, dt=dt, gravity=[0.0, 0.0, 0.0])
    x = np.zeros((2, 3))
    x[1, 0] = 2 * R + gap
    v = np.zeros((2, 3))
    v[1] = (-vn, vt, 0.0)
    sim.add_particles(x, [R, R], velocities=v)
    touched = False
    for _ in range(2_000_000):
        sim.step(1)
        d = 2 * R - np.linalg.norm(sim.positions[1] - sim.positions[0])
        touched |= d > 0
        if touched and d <= 0:
            return sim
    raise AssertionError("the contact did not open")


def main() -> None:
    out: dict[str, list[float]] = {}
    # head-on, the paper's material (damping 0.1) and dt, a 4.3 sphere landing at 0.63 m/s
    mat = gp.Material(friction=0.0)
    v0, dt = 0.63, 1e-4
    out["head_on_e"] = []
    for k in range(8):
        s = collide(mat, dt, v0, 0.0, 1e-12 + k / 8 * v0 * dt)
        out["head_on_e"].append(float((s.velocities[1, 0] - s.velocities[0, 0]) / v0))
    for name, vt, damping in (("sliding", 1.5, 0.0), ("sticking", 0.1, 0.1)):
        mat = gp.Material(friction=0.3, damping=damping)
        s = collide(mat, 1e-6, 0.5, vt, 1e-9)
        v, w = s.velocities, s.spins
        # in the frame of the contact as it opens: the normal has turned as the
        # spheres slid past each other
        n = s.positions[1] - s.positions[0]
        n /= np.linalg.norm(n)
        dv = v[1] - v[0]
        vc = dv - np.cross(R * (w[0] + w[1]), n)
        vct = vc - (vc @ n) * n
        out[f"{name}_normal_restitution"] = [float(dv @ n / 0.5)]
        out[f"{name}_tangential_ratio"] = [float(np.linalg.norm(vct) / vt)]
        out[f"{name}_spin_z"] = [float(w[0, 2]), float(w[1, 2])]
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
