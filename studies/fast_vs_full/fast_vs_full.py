"""Run time against error: the paper's full-fidelity settings against faster ones.

For each preset, `--packs` packs with the paper's settings (dt = 1e-4 s, 1.0 s of
jamming per layer, no freezing) and the same number with each faster variant:

- ``freeze``: the paper's fixed 1.0 s per layer, with freezing as in
  `PackScene.fast()`;
- ``dt``: dt = `--dt-fraction` of the Rayleigh estimate (all presets are stable up to
  the estimate, `studies/stability/stability.py`);
- ``settle``: adaptive settling as in `PackScene.fast()`, no freezing;
- ``fast``: `PackScene.fast()` (adaptive settling, freezing, and in 3D a larger dt);
- ``fast+dt``: `PackScene.fast()` with dt = `--dt-fraction` of the Rayleigh estimate;
- ``fast-paper-dt``: `PackScene.fast()` with the scene's own dt (the fast settings of
  before 2026-12-01).

Packs of one setting use the master seed and streams 0..n-1, like `granpack paper`.
For each variant it reports the wall time per pack and the difference of the mean phi,
Z, |a^r| (fabric) and |a^n| (normal forces) from the full-fidelity ensemble, in units of
the full ensemble's standard deviation (ddof = 1), and writes a CSV (rewritten after
every variant, so a cut-off run keeps what it finished) and a plot of time against
error.

    python studies/fast_vs_full/fast_vs_full.py --presets 4.1 --packs 10 --out bench-out
    python studies/fast_vs_full/fast_vs_full.py --presets 4.3 --variants full freeze fast
    python studies/fast_vs_full/fast_vs_full.py --presets 4.1 4.2 --packs 20 --variants full fast \
        --inertia-2d sphere

`--inertia-2d` sets the 2D mass convention of every variant (the presets' default is
disc mass; the manifest records which one ran).

Every pack's values go to `fast_vs_full_packs.csv` as well, with Z in each fifth of the
pack height (z_fifth_1 at the bottom): it shows where a variant changes the contacts.
`--reference` takes the full-fidelity packs from such a file instead of running them
again (they are the expensive part: 10 packs of 4.3 take 8 min), and `--set` changes a
scene field in every faster variant, for trying new fast settings:

    python studies/fast_vs_full/fast_vs_full.py --presets 4.3 --variants fast \
        --reference bench-out/fast_vs_full_packs.csv --set freeze_force=1.0
"""

from __future__ import annotations

import argparse
import sys
import time
import tomllib
from pathlib import Path

import numpy as np
import polars as pl

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "_common"))
from manifest import write_manifest  # noqa: E402

import granpack as gp  # noqa: E402
from granpack.analysis.coordination import degrees  # noqa: E402
from granpack.pack import atomic_write  # noqa: E402

FIFTHS = [f"z_fifth_{k}" for k in range(1, 6)]
QUANTITIES = ("time", "phi", "z", "a_r", "a_n", *FIFTHS)


def variants(
    scene: gp.PackScene, dt_fraction: float, changes: dict | None = None
) -> dict[str, gp.PackScene]:
    """The full-fidelity scene and the faster ones; `changes` (scene fields) apply to
    every faster variant."""
    dt = dt_fraction * scene.material.critical_time_step(scene.r_min)
    fast = scene.fast()
    faster = {
        "freeze": scene.replace(freeze_depth=fast.freeze_depth),
        "dt": scene.replace(dt=dt),
        "settle": scene.replace(settle_tol=fast.settle_tol),
        "fast": fast,
        "fast+dt": fast.replace(dt=dt),
        "fast-paper-dt": fast.replace(dt=scene.dt),
    }
    return {"full": scene} | {k: v.replace(**(changes or {})) for k, v in faster.items()}


def parse_set(items: list[str]) -> dict:
    """`key=value` pairs, each value read as TOML (1.0, true, "text")."""
    out = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep:
            raise SystemExit(f"--set {item!r}: expected key=value")
        out[key.strip()] = tomllib.loads(f"v = {value}")["v"]
    return out


def z_by_fifth(pack: gp.Pack) -> list[float]:
    """Mean particle-particle contacts per particle in each fifth of the pack height."""
    count = degrees(pack.contacts.i, pack.contacts.j, len(pack))
    fifth = np.minimum((5.0 * pack.positions[:, -1] / pack.height).astype(int), 4)
    return [
        float(count[fifth == b].mean()) if np.any(fifth == b) else float("nan") for b in range(5)
    ]


def measure(scene: gp.PackScene, packs: int, seed: int) -> dict[str, np.ndarray]:
    out: dict[str, list[float]] = {q: [] for q in QUANTITIES}
    for k in range(packs):
        t0 = time.perf_counter()
        pack = gp.generate(scene.replace(seed=seed, stream=k))
        out["time"].append(time.perf_counter() - t0)
        m = gp.microstructure(pack)
        out["phi"].append(pack.phi)
        out["z"].append(m.z)
        out["a_r"].append(float(np.linalg.norm(m.a_r)))
        out["a_n"].append(float(np.linalg.norm(m.a_n)))
        for q, z in zip(FIFTHS, z_by_fifth(pack), strict=True):
            out[q].append(z)
    return {k: np.asarray(v) for k, v in out.items()}


