"""Pairs of 4.3 `fast()` packs, the same seed and stream, in a periodic cell wide enough
that every layer is re-sorted (2.5 m: layers of 4 663 spheres): the build that re-sorts
into one row-major order of cells against the build before it (one Morton order). The
order changes each sphere's sums, hence every pack's details; the ensemble must stay
where it was.

    python ensemble.py --build rows --out OUT
    PYTHONPATH=<site of the build before> python ensemble.py --build morton --out OUT
    python ensemble.py --compare OUT

What each run writes, and keeps when cut off, is `paired.periodic_ensemble_main`'s:
a row a pack and the layers' seconds, a manifest a build, and compare.md.
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
