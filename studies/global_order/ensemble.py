"""Packs of example 4.3 with `PackScene.fast()` in a periodic cell wide enough that each
layer holds more than `RESORT_MIN_LAYER` spheres, made by two builds of granpack: the
one that re-sorts the whole pack into one Morton order after each such layer, and the
one before it, which appended each layer in its own Morton order. The re-sort changes
the order in which each sphere's forces are summed, hence the last bits of every step
and, through the chaos of a granular flow, each pack; it must leave the ensemble where
it was. Pairs are made with the same seed and stream.

    python ensemble.py --build resorted --packs 10 --out OUT
    PYTHONPATH=<site of the build before> python ensemble.py --build layered --packs 10 --out OUT
    python ensemble.py --compare OUT

Each run appends one row a pack to OUT/<build>_packs.csv (N, phi, Z, |a^r|, |a^n|,
seconds) and the layers' seconds to OUT/<build>_layers.csv, written after every pack, so
a run cut off keeps what it made; a pack already in the file is not made again. Each run
writes OUT/manifest_<build>.json, naming the granpack it imported; ``--compare`` writes
OUT/compare.md.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import polars as pl

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "_common"))
from manifest import write_manifest  # noqa: E402
from paired import layer_medians, paired_row, table_head  # noqa: E402

import granpack as gp  # noqa: E402
from granpack.pack import atomic_write  # noqa: E402

STATS = ("n", "phi", "z", "a_r", "a_n")


def scene(side: float) -> gp.PackScene:
    """4.3 with `fast()` in a periodic cell of side `side` (m)."""
    return gp.PackScene.preset("4.3").replace(container="periodic", base=(side, side)).fast()


def run(a: argparse.Namespace) -> None:
    a.out.mkdir(parents=True, exist_ok=True)
    packs_csv, layers_csv = a.out / f"{a.build}_packs.csv", a.out / f"{a.build}_layers.csv"
    rows = pl.read_csv(packs_csv).to_dicts() if packs_csv.exists() else []
    layers = pl.read_csv(layers_csv).to_dicts() if layers_csv.exists() else []
    done = {r["stream"] for r in rows}
    write_manifest(
        a.out,
        seeds={"seed": a.seed, "streams": f"0-{a.packs - 1}"},
        extra={"side_m": a.side, "build": a.build, "granpack": gp.__file__},
        name=f"manifest_{a.build}.json",
    )
    sc = scene(a.side)
    for k in range(a.packs):
        if k in done:
            continue
        t0 = time.perf_counter()
        pack = gp.generate(sc.replace(seed=a.seed, stream=k))
        seconds = time.perf_counter() - t0
        m = gp.microstructure(pack)
        rows.append(
            {
                "build": a.build,
                "seed": a.seed,
                "stream": k,
                "n": len(pack),
                "smallest_layer": min(rep["added"] for rep in pack.layers),
                "seconds": seconds,
                "phi": pack.phi,
                "z": m.z,
                "a_r": float(np.linalg.norm(m.a_r)),
                "a_n": float(np.linalg.norm(m.a_n)),
            }
        )
        layers.extend(
            {"stream": k, "layer": i, "total": rep["total"], "seconds": rep["wall_seconds"]}
            for i, rep in enumerate(pack.layers)
        )
        atomic_write(packs_csv, pl.DataFrame(rows).write_csv().encode())
        atomic_write(layers_csv, pl.DataFrame(layers).write_csv().encode())
        print(
            f"{a.build} stream {k}: N {len(pack)} phi {pack.phi:.4f} Z {m.z:.3f} {seconds:.1f} s",
            flush=True,
        )


def compare(out: Path) -> None:
    """Paired differences of the re-sorted packs from the layered ones."""
    ref = pl.read_csv(out / "layered_packs.csv").sort("stream")
    var = pl.read_csv(out / "resorted_packs.csv").sort("stream")
    streams = sorted(set(ref["stream"]) & set(var["stream"]))
    r = ref.filter(pl.col("stream").is_in(streams))
    v = var.filter(pl.col("stream").is_in(streams))
    lines = [
        "# One Morton order over the whole pack, against a Morton order a layer",
        "",
        f"{len(streams)} pairs (streams {streams}); the smallest layer of any pack held "
        f"{min(r['smallest_layer'].min(), v['smallest_layer'].min())} spheres.",
        "",
        *table_head("layered", "re-sorted"),
    ]
    for q in ("seconds", *STATS):
        lines.append(paired_row(q, r[q].to_numpy(), v[q].to_numpy()))
    lines.append("")
    for name in ("layered", "resorted"):
        lines += [layer_medians(out / f"{name}_layers.csv", name), ""]
    atomic_write(out / "compare.md", "\n".join(lines).encode())
    print("\n".join(lines))


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--build", choices=["resorted", "layered"], default="resorted")
    ap.add_argument("--side", type=float, default=2.5, help="side of the periodic cell (m)")
    ap.add_argument("--packs", type=int, default=10)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=Path("bench-global-order"))
    ap.add_argument("--compare", type=Path, help="only compare the runs in this folder")
    a = ap.parse_args(argv)
    if a.compare:
        compare(a.compare)
    else:
        run(a)


if __name__ == "__main__":
    main()
