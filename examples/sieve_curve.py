"""A pack graded by a sieve curve, and the grading it actually has.

    python examples/sieve_curve.py [OUTPUT_FOLDER]

The scene gives the fraction by mass passing each sieve (docs/grading.md); the radii are
drawn from that curve. The script prints the characteristic diameters D10, D30, D50,
D60, Cu and Cc of the target curve beside the pack's, and the fraction passing each
sieve, then saves the pack as sieve_pack.npz in OUTPUT_FOLDER (default: a new temporary
folder). A few seconds on two cores.
"""

import sys
import tempfile
from pathlib import Path

import granpack as gp
from granpack.grading import passing

out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(tempfile.mkdtemp(prefix="granpack-"))
out.mkdir(parents=True, exist_ok=True)

# Sieve openings (diameters, m) and the fraction of the mass passing each: nothing below
# 20 mm, 30 % below 30 mm, 70 % below 50 mm, everything below 80 mm.
sieves = (0.02, 0.03, 0.05, 0.08)
scene = gp.PackScene.preset("4.3").replace(
    base=(0.3, 0.3),
    height=0.2,
    radius_law="sieve",
    sieve_sizes=sieves,
    sieve_passing=(0.0, 0.3, 0.7, 1.0),
    seed=3,
)
pack = gp.generate(scene)

# The target grading (the scene's curve) beside the realised one (the pack's radii), by mass.
target, real = gp.target_grading(scene), gp.realised_grading(pack)
print(f"{len(pack)} spheres")
print(f"{'':8}{'target':>8}{'pack':>8}")
for name in ("d10_mass", "d30_mass", "d50_mass", "d60_mass"):
    label = f"{name[:3].upper()} mm"
    print(f"{label:8}{1e3 * getattr(target, name):8.1f}{1e3 * getattr(real, name):8.1f}")
print(f"{'Cu':8}{target.cu_mass:8.2f}{real.cu_mass:8.2f}")
print(f"{'Cc':8}{target.cc_mass:8.2f}{real.cc_mass:8.2f}")

# The realised curve at the sieves themselves: the fraction of the pack's mass passing each.
for d, p in zip(sieves, passing(pack, sieves), strict=True):
    print(f"passing {1e3 * d:4.0f} mm: {100 * p:5.1f} %")

path = pack.save(out / "sieve_pack.npz")
print(f"saved {path}")
