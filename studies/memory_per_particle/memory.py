"""Where a pack's memory goes, per particle: the layer loop, the pack, the analysis and an
export, for periodic 4.3 cells of growing width.

Each cell runs in a fresh process, so that its peak resident set (``VmHWM``) is its own;
the peak is reset (``/proc/self/clear_refs``) before each stage, so each stage's peak is
counted from the resident set it started with. Beside the process's figures, the engine's
own state by group at the last layer (`_core.LayerPacker.memory`: particles, the walls'
contact state, the pair list with its per-pair state, the incidence lists, the layer
record) and the arrays of the finished pack (`numpy.ndarray.nbytes`).

    python studies/memory_per_particle/memory.py --bases 1.0 1.5 3.0 --fast \\
        --out studies/memory_per_particle

Writes ``results.json`` and ``results.md`` with a manifest (commit, CPU, date, command).
Linux only (``/proc``).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "_common"))

from manifest import write_manifest  # noqa: E402

_STATUS = Path("/proc/self/status")


def _kib(key: str) -> int:
    for line in _STATUS.read_text().splitlines():
        if line.startswith(key):
            return int(line.split()[1]) * 1024
    raise RuntimeError(f"no {key} in /proc/self/status")


def _reset_peak() -> int:
    """Resets the peak resident set to the current one and returns it (bytes)."""
    Path("/proc/self/clear_refs").write_text("5")
    return _kib("VmRSS:")


def measure(base: float, fast: bool, seed: int, tmp: Path) -> dict:
    """One cell, in this process: the figures of `main`'s table."""
    import granpack as gp
    from granpack.io.registry import export

    scene = gp.PackScene.preset("4.3").replace(container="periodic", base=(base, base), seed=seed)
    if fast:
        scene = scene.fast()
    out: dict = {"base_m": base, "fast": fast, "seed": seed, "import_rss": _kib("VmRSS:")}
    layers: list[dict] = []

    def on_layer(rep: dict) -> None:
        layers.append(
            {
                "layer": rep["layer"],
                "total": rep["total"],
                "steps": rep["steps"],
                "wall_seconds": rep["wall_seconds"],
                "rss": _kib("VmRSS:"),
                "engine": rep["memory"],
            }
        )

    start = _reset_peak()
    t = time.perf_counter()
    pack = gp.generate(scene, progress=on_layer)
    out["generate_s"] = time.perf_counter() - t
    out["generate_peak"] = _kib("VmHWM:") - start
    out["after_generate"] = _kib("VmRSS:") - start
    n = len(pack)
    out["n"] = n
    out["engine_last_layer"] = layers[-1]["engine"]
    c = pack.contacts
    out["contacts"] = len(c.i)
    arrays = [pack.positions, pack.radii, pack.velocities, pack.spins, pack.layer]
    out["pack_arrays"] = int(sum(a.nbytes for a in arrays))
    out["contact_arrays"] = int(sum(v.nbytes for v in vars(c).values() if hasattr(v, "nbytes")))
    # BLAS allocates a work buffer at its first product (memray counts 33.5 MB; the
    # resident part is what this measures): the same at any N, so it is taken before the
    # analysis's peak is counted
    import numpy as np

    start = _reset_peak()
    np.ones((4, 4)) @ np.ones((4, 4))
    out["blas_buffer"] = _kib("VmHWM:") - start
    start = _reset_peak()
    t = time.perf_counter()
    m = gp.microstructure(pack)
    out["analysis_s"] = time.perf_counter() - t
    out["analysis_peak"] = _kib("VmHWM:") - start
    start = _reset_peak()
    t = time.perf_counter()
    export(pack, tmp / "pack.data", format="lammps")
    out["export_s"] = time.perf_counter() - t
    out["export_peak"] = _kib("VmHWM:") - start
    out["phi_core"] = float(m.phi_core)
    out["Z"] = float(m.z)
    out["layers"] = layers
    return out


def _per(d: dict, key: str) -> float:
    return d[key] / d["n"]


def _table(rows: list[dict]) -> str:
    head = (
        "| base (m) | N | contacts | generate (s) | generate peak | after generate | "
        "engine: particles | wall contacts | pair list | incidence | pack arrays | "
        "contact arrays | analysis peak | export peak |\n"
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n"
    )
    lines = []
    for d in rows:
        e = d["engine_last_layer"]
        per_e = {k: e[k] / d["n"] for k in ("particles", "wall_contacts", "pair_list", "incidence")}
        lines.append(
            f"| {d['base_m']:g} | {d['n']} | {d['contacts']} | {d['generate_s']:.1f} | "
            f"{_per(d, 'generate_peak'):.0f} | {_per(d, 'after_generate'):.0f} | "
            f"{per_e['particles']:.0f} | {per_e['wall_contacts']:.0f} | "
            f"{per_e['pair_list']:.0f} | {per_e['incidence']:.0f} | "
            f"{_per(d, 'pack_arrays'):.0f} | {_per(d, 'contact_arrays'):.0f} | "
            f"{_per(d, 'analysis_peak'):.0f} | {_per(d, 'export_peak'):.0f} |"
        )
    return head + "\n".join(lines) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--bases", type=float, nargs="+", default=[1.0, 1.5, 3.0])
    ap.add_argument("--fast", action="store_true", help="the fast settings (PackScene.fast)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--out", type=Path, default=HERE)
    ap.add_argument("--one", type=float, help=argparse.SUPPRESS)  # a child process's cell
    ap.add_argument("--tmp", type=Path, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.one is not None:
        print(json.dumps(measure(args.one, args.fast, args.seed, args.tmp)))
        return
    rows = []
    args.out.mkdir(parents=True, exist_ok=True)
    tmp = args.out / "scratch"
    tmp.mkdir(exist_ok=True)
    for base in args.bases:
        cmd = [sys.executable, __file__, "--one", str(base), "--seed", str(args.seed)]
        cmd += ["--tmp", str(tmp)] + (["--fast"] if args.fast else [])
        done = subprocess.run(cmd, capture_output=True, text=True, check=True)
        rows.append(json.loads(done.stdout.strip().splitlines()[-1]))
        print(f"base {base:g} m: N = {rows[-1]['n']}", file=sys.stderr)
    for f in tmp.iterdir():
        f.unlink()
    tmp.rmdir()
    (args.out / "results.json").write_text(json.dumps(rows, indent=1) + "\n")
    text = (
        "# Memory per particle: periodic 4.3 cells\n\n"
        f"Settings: {'fast()' if args.fast else 'the paper'}; seed {args.seed}. Bytes per "
        "particle. The peaks are the process's resident set above the one each stage "
        "started with; the engine's groups are its state at the last layer; the arrays are "
        "the finished pack's. The analysis peak leaves out BLAS's work buffer, allocated "
        "once at any N ("
        + ", ".join(f"{r['blas_buffer'] / 1e6:.1f}" for r in rows)
        + " MB).\n\n"
        + _table(rows)
    )
    (args.out / "results.md").write_text(text)
    write_manifest(args.out, seeds=[args.seed])
    print(text)


if __name__ == "__main__":
    main()
