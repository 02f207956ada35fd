"""A tall pack of example 4.3 with `PackScene.fast()`, against the same pack with its bed
frozen for good below a depth: the cost of each layer against the depth, and what the
frozen bed does to phi, Z and the fabric, paired pack by pack (same seed and stream).

`fast()` thaws a buried sphere when its net force passes 0.1 of its weight, which every
landing does to most of the bed, so the cost of a layer grows with the spheres below it
and a pack's cost with the square of its height. With ``freeze_force`` above any force a
landing gives (10 weights) and ``freeze_depth`` D, a sphere more than D below the top
freezes on its speed alone and stays frozen until the final relax: the active band is
then D thick, and a layer's cost stops growing once the pack is taller than D.

    python tall.py --variant fast --packs 12 --out OUT
    python tall.py --variant rigid --depth 0.4 --packs 12 --out OUT
    python tall.py --compare OUT

Each run appends one row a pack to OUT/<variant>_packs.csv (phi, Z, |a^r|, |a^n|, Z in
0.1 m bins of depth below the top, seconds) and the layers' seconds to
OUT/<variant>_layers.csv, written after every pack, so a run cut off keeps what it made;
a pack already in the file is not made again. Each run writes OUT/manifest_<variant>.json;
``--compare`` writes OUT/compare.md.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import polars as pl

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "_common"))
from manifest import write_manifest  # noqa: E402
from paired import common_streams, layer_medians, paired_row, table_head  # noqa: E402

import granpack as gp  # noqa: E402
from granpack.analysis.coordination import degrees  # noqa: E402
from granpack.pack import atomic_write  # noqa: E402

BIN = 0.1  # m, the depth bins of Z
STATS = ("phi", "z", "a_r", "a_n")


def scene_of(variant: str, height: float, depth: float) -> gp.PackScene:
    """4.3 with `fast()` at `height` (m); `rigid`: frozen for good below `depth` (m)."""
    fast = gp.PackScene.preset("4.3").replace(height=height).fast()
    if variant == "fast":
        return fast
    return fast.replace(freeze_depth=depth, freeze_force=10.0)


def z_by_depth(pack: gp.Pack, bins: int) -> list[float]:
    """Mean particle-particle contacts a sphere in each BIN of depth below the top."""
    count = degrees(pack.contacts.i, pack.contacts.j, len(pack))
    depth = pack.height - pack.positions[:, -1]
    b = np.minimum((depth / BIN).astype(int), bins - 1)
    return [float(count[b == k].mean()) if np.any(b == k) else float("nan") for k in range(bins)]


def run(a: argparse.Namespace) -> None:
    label = a.variant if a.variant == "fast" else f"rigid_{a.depth:g}m"
    a.out.mkdir(parents=True, exist_ok=True)
    packs_csv, layers_csv = a.out / f"{label}_packs.csv", a.out / f"{label}_layers.csv"
    rows = pl.read_csv(packs_csv).to_dicts() if packs_csv.exists() else []
    layers = pl.read_csv(layers_csv).to_dicts() if layers_csv.exists() else []
    done = {r["stream"] for r in rows}
    write_manifest(
        a.out,
        seeds={"seed": a.seed, "streams": f"0-{a.packs - 1}"},
        extra={"height_m": a.height, "variant": label},
        name=f"manifest_{label}.json",
    )
    bins = int(np.ceil(a.height / BIN)) + 1
    scene = scene_of(a.variant, a.height, a.depth)
    for k in range(a.packs):
        if k in done:
            continue
        t0 = time.perf_counter()
        pack = gp.generate(scene.replace(seed=a.seed, stream=k))
        seconds = time.perf_counter() - t0
        m = gp.microstructure(pack)
        row = {
            "variant": label,
            "seed": a.seed,
            "stream": k,
            "n": len(pack),
            "height": pack.height,
            "seconds": seconds,
            "phi": pack.phi,
            "z": m.z,
            "a_r": float(np.linalg.norm(m.a_r)),
            "a_n": float(np.linalg.norm(m.a_n)),
        }
        row |= {f"z_depth_{b}": z for b, z in enumerate(z_by_depth(pack, bins))}
        rows.append(row)
        layers.extend(
            {"stream": k, "layer": i, "total": rep["total"], "seconds": rep["wall_seconds"]}
            for i, rep in enumerate(pack.layers)
        )
        atomic_write(packs_csv, pl.DataFrame(rows).write_csv().encode())
        atomic_write(layers_csv, pl.DataFrame(layers).write_csv().encode())
        print(
            f"{label} stream {k}: N {len(pack)} phi {pack.phi:.4f} Z {m.z:.3f} {seconds:.1f} s",
            flush=True,
        )


def compare(out: Path) -> None:
    """Paired differences of each rigid variant from `fast`, and the layers' seconds."""
    ref = pl.read_csv(out / "fast_packs.csv")
    lines = ["# The bed frozen for good below a depth, against `fast()`, pack by pack", ""]
    depth_cols = [c for c in ref.columns if c.startswith("z_depth_")]
    for f in sorted(out.glob("rigid_*_packs.csv")):
        r, v, streams = common_streams(ref, pl.read_csv(f))
        name = f.name.removesuffix("_packs.csv")
        lines += [f"## {name}: {len(streams)} packs (streams {streams})", ""]
        lines += table_head("fast()", "variant")
        for q in ("seconds", "n", "height", *STATS, *depth_cols):
            row = paired_row(q, r[q].to_numpy(), v[q].to_numpy())
            if row is not None:
                lines.append(row)
        lines.append("")
    for f in sorted(out.glob("*_layers.csv")):
        lines += [layer_medians(f, f"`{f.name}`"), ""]
    atomic_write(out / "compare.md", "\n".join(lines).encode())
    print("\n".join(lines))


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--variant", choices=["fast", "rigid"], default="fast")
    ap.add_argument("--depth", type=float, default=0.4, help="rigid: frozen below (m)")
    ap.add_argument("--height", type=float, default=1.5, help="pack height H_d (m)")
    ap.add_argument("--packs", type=int, default=6)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=Path("bench-rigid-freeze-tall"))
    ap.add_argument("--compare", type=Path, help="only compare the runs in this folder")
    a = ap.parse_args(argv)
    if a.compare:
        compare(a.compare)
    else:
        run(a)


if __name__ == "__main__":
    main()
