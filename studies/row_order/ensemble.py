"""Packs of example 4.3 with `PackScene.fast()` in a periodic cell wide enough that each
layer holds more than `RESORT_MIN_LAYER` spheres, made by two builds of granpack: the
one that re-sorts the whole pack into one row-major order of cells after each such
layer, and the one before it, which re-sorted it into one Morton order. The order
changes the order in which each sphere's forces are summed, hence the last bits of every
step and, through the chaos of a granular flow, each pack; it must leave the ensemble
where it was. Pairs are made with the same seed and stream.

    python ensemble.py --build rows --packs 10 --out OUT
    PYTHONPATH=<site of the build before> python ensemble.py --build morton --packs 10 --out OUT
    python ensemble.py --compare OUT

Each run appends one row a pack to OUT/<build>_packs.csv (N, phi, Z, |a^r|, |a^n|,
seconds) and the layers' seconds to OUT/<build>_layers.csv, written after every pack, so
a run cut off keeps what it made; a pack already in the file is not made again. Each run
writes OUT/manifest_<build>.json, naming the granpack it imported; ``--compare`` writes
OUT/compare.md.
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "_common"))
from paired import periodic_ensemble_main  # noqa: E402

TITLE = "One row-major order over the whole pack, against one Morton order"


def main(argv: list[str] | None = None) -> None:
    periodic_ensemble_main(
        argv,
        __doc__,
        ("morton", "rows"),
        Path("bench-row-order"),
        TITLE,
        ("Morton", "row-major"),
    )


if __name__ == "__main__":
    main()