def plot(df: pl.DataFrame, out: Path) -> None:
    """Time per pack against the largest shift of the four statistics."""

    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure
    from matplotlib.ticker import NullFormatter

    fig = Figure(figsize=(8.5, 4))
    ax = fig.add_subplot()
    cols = ["phi_shift_sd", "z_shift_sd", "a_r_shift_sd", "a_n_shift_sd"]
    markers = dict(zip(sorted(df["preset"].unique()), "osD^v<>", strict=False))
    # the standard variants keep their colours; variants run with --set get the next ones
    known = ["full", "freeze", "dt", "settle", "fast", "fast+dt", "fast-paper-dt"]
    extra = [v for v in df["variant"].unique(maintain_order=True) if v not in known]
    colors = {v: f"C{k % 10}" for k, v in enumerate(known + extra)}
    for (preset, label), sub in df.group_by(["preset", "variant"], maintain_order=True):
        err = np.max(np.abs(sub.select(cols).to_numpy()), axis=1)
        ax.scatter(
            sub["seconds_per_pack"],
            err,
            marker=markers[preset],
            color=colors[label],
            label=f"{preset} {label}",
        )
    ax.axhline(1.0, color="grey", lw=0.8, ls="--")
    ax.set_xscale("log")
    ax.xaxis.set_minor_formatter(NullFormatter())  # minor labels overlap on short ranges
    ax.set_xlabel("wall time per pack (s)")
    ax.set_ylabel("largest |shift| of mean phi, Z, |a^r|, |a^n|\n(full-fidelity sd)")
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0))
    fig.tight_layout()
    fig.savefig(out / "fast_vs_full.png", dpi=120)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--presets", nargs="+", default=["4.1", "4.2", "4.3", "4.4"])
    ap.add_argument("--packs", type=int, default=10)
    ap.add_argument(
        "--variants",
        nargs="+",
        default=["full", "freeze", "dt", "fast", "fast+dt"],
        help="which settings to run; 'full' always runs first (the reference)",
    )
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--dt-fraction", type=float, default=0.9)
    ap.add_argument(
        "--inertia-2d",
        choices=["sphere", "disc"],
        default=None,
        help="2D mass convention of every variant, full fidelity included (default: the "
        "presets' own); ignored by the 3D presets",
    )
    ap.add_argument("--out", type=Path, default=Path("bench-fast-vs-full"))
    ap.add_argument("--replot", action="store_true", help="only redraw the plot from --out's CSV")
    ap.add_argument(
        "--reference",
        type=Path,
        default=None,
        help="a fast_vs_full_packs.csv whose 'full' packs (same preset, seed and count) "
        "serve as the reference instead of running them",
    )
    ap.add_argument(
        "--set",
        nargs="+",
        default=[],
        metavar="KEY=VALUE",
        help="scene fields to change in every faster variant (its label gets them)",
    )
    a = ap.parse_args(argv)
    changes = parse_set(a.set)
    suffix = "".join(f" {k}={v}" for k, v in changes.items())
    if a.replot:
        plot(pl.read_csv(a.out / "fast_vs_full.csv"), a.out)
        return
    rows: list[dict] = []
    packs: list[dict] = []
    reference = (
        pl.read_csv(a.reference, schema_overrides={"preset": pl.String}) if a.reference else None
    )
    a.out.mkdir(parents=True, exist_ok=True)
    write_manifest(
        a.out,
        seeds={"seed": a.seed, "streams": f"0-{a.packs - 1}"},
        extra={"inertia_2d": a.inertia_2d or gp.PackScene.preset("4.1").inertia_2d},
    )
    wanted = ["full"] + [v for v in a.variants if v != "full"]
    for name in a.presets:
        base = gp.PackScene.preset(name)
        if a.inertia_2d is not None and base.dim == 2:
            base = base.replace(inertia_2d=a.inertia_2d)
        results = {}
        all_variants = variants(base, a.dt_fraction, changes)
        for label in wanted:
            scene = all_variants[label]
            ref = None
            if label == "full" and reference is not None:
                ref = reference.filter(
                    (pl.col("preset") == name)
                    & (pl.col("variant") == "full")
                    & (pl.col("seed") == a.seed)
                    & (pl.col("stream") < a.packs)
                ).sort("stream")
            if ref is not None and ref.height == a.packs:
                # files written before the per-fifth Z have no such columns
                results[label] = {
                    q: ref[q].to_numpy() if q in ref.columns else np.full(a.packs, np.nan)
                    for q in QUANTITIES
                }
            else:
                results[label] = measure(scene, a.packs, a.seed)
            r = results[label]
            shown = label if label == "full" else label + suffix
            packs.extend(
                {"preset": name, "variant": shown, "seed": a.seed, "stream": k}
                | {q: float(r[q][k]) for q in QUANTITIES}
                for k in range(a.packs)
            )
            full = results["full"]
            row = {
                "preset": name,
                "variant": shown,
                "packs": a.packs,
                "seconds_per_pack": float(r["time"].mean()),
            }
            for q in ("phi", "z", "a_r", "a_n"):
                sd = float(full[q].std(ddof=1)) if a.packs > 1 else float("nan")
                row[f"{q}_mean"] = float(r[q].mean())
                row[f"{q}_shift_sd"] = float((r[q].mean() - full[q].mean()) / sd)
            rows.append(row)
            print(
                ", ".join(
                    f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}" for k, v in row.items()
                ),
                flush=True,
            )
            atomic_write(a.out / "fast_vs_full.csv", pl.DataFrame(rows).write_csv().encode())
            atomic_write(a.out / "fast_vs_full_packs.csv", pl.DataFrame(packs).write_csv().encode())
    plot(pl.DataFrame(rows), a.out)
    print(f"wrote {a.out / 'fast_vs_full.csv'} and {a.out / 'fast_vs_full.png'}")


if __name__ == "__main__":
    main()
