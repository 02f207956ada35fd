"""The density window of example 4.3 against the rolling friction mu_r.

Example 4.3 (``fast()``, in the box) deposited at mu = 0.5 with rolling resistance
(``rolling = "epsd"``, its derived spring 2.25 mu_r^2 k_n, no rolling dashpot), for
mu_r in 0, 0.05, 0.1, 0.2, 0.4, 0.8 and two seeds; each deposit then consolidated
oedometrically to 100 kPa with the stage's defaults. Records phi (between floor and
top, or lid), the core window's phi, e, Z and the time of each. Writes ``runs.csv``,
``summary.md``, ``phi_vs_mu_r.png`` and the manifest.

With ``--sieve``, instead: ``gp.void_ratio_limits`` of the sieve-curve scene of
``examples/sieve_curve.py`` (``fast()``, one stream) under mu = 0.5 and mu_r = 0.4,
whose window takes every rolling friction of its grid (0, 0.1, 0.2, 0.4):
each pack's e, by deposition friction and rolling friction. Writes ``sieve.csv`` and
``sieve.md``.

    python studies/rolling_window_4.3/rolling_window.py [--sieve] [--out studies/rolling_window_4.3]
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "_common"))
from manifest import write_manifest  # noqa: E402

import granpack as gp  # noqa: E402

MU = 0.5
MU_R = (0.0, 0.05, 0.1, 0.2, 0.4, 0.8)
SEEDS = (1, 2)


def material(mu_r: float) -> gp.Material:
    base = gp.PackScene.preset("4.3").material
    if mu_r == 0.0:
        return dataclasses.replace(base, friction=MU)
    return dataclasses.replace(base, friction=MU, rolling="epsd", rolling_friction=mu_r)


def one(mu_r: float, seed: int) -> dict:
    scene = gp.PackScene.preset("4.3").replace(seed=seed, material=material(mu_r)).fast()
    t0 = time.perf_counter()
    deposit = gp.generate(scene)
    t_dep = time.perf_counter() - t0
    md = gp.microstructure(deposit)
    t0 = time.perf_counter()
    sample = gp.consolidate(deposit, 1e5)
    t_con = time.perf_counter() - t0
    mc = gp.microstructure(sample)
    rec = sample.record("consolidate").table()
    return {
        "mu_r": mu_r,
        "seed": seed,
        "n": len(deposit.radii),
        "deposit_phi": md.phi,
        "deposit_phi_core": md.phi_core,
        "deposit_e": md.void_ratio,
        "deposit_z": md.z,
        "deposit_s": t_dep,
        "phi_100kPa": mc.phi,
        "phi_core_100kPa": mc.phi_core,
        "e_100kPa": mc.void_ratio,
        "z_100kPa": mc.z,
        "steps_100kPa": rec.get("steps"),
        "consolidate_s": t_con,
    }


def summary(rows: list[dict]) -> str:
    lines = [
        "# The density window of example 4.3 against mu_r (mu = 0.5)",
        "",
        "Example 4.3, `fast()`, in the box; every layer deposited at mu = 0.5 with rolling",
        "resistance `epsd` (derived spring 2.25 mu_r^2 k_n, no rolling dashpot); then",
        "consolidated oedometrically to 100 kPa with the stage's defaults. phi is the",
        "sample's between floor and top (lid), phi_core the core window's, e = 1/phi - 1.",
        "Mean of the seeds " + ", ".join(str(s) for s in SEEDS) + " (their spread in brackets).",
        "",
        "| mu_r | deposit phi | deposit phi_core | deposit e | 100 kPa phi | 100 kPa phi_core "
        "| 100 kPa e | Z at 100 kPa |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for mu_r in MU_R:
        rs = [r for r in rows if r["mu_r"] == mu_r]
        if not rs:
            continue

        def col(key: str, rs: list[dict] = rs) -> str:
            vals = [r[key] for r in rs]
            mean = sum(vals) / len(vals)
            return f"{mean:.4f} ({max(vals) - min(vals):.4f})"

        lines.append(
            f"| {mu_r} | {col('deposit_phi')} | {col('deposit_phi_core')} | {col('deposit_e')} "
            f"| {col('phi_100kPa')} | {col('phi_core_100kPa')} | {col('e_100kPa')} "
            f"| {col('z_100kPa')} |"
        )
    return "\n".join(lines) + "\n"


def figure(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5, 3.5))
    for key, label in (
        ("deposit_phi_core", "deposit (core)"),
        ("phi_100kPa", "100 kPa"),
    ):
        xs = [r["mu_r"] for r in rows]
        ax.plot(xs, [r[key] for r in rows], "o", label=label)
    ax.axhline(0.57, color="grey", lw=0.8, ls="--")
    ax.set_xlabel("rolling friction mu_r")
    ax.set_ylabel("phi")
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def sieve(out: Path) -> None:
    """The window of a sieve-curve scene, point by point (see the module's doc)."""
    base = gp.PackScene.preset("4.3")
    material = dataclasses.replace(base.material, friction=MU, rolling="epsd", rolling_friction=0.4)
    scene = base.replace(
        base=(0.3, 0.3),
        height=0.2,
        radius_law="sieve",
        sieve_sizes=(0.02, 0.03, 0.05, 0.08),
        sieve_passing=(0.0, 0.3, 0.7, 1.0),
        seed=3,
        material=material,
    ).fast()
    t0 = time.perf_counter()
    lim = gp.void_ratio_limits(scene, packs=1)
    seconds = time.perf_counter() - t0
    rows = []
    for (stream, mech, mu_dep, phi), mu_r in zip(lim.points, lim.rolling_frictions, strict=True):
        rows.append(
            {
                "stream": stream,
                "mechanism": mech,
                "mu_dep": mu_dep,
                "mu_r": mu_r,
                "phi": phi,
                "e": 1.0 / phi - 1.0,
            }
        )
    with open(out / "sieve.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    lines = [
        "# The window of a sieve-curve scene against mu_r",
        "",
        "`examples/sieve_curve.py`'s scene (sieves 20-80 mm, 0.3 x 0.3 m, 0.2 m high), `fast()`,",
        f"one stream, mu = {MU}, rolling `epsd` with mu_r = 0.4: every pack of",
        f"`gp.void_ratio_limits` ({seconds:.0f} s). e is the core window's.",
        "",
        "| mechanism | mu_dep | mu_r | phi | e |",
        "|---|---|---|---|---|",
    ]
    for r in rows:
        cells = (r["mechanism"], f"{r['mu_dep']:g}", f"{r['mu_r']:g}", f"{r['phi']:.4f}")
        lines.append("| " + " | ".join(cells) + f" | {r['e']:.3f} |")
    lines += [
        "",
        f"e_min = {lim.e_min:.3f} ({', '.join(lim.e_min_from)}), "
        f"e_max = {lim.e_max:.3f} ({', '.join(lim.e_max_from)}).",
    ]
    (out / "sieve.md").write_text("\n".join(lines) + "\n")
    write_manifest(out, seeds=[3], name="manifest_sieve.json")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, default=Path(__file__).resolve().parent)
    ap.add_argument("--sieve", action="store_true", help="the sieve-curve scene's window")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    if args.sieve:
        sieve(args.out)
        return 0
    rows = []
    for mu_r in MU_R:
        for seed in SEEDS:
            rows.append(one(mu_r, seed))
            print(rows[-1], flush=True)
    with open(args.out / "runs.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    (args.out / "summary.md").write_text(summary(rows))
    figure(rows, args.out / "phi_vs_mu_r.png")
    write_manifest(args.out, seeds=list(SEEDS))
    return 0


if __name__ == "__main__":
    sys.exit(main())
