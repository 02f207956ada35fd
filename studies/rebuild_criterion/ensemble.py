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

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "_common"))
from paired import periodic_ensemble_main  # noqa: E402

TITLE = "Positions wrapped on the drift, against wrapped at each rebuild"


def main(argv: list[str] | None = None) -> None:
    periodic_ensemble_main(
        argv,
        __doc__,
        ("rebuild", "drift"),
        Path("bench-rebuild-criterion"),
        TITLE,
        ("wrapped at a rebuild", "wrapped on the drift"),
    )


if __name__ == "__main__":
    main()
