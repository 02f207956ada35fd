"""Paired comparisons of two ensembles made with the same seeds and streams: the rows of
the tables that `compare.md` files give, shared by the studies that pit a variant against
a reference pack by pack."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import polars as pl

#: What `make_packs` records of each pack, beside its stream and seconds.
STATS = ("n", "phi", "z", "a_r", "a_n")

HEADER = (
    "| quantity | {ref} mean | {var} mean | mean difference | its standard error "
    "| difference / sd of {ref} |"
)


def table_head(ref: str, var: str) -> list[str]:
    """The header and rule of the paired table, the reference named `ref`, the variant `var`."""
    return [HEADER.format(ref=ref, var=var), "|---|---|---|---|---|---|"]


def paired_row(q: str, a: np.ndarray, b: np.ndarray) -> str | None:
    """Row of quantity `q`: the means of the reference `a` and the variant `b` (pack k of
    each made with the same seed and stream), the mean paired difference, its standard
    error, and the difference in sd of the reference. Pairs with a NaN on either side are
    left out; None with fewer than two pairs."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    ok = ~(np.isnan(a) | np.isnan(b))
    if ok.sum() < 2:
        return None
    d = b[ok] - a[ok]
    sd = a[ok].std(ddof=1)
    se = d.std(ddof=1) / np.sqrt(ok.sum())
    return (
        f"| {q} | {a[ok].mean():.5g} | {b[ok].mean():.5g} | {d.mean():+.4g} "
        f"| {se:.2g} | {d.mean() / sd if sd > 0 else float('nan'):+.2f} |"
    )


def common_streams(a: pl.DataFrame, b: pl.DataFrame) -> tuple[pl.DataFrame, pl.DataFrame, list]:
    """The rows of `a` and `b` (tables of packs with a column `stream`) for the streams both
    hold, each sorted by stream, and those streams in order: pack k of one beside pack k
    of the other, for `paired_row`."""
    streams = sorted(set(a["stream"]) & set(b["stream"]))
    keep = pl.col("stream").is_in(streams)
    return a.filter(keep).sort("stream"), b.filter(keep).sort("stream"), streams


def layer_medians(path: Path, label: str) -> str:
    """The median seconds of each layer over the packs of a `*_layers.csv` (columns
    layer, seconds), as one line."""
    lay = pl.read_csv(path)
    med = lay.group_by("layer").agg(pl.col("seconds").median()).sort("layer")
    return f"Median seconds a layer, {label}: " + ", ".join(f"{s:.2f}" for s in med["seconds"])


def make_packs(out: Path, build: str, scene, packs: int, seed: int, extra=None) -> None:
    """Makes packs 0..`packs`-1 of `scene` (a `PackScene`; stream k for pack k) and
    appends one row a pack to OUT/<build>_packs.csv (N, phi, Z, |a^r|, |a^n|, seconds,
    and the columns that `extra(pack)`, when given, returns as a dict) and the layers'
    seconds to OUT/<build>_layers.csv, both written after every pack, so that a run cut
    off keeps what it made; a pack already in the file is not made again."""
    import granpack as gp
    from granpack.pack import atomic_write

    out.mkdir(parents=True, exist_ok=True)
    packs_csv, layers_csv = out / f"{build}_packs.csv", out / f"{build}_layers.csv"
    rows = pl.read_csv(packs_csv).to_dicts() if packs_csv.exists() else []
    layers = pl.read_csv(layers_csv).to_dicts() if layers_csv.exists() else []
    done = {r["stream"] for r in rows}
    for k in range(packs):
        if k in done:
            continue
        t0 = time.perf_counter()
        pack = gp.generate(scene.replace(seed=seed, stream=k))
        seconds = time.perf_counter() - t0
        m = gp.microstructure(pack)
        rows.append(
            {
                "build": build,
                "seed": seed,
                "stream": k,
                "n": len(pack),
                "smallest_layer": min(rep["added"] for rep in pack.layers),
                "seconds": seconds,
                "phi": pack.phi,
                "z": m.z,
                "a_r": float(np.linalg.norm(m.a_r)),
                "a_n": float(np.linalg.norm(m.a_n)),
                **(extra(pack) if extra else {}),
            }
        )
        layers.extend(
            {"stream": k, "layer": i, "total": rep["total"], "seconds": rep["wall_seconds"]}
            for i, rep in enumerate(pack.layers)
        )
        atomic_write(packs_csv, pl.DataFrame(rows).write_csv().encode())
        atomic_write(layers_csv, pl.DataFrame(layers).write_csv().encode())
        line = f"{build} stream {k}: N {len(pack)} phi {pack.phi:.4f} Z {m.z:.3f} {seconds:.1f} s"
        print(line, flush=True)


def compare_builds(out: Path, ref: str, var: str, title: str, labels: tuple[str, str]) -> str:
    """The paired table of the packs of builds `ref` and `var` in OUT (made by
    `make_packs`), over the streams both made, with each build's median seconds a layer;
    written to OUT/compare.md under `title`, with `labels` naming the two builds."""
    from granpack.pack import atomic_write

    r, v, streams = common_streams(
        pl.read_csv(out / f"{ref}_packs.csv"), pl.read_csv(out / f"{var}_packs.csv")
    )
    lines = [
        f"# {title}",
        "",
        f"{len(streams)} pairs (streams {streams}); the smallest layer of any pack held "
        f"{min(r['smallest_layer'].min(), v['smallest_layer'].min())} spheres.",
        "",
        *table_head(*labels),
    ]
    for q in ("seconds", *STATS):
        lines.append(paired_row(q, r[q].to_numpy(), v[q].to_numpy()))
    lines.append("")
    for name in (ref, var):
        lines += [layer_medians(out / f"{name}_layers.csv", name), ""]
    text = "\n".join(lines)
    atomic_write(out / "compare.md", text.encode())
    return text


def periodic_ensemble_main(
    argv: list[str] | None,
    doc: str,
    builds: tuple[str, str],
    out: Path,
    title: str,
    labels: tuple[str, str],
) -> None:
    """The command line of a study that pits two builds of granpack against each other on
    packs of 4.3 with `fast()` in a periodic cell: ``--build NAME`` makes the packs of the
    build imported (`make_packs`; `builds` = (reference, variant)), ``--compare OUT``
    writes the paired table (`compare_builds`, with `title` and `labels`)."""
    import argparse

    from manifest import write_manifest

    ref, var = builds
    ap = argparse.ArgumentParser(description=doc, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--build", choices=[var, ref], default=var)
    ap.add_argument("--side", type=float, default=2.5, help="side of the periodic cell (m)")
    ap.add_argument("--packs", type=int, default=10)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=out)
    ap.add_argument("--compare", type=Path, help="only compare the runs in this folder")
    a = ap.parse_args(argv)
    if a.compare:
        print(compare_builds(a.compare, ref, var, title, labels))
        return
    import granpack as gp

    write_manifest(
        a.out,
        seeds={"seed": a.seed, "streams": f"0-{a.packs - 1}"},
        extra={"side_m": a.side, "build": a.build, "granpack": gp.__file__},
        name=f"manifest_{a.build}.json",
    )
    sc = gp.PackScene.preset("4.3").replace(container="periodic", base=(a.side, a.side)).fast()
    make_packs(a.out, a.build, sc, a.packs, a.seed)
