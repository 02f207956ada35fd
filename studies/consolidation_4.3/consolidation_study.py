"""Example 4.3 consolidated oedometrically to 100 kPa: what the stage's settings do.

On one deposit (preset 4.3, seed 1, ``fast()``), in the box:
- the loading rate: the lid's speed cap ``max_wall_speed`` (m/s);
- the local damping of the stage;
- the servo gain;
and, for the defaults, the convergence history (stress error and unbalanced ratio
against the step) as a figure. Writes ``runs.csv``, ``summary.md``, the figure
``convergence.png`` and the manifest.

    python studies/consolidation_4.3/consolidation_study.py [--pack PACK.npz] \\
        [--out studies/consolidation_4.3]
"""

from __future__ import annotations

import argparse
import csv
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "_common"))
from manifest import write_manifest  # noqa: E402

import granpack as gp  # noqa: E402

SWEEPS = {
    "defaults": {},
    "max_wall_speed": [{"max_wall_speed": v} for v in (0.05, 0.25, 0.5, 1.0)],
    "local_damping": [{"local_damping": v} for v in (0.0, 0.2, 0.7)],
    "gain": [{"gain": v} for v in (0.2, 1.0)],
}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--pack", type=Path, default=None, help="a saved 4.3 deposit")
    ap.add_argument("--out", type=Path, default=Path(__file__).resolve().parent)
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    if args.pack is not None:
        deposit = gp.load_pack(args.pack)
    else:
        deposit = gp.generate(gp.PackScene.preset("4.3").replace(seed=1).fast())
    runs = [("defaults", {})]
    for name in ("max_wall_speed", "local_damping", "gain"):
        runs += [(name, kw) for kw in SWEEPS[name]]
    rows = []
    history = None
    for sweep, kw in runs:
        t0 = time.perf_counter()
        pack = gp.consolidate(deposit, 1e5, **kw)
        rec = pack.record("consolidate").table()
        m = gp.microstructure(pack)
        row = {
            "sweep": sweep,
            "max_wall_speed": rec["max_wall_speed"],
            "local_damping": rec["local_damping"],
            "gain": rec["gain"],
            "dt": rec["dt"],
            "steps": rec["steps"],
            "seconds": round(rec["seconds"], 2),
            "phi": round(rec["phi"], 5),
            "e": round(rec["void_ratio"], 5),
            "K0": round(rec["k0"], 4),
            "Z": round(m.z, 4),
            "Z_m": round(m.z_mech, 4),
            "floor_kPa": round(rec["wall_stress"]["floor"] / 1e3, 2),
            "love_weber_zz_kPa": round(rec["love_weber"][-1][-1] / 1e3, 2),
            "unbalanced": f"{rec['unbalanced']:.2e}",
            "max_ratio": f"{rec['max_ratio']:.2e}",
            "wall_s": round(time.perf_counter() - t0, 2),
        }
        print(row, flush=True)
        rows.append(row)
        if sweep == "defaults":
            history = rec["history"]
    with (args.out / "runs.csv").open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    keys = list(rows[0])
    md = ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    md += ["| " + " | ".join(str(r[k]) for k in keys) + " |" for r in rows]
    (args.out / "summary.md").write_text("\n".join(md) + "\n")
    if history is not None:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(6.4, 4.0))
        ax.semilogy(history["step"], history["stress_error"], label="|sigma - sigma*| / sigma*")
        ax.semilogy(history["step"], history["unbalanced"], label="unbalanced ratio")
        ax.axhline(1e-3, color="C0", ls=":", lw=1)
        ax.axhline(1e-4, color="C1", ls=":", lw=1)
        ax.set_xlabel("step")
        ax.set_ylabel("(-)")
        ax.set_title("4.3 in the box, oedometric to 100 kPa (defaults)")
        ax.legend()
        fig.tight_layout()
        fig.savefig(args.out / "convergence.png", dpi=110)
    write_manifest(
        args.out,
        seeds=[1],
        extra={"deposit": str(args.pack) if args.pack else "preset 4.3, seed 1, fast()"},
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
