"""A pack to LIGGGHTS and back: export, a short LIGGGHTS run, the dump read back.

    python examples/liggghts_round_trip.py [OUTPUT_FOLDER]

Makes a small 3D pack, exports it for LIGGGHTS (pack.data and in.granpack, the input
that continues the run with granpack's contact law, material, walls and gravity), runs
LIGGGHTS on it, and reads its dumps back with gp.read_particles: at step 0 the positions
are granpack's to the last bit; after 200 steps (0.02 s) of LIGGGHTS' own dynamics the
settled spheres have moved by a few percent of a radius at most. Needs the `liggghts`
executable on PATH (Debian and Ubuntu: apt-get install liggghts); without it the script
says so and stops after the export. Files go to OUTPUT_FOLDER (default: a new temporary
folder). A few seconds on two cores.
"""

import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

import granpack as gp
from granpack.io import export

out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(tempfile.mkdtemp(prefix="granpack-"))
out.mkdir(parents=True, exist_ok=True)

scene = gp.PackScene.preset("4.4").replace(base=(0.3, 0.3), height=0.2, seed=1)
pack = gp.generate(scene)

# pack.data (atom_style sphere) and in.granpack beside it
written = export(pack, out / "pack.data", "liggghts")
print("exported", ", ".join(p.name for p in written))

liggghts = shutil.which("liggghts")
if liggghts is None:
    print("liggghts is not on PATH: the LIGGGHTS run is skipped")
    sys.exit(0)

# The export's input with 0 steps, a dump of the state as read, 200 steps, another dump.
# LIGGGHTS 3.8 takes one format string for the whole line; %.17g keeps every bit.
dump = 'write_dump all custom {} id type x y z radius modify format "%d %d{}"'
fmt = " %.17g" * 4
(out / "in.round_trip").write_text(
    "include in.granpack\n"
    + dump.format("start.dump", fmt)
    + "\nrun 200\n"
    + dump.format("end.dump", fmt)
    + "\n"
)
done = subprocess.run(
    [liggghts, "-in", "in.round_trip", "-log", "log.liggghts"],
    cwd=out,
    capture_output=True,
    text=True,
)
if done.returncode != 0:
    sys.exit(f"LIGGGHTS failed (see {out / 'log.liggghts'}):\n{done.stdout[-2000:]}")

# read_particles recognises a LAMMPS/LIGGGHTS dump by its content; particles come sorted by id,
# which are the export's 1..N in granpack's order.
start = gp.read_particles(out / "start.dump")
end = gp.read_particles(out / "end.dump")
same = np.array_equal(start.positions, pack.positions) and np.array_equal(start.radii, pack.radii)
print(f"step 0: {len(start)} spheres, positions and radii identical: {same}")
moved = np.linalg.norm(end.positions - pack.positions, axis=1)
print(
    f"after 200 steps: largest displacement {moved.max():.2e} m "
    f"({moved.max() / pack.radii.mean():.2%} of the mean radius)"
)
if not same:
    sys.exit("the positions read back differ from the pack's")
