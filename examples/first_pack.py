"""A first pack: a small 3D pack of the paper's example 4.4 (Gaussian radii), its
packing fraction and coordination number, saved to a file.

    python examples/first_pack.py [OUTPUT_FOLDER]

Writes first_pack.npz into OUTPUT_FOLDER (default: a new temporary folder). A few seconds
on two cores.
"""

import sys
import tempfile
from pathlib import Path

import granpack as gp

out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(tempfile.mkdtemp(prefix="granpack-"))
out.mkdir(parents=True, exist_ok=True)

# The paper's preset 4.4 on a 0.3 m square base, 0.2 m high (the paper's is 1 m, 0.5 m),
# so that it packs in seconds. Every other setting (radii, material, dt) is the preset's.
scene = gp.PackScene.preset("4.4").replace(base=(0.3, 0.3), height=0.2, seed=1)
pack = gp.generate(scene)  # the same scene and seed give the same pack, bit for bit

# The microstructure: phi over the whole height (the top's loose layer included), phi_core
# inside a window 0.02 m in from the walls, the floor and the top, Z = 2 contacts / spheres.
m = gp.microstructure(pack, core_margin=0.02)
print(f"{len(pack)} spheres")
print(f"phi = {m.phi:.4f}   phi_core = {m.phi_core:.4f}   Z = {m.z:.3f}")

path = pack.save(out / "first_pack.npz")  # read it back with gp.load_pack(path)
print(f"saved {path}")
