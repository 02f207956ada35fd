"""Pairs of 4.3 `fast()` packs in the presets' box, the same seed and stream, made by the
build whose last layer always runs the rest of its settle_time ("before") and by the build
that ends that rest once the pack's height falls below the target ("after"; the layer
was not the last, and the next one lands on it). A pack whose adaptive settle never left
a sphere in flight above the target keeps its bits; the others must stay in the ensemble.

    PYTHONPATH=<site of the build before> python ensemble.py --build before --out OUT
    python ensemble.py --build after --out OUT
    python ensemble.py --compare OUT

Each run writes `paired.make_packs`'s files (OUT/<build>_packs.csv, a row a pack: N, phi,
Z, |a^r|, |a^n|, the wall seconds, and here also the particle-steps, the steps of each
layer and a digest of the positions; OUT/<build>_layers.csv), rewritten after every pack
so that a run cut off keeps what it made, and a manifest. (The committed CSVs were
written by this study's own loop before it used `make_packs`: the same columns, without
`smallest_layer` and the layers' file.)
"""

from __future__ import annotations

import argparse
import hashlib
import sys
from pathlib import Path

import numpy as np
import polars as pl

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "_common"))
from paired import STATS, common_streams, make_packs, paired_row, table_head  # noqa: E402


def digest(x: np.ndarray) -> str:
    """The first 16 hex digits of the SHA-256 of the positions' bytes."""
    return hashlib.sha256(np.ascontiguousarray(x).tobytes()).hexdigest()[:16]


def bookkeeping(pack) -> dict:
    """What this study records of a pack beside `paired.make_packs`'s columns: its layer
    count, its particle-steps, each layer's steps and a digest of its positions."""
    return {
        "layers": len(pack.layers),
        "particle_steps": sum(rep["steps"] * rep["total"] for rep in pack.layers),
        "steps": " ".join(str(rep["steps"]) for rep in pack.layers),
        "digest": digest(pack.positions),
    }


def compare(out: Path) -> str:
    from granpack.pack import atomic_write

    a, b, streams = common_streams(
        pl.read_csv(out / "before_packs.csv"), pl.read_csv(out / "after_packs.csv")
    )
    same = (a["digest"] == b["digest"]).to_numpy()
    changed = [s for s, k in zip(streams, same, strict=True) if not k]
    lines = [
        "# The last layer's rest ended once the height falls below the target",
        "",
        f"{len(streams)} pairs of 4.3 `fast()` packs in the presets' box (seed "
        f"{a['seed'][0]}, streams {streams[0]}-{streams[-1]}); {int(same.sum())} pairs "
        f"bit-identical (the same digest of the positions), {len(changed)} changed: "
        f"streams {changed}.",
        "",
        "All pairs:",
        "",
        *table_head("before", "after"),
    ]
    for q in ("seconds", "particle_steps", "layers", *STATS):
        lines.append(paired_row(q, a[q].to_numpy(), b[q].to_numpy()))
    if len(changed) >= 2:
        ac = a.filter(pl.col("stream").is_in(changed))
        bc = b.filter(pl.col("stream").is_in(changed))
        lines += [
            "",
            "The changed pairs alone (differences in sd of all the packs before):",
            "",
            "| quantity | before mean | after mean | mean difference | difference / sd |",
            "|---|---|---|---|---|",
        ]
        for q in ("seconds", "particle_steps", "layers", *STATS):
            x, y, sd = ac[q].to_numpy(), bc[q].to_numpy(), a[q].to_numpy().std(ddof=1)
            d = (y - x).mean()
            in_sd = d / sd if sd > 0 else float("nan")
            lines.append(f"| {q} | {x.mean():.5g} | {y.mean():.5g} | {d:+.4g} | {in_sd:+.2f} |")
        lines += ["", "Steps of each layer, changed pairs (before / after):", ""]
        for s in changed:
            lines.append(
                f"- stream {s}: {a.filter(pl.col('stream') == s)['steps'][0]} / "
                f"{b.filter(pl.col('stream') == s)['steps'][0]}"
            )
    text = "\n".join(lines) + "\n"
    atomic_write(out / "compare.md", text.encode())
    return text


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--build", choices=["before", "after"], default="after")
    ap.add_argument("--packs", type=int, default=30)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=Path("bench-last-layer"))
    ap.add_argument("--compare", type=Path, help="only compare the runs in this folder")
    a = ap.parse_args(argv)
    if a.compare:
        print(compare(a.compare))
        return
    from manifest import write_manifest

    import granpack as gp

    write_manifest(
        a.out,
        seeds={"seed": a.seed, "streams": f"0-{a.packs - 1}"},
        extra={"build": a.build, "granpack": gp.__file__, "scene": "preset 4.3, fast()"},
        name=f"manifest_{a.build}.json",
    )
    scene = gp.PackScene.preset("4.3").fast()
    make_packs(a.out, a.build, scene, a.packs, a.seed, extra=bookkeeping)


if __name__ == "__main__":
    main()
