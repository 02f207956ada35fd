"""The LAMMPS engine's wall time at 1e7 and 1e8 spheres on 64 and 256 cores, estimated
from this folder's measurements (``runs.csv``, ``placement.json``) and LAMMPS' published
parallel efficiency of its granular chute benchmark. Writes ``scale_estimate.md``.

The model, for N spheres in L layers of S steps each (the RVE's geometry: 12 layers of
10 000 steps, settle_time 1 s at dt 1e-4 s):

- particle-steps PS = S * N * (L + 1) / 2 (layer k jams k N / L spheres);
- the step: PS * c / (P * e), with c the CPU ns a particle-step of one LAMMPS rank
  (measured here: the cheapest and the dearest LAMMPS run with 3 layers or more, its
  CPU seconds over all ranks) and e the parallel efficiency;
- the placement: N * u on rank 0 alone while the others wait, u the placement's
  microseconds a sphere on one thread (measured here at the largest layer);
- the gather at the end: N * (88 + 48 z / 2) bytes into rank 0 (id, x, v, r, omega: 11
  doubles a sphere; two ids and 4 doubles a contact, z / 2 contacts a sphere).

    python studies/lammps_engine_speed/scale_estimate.py
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

HERE = Path(__file__).resolve().parent

LAYERS = 12
STEPS = 10_000
Z = 5.2  # the million-sphere RVE's Z (studies/periodic_rve_1e6/)
#: parallel efficiency: LAMMPS' chute benchmark (bench/log.15Jul25.chute.fixed.g++.1
#: and .4: 32 000 atoms, 0.155391 s on 1 process, 0.0451259 s on 4: 3.44x), and the
#: floor the LAMMPS manual gives ("above 50% so long as the number of atoms/core is a few
#: 100 or greater", Speed_bench)
EFFICIENCIES = {"0.86 (chute, 8 000 atoms a rank)": 0.86, "0.5 (the manual's floor)": 0.5}
SIZES = (10_000_000, 100_000_000)
CORES = (64, 256)


def hms(s: float) -> str:
    h, rem = divmod(round(s), 3600)
    m, sec = divmod(rem, 60)
    return f"{h} h {m:02d} min" if h else f"{m} min {sec:02d} s"


def main() -> None:
    with (HERE / "runs.csv").open(newline="") as fh:
        runs = list(csv.DictReader(fh))
    # the CPU ns a particle-step of the LAMMPS runs with a settled bed beneath (3 layers
    # or more; on 2 ranks the CPU of both, which counts their communication too): the
    # cost differs by case, so the cheapest and the dearest bound the estimate
    one = [r for r in runs if r["config"].startswith("lammps") and int(r["layers"]) >= 3]
    lo = min(one, key=lambda r: float(r["cpu_ns_per_particle_step"]))
    hi = max(one, key=lambda r: float(r["cpu_ns_per_particle_step"]))
    c_lo, c_hi = (float(r["cpu_ns_per_particle_step"]) for r in (lo, hi))
    place = json.loads((HERE / "placement.json").read_text())
    largest = max(place, key=lambda r: r["layer0_spheres"])
    u_us = max(largest["layer0_us_per_sphere"], largest["layer1_us_per_sphere"])
    lines = [
        "# Scale estimate of the LAMMPS engine (from this folder's measurements)",
        "",
        f"- c = {c_lo:.1f} to {c_hi:.1f} CPU ns a particle-step a LAMMPS rank "
        f"({lo['case']}, {lo['config']}, {lo['particles']} spheres, {lo['layers']} layers; "
        f"{hi['case']}, {hi['config']}, {hi['particles']} spheres, {hi['layers']} layers)",
        f"- u = {u_us:.1f} us a sphere for the placement on rank 0, one thread "
        f"({largest['layer0_spheres']}-sphere layer, base {largest['base_side_m']} m)",
        f"- {LAYERS} layers of {STEPS} steps; PS = S N (L+1)/2; Z = {Z}",
        "",
        f"| spheres | cores | efficiency | particle-steps | step, c = {c_lo:.0f} ns "
        f"| step, c = {c_hi:.0f} ns | placement (rank 0) | gather into rank 0 "
        "| placement / step |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for n in SIZES:
        ps = STEPS * n * (LAYERS + 1) / 2
        t_place = n * u_us * 1e-6
        gather = n * (88 + 48 * Z / 2)
        for p in CORES:
            for label, e in EFFICIENCIES.items():
                t_lo = ps * c_lo * 1e-9 / (p * e)
                t_hi = ps * c_hi * 1e-9 / (p * e)
                lines.append(
                    f"| {n:.0e} | {p} | {label} | {ps:.2e} | {hms(t_lo)} | {hms(t_hi)} "
                    f"| {hms(t_place)} | {gather / 1e9:.1f} GB "
                    f"| {100 * t_place / t_hi:.0f}-{100 * t_place / t_lo:.0f}% |"
                )
    text = "\n".join(lines) + "\n"
    (HERE / "scale_estimate.md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
