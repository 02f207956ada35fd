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
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "_common"))
from manifest import write_manifest  # noqa: E402
from paired import compare_builds, make_packs  # noqa: E402

import granpack as gp  # noqa: E402


def scene(side: float) -> gp.PackScene:
    """4.3 with `fast()` in a periodic cell of side `side` (m)."""
    return gp.PackScene.preset("4.3").replace(container="periodic", base=(side, side)).fast()


def run(a: argparse.Namespace) -> None:
    write_manifest(
        a.out,
        seeds={"seed": a.seed, "streams": f"0-{a.packs - 1}"},
        extra={"side_m": a.side, "build": a.build, "granpack": gp.__file__},
        name=f"manifest_{a.build}.json",
    )
    make_packs(a.out, a.build, scene(a.side), a.packs, a.seed)


def compare(out: Path) -> None:
    """Paired differences of the re-sorted packs from the layered ones."""
    title = "One Morton order over the whole pack, against a Morton order a layer"
    print(compare_builds(out, "layered", "resorted", title, ("layered", "re-sorted")))


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
