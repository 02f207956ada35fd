"""Read and write a large pack in every format: seconds, MB/s and peak memory.

The pack is a periodic 4.3 pack (fast settings) tiled laterally to about `--n` spheres
(`gp.tile`: the contacts across the junctions are the seam's, so the contact tables are a
real pack's). Each write and each read runs in a fresh process, so that its peak resident
memory is its own; the baselines are numpy's ``savetxt``/``loadtxt`` of the same
``x y z r`` table at 17 significant digits (what granpack's text writers keep) and
``np.save``/``np.load`` of it.

    python studies/io_1e6/io_speed.py --n 1000000 --out studies/io_1e6

Writes ``results.md`` and ``results.json`` with a manifest (commit, CPU, date, command).
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "_common"))

from manifest import write_manifest  # noqa: E402

# (label, export format, the file written, the file read back, read format)
CASES = [
    ("LAMMPS data", "lammps", "p.data", "p.data", "lammps-data"),
    ("LAMMPS dump (written by numpy)", "dump", "p.dump", "p.dump", "lammps-dump"),
    ("extended XYZ", "xyz", "p.xyz", "p.xyz", "xyz"),
    ("YADE text", "yade", "p.txt", "p.txt", "yade"),
    ("CSV", "csv", "p.csv", "p.particles.csv", "csv"),
    ("Parquet", "parquet", "p.parquet", "p.particles.parquet", "parquet"),
    ("gsd", "gsd", "p.gsd", "p.gsd", "gsd"),
    ("Kratos mdpa", "kratos", "p.mdpa", "p.mdpa", "kratos"),
    ("MercuryDPM data", "mercurydpm", "p.mercury.data", None, None),
    ("PFC commands", "pfc", "p.p3dat", None, None),
    ("DEM-Engine CSV", "demengine", "p.demengine.csv", None, None),
    ("VTK", "vtk", "p.vtu", None, None),
    ("pack file (npz)", "npz", "p.npz", "p.npz", "npz"),
]

CHILD = r"""
import json, sys, time
from pathlib import Path
import numpy as np
import granpack as gp
from granpack.io import export, read_particles


def rss(key):
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith(key):
            return int(line.split()[1]) / 1024.0
    return float("nan")


kind, fmt, path, read_path, pack_path = sys.argv[1:6]
path = Path(path)
pack = gp.load_pack(pack_path) if kind in ("write", "np-write") else None
Path("/proc/self/clear_refs").write_text("5")  # the peak (VmHWM) starts again from here
before = rss("VmRSS:")
t = time.perf_counter()
if kind == "write":
    if fmt == "npz":
        files = [pack.save(path)]
    elif fmt == "dump":
        x = pack.positions
        ids = np.arange(1, len(pack) + 1)
        head = (f"ITEM: TIMESTEP\n0\nITEM: NUMBER OF ATOMS\n{len(pack)}\n"
                "ITEM: BOX BOUNDS pp pp fm\n" + "".join(
                    f"{float(lo)!r} {float(hi)!r}\n" for lo, hi in zip(*pack.box)) +
                "ITEM: ATOMS id x y z radius")
        np.savetxt(path, np.column_stack([ids, x, pack.radii]), fmt=["%d"] + ["%.17g"] * 4,
                   header=head, comments="")
        files = [path]
    else:
        files = export(pack, path, fmt)
elif kind == "read":
    files = [Path(read_path)]
    p = read_particles(read_path, format=fmt)
elif kind == "np-write":
    table = np.column_stack([pack.positions, pack.radii])
    if fmt == "savetxt":
        np.savetxt(path, table, fmt="%.17g")
    else:
        np.save(path, table)
    files = [path]
else:
    files = [path]
    a = np.loadtxt(path) if fmt == "savetxt" else np.load(path)
dt = time.perf_counter() - t
print(json.dumps({"seconds": dt, "bytes": sum(Path(f).stat().st_size for f in files),
                  "peak_mb": rss("VmHWM:") - before, "rss_before_mb": before}))
"""


def run(kind: str, fmt: str, path: Path, pack_path: Path, read_path: Path | None = None) -> dict:
    out = subprocess.run(
        [sys.executable, "-c", CHILD, kind, fmt, str(path), str(read_path or path), str(pack_path)],
        capture_output=True,
        text=True,
    )
    if out.returncode != 0:
        return {"error": out.stderr.strip().splitlines()[-1] if out.stderr else "failed"}
    return json.loads(out.stdout.strip().splitlines()[-1])


def make_pack(n: int, work: Path) -> Path:
    import granpack as gp

    path = work / f"pack_{n}.npz"
    if path.exists():
        return path
    scene = gp.PackScene.preset("4.3").replace(container="periodic", seed=1).fast()
    small = gp.generate(scene)
    k = max(1, math.ceil(math.sqrt(n / len(small))))
    big = gp.tile(small, (k, k))
    big.save(path)
    print(f"pack: {len(small)} spheres tiled {k} x {k} = {len(big)}", flush=True)
    return path


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=1_000_000)
    ap.add_argument("--out", type=Path, default=HERE)
    ap.add_argument("--work", type=Path, default=Path("/tmp/granpack_io_speed"))
    args = ap.parse_args()
    args.work.mkdir(parents=True, exist_ok=True)
    pack_path = make_pack(args.n, args.work)
    rows = []
    for label, fmt, name in [
        ("numpy savetxt/loadtxt (x y z r, %.17g)", "savetxt", "np.txt"),
        ("numpy save/load (x y z r)", "npy", "np.npy"),
    ]:
        w = run("np-write", fmt, args.work / name, pack_path)
        r = run("np-read", fmt, args.work / name, pack_path)
        rows.append({"format": label, "write": w, "read": r})
        print(rows[-1], flush=True)
    for label, fmt, name, read_name, read_fmt in CASES:
        target = args.work / name
        w = run("write", fmt, target, pack_path)
        r = None
        if read_fmt and "error" not in w:
            r = run("read", read_fmt, target, pack_path, args.work / read_name)
        rows.append({"format": label, "write": w, "read": r})
        print(rows[-1], flush=True)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "results.json").write_text(json.dumps(rows, indent=2))
    lines = [
        f"# Read and write {args.n:.0e} spheres in every format",
        "",
        "Seconds, MB/s (the size of every file written or read, over the time) and the peak",
        "resident memory above the process's before the call (MB; a write holds the pack,",
        "a read holds nothing before), each in a fresh process. `studies/io_1e6/io_speed.py`;",
        "manifest beside. The baselines are numpy on the x y z r table alone.",
        "",
        "| format | write s | write MB/s | write peak MB | read s | read MB/s | read peak MB |",
        "|---|---|---|---|---|---|---|",
    ]

    def cells(d: dict | None) -> str:
        if d is None:
            return "— | — | —"
        if "error" in d:
            return f"failed: {d['error'][:60]} | | "
        mbs = d["bytes"] / 1e6 / d["seconds"]
        return f"{d['seconds']:.2f} | {mbs:.0f} | {d['peak_mb']:.0f}"

    for row in rows:
        lines.append(f"| {row['format']} | {cells(row['write'])} | {cells(row['read'])} |")
    (args.out / "results.md").write_text("\n".join(lines) + "\n")
    write_manifest(args.out, extra={"n": args.n, "started": time.strftime("%Y-%m-%d")})
    print("\n".join(lines))


if __name__ == "__main__":
    main()
