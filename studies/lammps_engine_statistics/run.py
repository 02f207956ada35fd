"""Packs made on granpack's engine and on LAMMPS (1 and 2 MPI ranks) from the same scenes
and seeds: do the three engines give the same pack statistics?

The reduced 4.3 (0.4 m x 0.4 m, 0.35 m high, about 1 000 spheres) and the reduced 4.1
(0.5 m wide, 0.35 m high, about 800 discs), seeds 0..9, each on three engines: granpack's
(two threads), LAMMPS on one MPI rank and LAMMPS on two. For each pack: N, layers, phi,
phi_core, Z, |a_r|, |a_n| (granpack's `microstructure`) and the wall seconds of
`generate`. The engines differ in their arithmetic, so the packs differ bit for bit;
the question is whether their means agree within the spread of one engine's packs.

    python studies/lammps_engine_statistics/run.py [--out DIR] [--seeds 10]

Writes ``packs.csv`` (one row a pack, written as it goes), ``table.md`` and
``summary.json`` (mean, sd and the agreement checks) and ``manifest.json``.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numpy as np  # noqa: E402

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "_common"))
from manifest import write_manifest  # noqa: E402

import granpack as gp  # noqa: E402
from granpack.mpi.engine import LammpsRunError  # noqa: E402

SCENES = {
    "4.3 reduced": lambda: gp.PackScene.preset("4.3").replace(base=(0.4, 0.4), height=0.35),
    "4.1 reduced": lambda: gp.PackScene.preset("4.1").replace(base=(0.5,), height=0.35),
}
ENGINES = {
    # RAYON_NUM_THREADS unset: the native pool takes every core (2 here); the LAMMPS job
    # sets one thread a rank itself, which an inherited RAYON_NUM_THREADS would override
    "granpack (2 threads)": {"engine": "granpack"},
    "lammps 1 rank": {"engine": "lammps", "ranks": 1},
    "lammps 2 ranks": {"engine": "lammps", "ranks": 2},
}
FIELDS = ["n", "layers", "phi", "phi_core", "z", "a_r_mag", "a_n_mag", "wall_s"]


def uptime() -> str:
    return subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()


def one_pack(scene, kwargs) -> dict:
    # an MPI job killed from outside (exit status 9: other work on a shared machine) is
    # run again, and the retry counted; LAMMPS' own errors are not retried
    retries = 0
    while True:
        t = time.perf_counter()
        try:
            pack = gp.generate(scene, **kwargs)
        except LammpsRunError as exc:
            if "exit status 9" not in str(exc) or retries >= 2:
                raise
            retries += 1
            print("retry:", str(exc).splitlines()[0], flush=True)
            continue
        wall = time.perf_counter() - t
        break
    d = gp.microstructure(pack).to_dict()
    return {
        "n": len(pack.radii),
        "layers": pack.n_layers,
        "phi": d["phi"],
        "phi_core": d["phi_core"],
        "z": d["z"],
        "a_r_mag": d["a_r_mag"],
        "a_n_mag": d.get("a_n_mag", float("nan")),
        "wall_s": wall,
        "engine_record": json.dumps(pack.engine),
        "retries": retries,
    }


def summarise(rows: list[dict]) -> dict:
    out: dict = {}
    for scene in SCENES:
        out[scene] = {}
        for engine in ENGINES:
            sel = [r for r in rows if r["scene"] == scene and r["engine"] == engine]
            if len(sel) < 2:
                continue
            out[scene][engine] = {
                f: {
                    "mean": float(np.mean([float(r[f]) for r in sel])),
                    "sd": float(np.std([float(r[f]) for r in sel], ddof=1)),
                    "count": len(sel),
                }
                for f in FIELDS
            }
        # a mean agrees with another when the two lie within one sd (the larger of the
        # two engines' sds) of each other
        pairs = [
            ("lammps 1 rank", "granpack (2 threads)"),
            ("lammps 2 ranks", "granpack (2 threads)"),
            ("lammps 1 rank", "lammps 2 ranks"),
        ]
        agree = {}
        for a, b in pairs:
            if a not in out[scene] or b not in out[scene]:
                continue
            agree[f"{a} vs {b}"] = {}
            for f in FIELDS[2:7]:
                sa, sb = out[scene][a][f], out[scene][b][f]
                diff = abs(sa["mean"] - sb["mean"])
                sd = max(sa["sd"], sb["sd"])
                agree[f"{a} vs {b}"][f] = {
                    "diff": diff,
                    "sd": sd,
                    "diff_over_sd": diff / sd if sd > 0 else float("inf"),
                    "within_one_sd": bool(diff <= sd),
                }
        out[scene]["agreement"] = agree
    return out


def table(summary: dict) -> str:
    lines = []
    for scene, per in summary.items():
        lines.append(f"### {scene}\n")
        lines.append(
            "| engine | packs | N | layers | phi | phi_core | Z | abs(a_r) | abs(a_n) | wall s |"
        )
        lines.append("|---|---|---|---|---|---|---|---|---|---|")
        for engine in ENGINES:
            if engine not in per:
                continue
            s = per[engine]
            cells = [
                str(s["n"]["count"]),
                f"{s['n']['mean']:.1f} ± {s['n']['sd']:.1f}",
                f"{s['layers']['mean']:.1f} ± {s['layers']['sd']:.1f}",
                *(
                    f"{s[f]['mean']:.4f} ± {s[f]['sd']:.4f}"
                    for f in ("phi", "phi_core", "z", "a_r_mag", "a_n_mag")
                ),
                f"{s['wall_s']['mean']:.2f} ± {s['wall_s']['sd']:.2f}",
            ]
            lines.append(f"| {engine} | " + " | ".join(cells) + " |")
        lines.append("")
        lines.append("| pair | phi | phi_core | Z | abs(a_r) | abs(a_n) |")
        lines.append("|---|---|---|---|---|---|")
        for pair, per_f in per["agreement"].items():
            cells = [
                f"{'yes' if v['within_one_sd'] else 'NO'} ({v['diff_over_sd']:.2f} sd)"
                for v in per_f.values()
            ]
            lines.append(f"| {pair} | " + " | ".join(cells) + " |")
        lines.append("")
    lines.append(
        "Mean ± sd over the seeds; a pair agrees ('yes') where its means differ by no more "
        "than the larger of the two sds (the difference in units of that sd in brackets)."
    )
    return "\n".join(lines) + "\n"


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", default=str(HERE))
    p.add_argument("--seeds", type=int, default=10)
    p.add_argument("--fresh", action="store_true", help="start over, not from packs.csv")
    p.add_argument("--summary-only", action="store_true", help="the table from packs.csv, no packs")
    args = p.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    warnings.simplefilter("ignore")
    loads = {"before": uptime()}
    path = out / "packs.csv"
    cols = ["scene", "seed", "engine", *FIELDS, "engine_record", "retries", "uptime_after"]
    # a run cut off goes on where it stopped: the packs already in packs.csv are kept
    rows: list[dict] = []
    if path.exists() and not args.fresh:
        with path.open(newline="") as fh:
            rows = list(csv.DictReader(fh))
    done = {(r["scene"], int(r["seed"]), r["engine"]) for r in rows}
    with path.open("a" if rows else "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=cols)
        if not rows:
            w.writeheader()
        # seeds outermost: a run stopped early still has as many seeds of each scene
        for seed in range(0 if args.summary_only else args.seeds):
            for scene_name, make in SCENES.items():
                scene = make().replace(seed=seed)
                # the engines in turn on each seed, so load on the machine falls on all
                for engine, kwargs in ENGINES.items():
                    if (scene_name, seed, engine) in done:
                        continue
                    row = {"scene": scene_name, "seed": seed, "engine": engine}
                    row.update(one_pack(scene, kwargs))
                    row["uptime_after"] = uptime()
                    rows.append(row)
                    w.writerow(row)
                    fh.flush()
                    print(
                        scene_name,
                        seed,
                        engine,
                        f"{row['wall_s']:.2f}s",
                        row["n"],
                        f"phi={row['phi']:.4f}",
                        flush=True,
                    )
    loads["after"] = uptime()
    summary = summarise(rows)
    (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    (out / "table.md").write_text(table(summary))
    write_manifest(
        out,
        seeds=list(range(args.seeds)),
        extra={
            "native_threads": os.environ.get("RAYON_NUM_THREADS", os.cpu_count()),
            "lammps_job_threads": "RAYON_NUM_THREADS=1 a rank",
            "uptime": loads,
        },
    )
    print(table(summary))


if __name__ == "__main__":
    main()
