"""Packs of example 4.3 with `PackScene.fast()` in a 2.5 m periodic cell, made by two
builds of granpack: the one that wraps a particle into the periodic cell on the drift
that takes it out (``drift``), and the one before it, which wrapped positions at each
pair-list rebuild (``rebuild``). A wrap rounds a position to the cell, so wrapping at a
rebuild made a periodic pack depend, in its last bits and then through the chaos of a
granular flow in its details, on when the list was rebuilt; the build with the drift's
wrap does not, and rebuilds less often. The change must leave the ensemble where it
was. Pairs are made with the same seed and stream.

    python ensemble.py --build drift --packs 10 --out OUT
    PYTHONPATH=BEFORE python ensemble.py --build rebuild --packs 10 --out OUT
    python ensemble.py --compare OUT

The packs' rows go to OUT/<build>_packs.csv and OUT/<build>_layers.csv, written after
every pack (`paired.make_packs`); each run writes OUT/manifest_<build>.json, naming the
granpack it imported (BEFORE: a folder holding the build before's `granpack`);
``--compare`` writes OUT/compare.md.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "_common"))
from manifest import write_manifest  # noqa: E402
from paired import compare_builds, make_packs  # noqa: E402

import granpack as gp  # noqa: E402


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--build", choices=["drift", "rebuild"], default="drift")
    ap.add_argument("--side", type=float, default=2.5, help="side of the periodic cell (m)")
    ap.add_argument("--packs", type=int, default=10)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=Path("bench-rebuild-criterion"))
    ap.add_argument("--compare", type=Path, help="only compare the runs in this folder")
    a = ap.parse_args(argv)
    if a.compare:
        title = "Positions wrapped on the drift, against wrapped at each rebuild"
        labels = ("wrapped at a rebuild", "wrapped on the drift")
        print(compare_builds(a.compare, "rebuild", "drift", title, labels))
        return
    write_manifest(
        a.out,
        seeds={"seed": a.seed, "streams": f"0-{a.packs - 1}"},
        extra={"side_m": a.side, "build": a.build, "granpack": gp.__file__},
        name=f"manifest_{a.build}.json",
    )
    sc = gp.PackScene.preset("4.3").replace(container="periodic", base=(a.side, a.side)).fast()
    make_packs(a.out, a.build, sc, a.packs, a.seed)


if __name__ == "__main__":
    main()
