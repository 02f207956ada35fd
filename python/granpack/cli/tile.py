"""``granpack tile``: a periodic pack copied into one larger periodic pack."""

from __future__ import annotations

import argparse
import math
import time

from .._console import Console
from .._outputs import sweep_written
from .._validate import check_outputs
from . import _args

HELP = "copy a periodic pack nx x ny times into one larger periodic pack"
DESCRIPTION = (
    "Copies a pack made in a periodic cell (container = 'periodic') NX "
    "times along x and NY times along y (3D; NX alone in 2D) into one pack file: the "
    "contacts across the junctions are those of the original's seam, with their "
    "forces, so Z, phi, the fabric and the force tensors are the original's. The "
    "tiled pack repeats exactly, with the original cell as its period."
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    t = parser
    _args.add_pack(t, "a periodic pack file (.npz)")
    t.add_argument(
        "counts",
        type=_args.positive_int,
        nargs="+",
        metavar="COUNT",
        help="copies along x (and y in 3D), each >= 1",
    )
    _args.add_out(t, "output pack file (default: <PACK stem>_tiled_NXxNY.npz beside PACK)")


def run(args: argparse.Namespace, console: Console) -> int:
    from ..pack import load_pack
    from ..tiling import tile

    counts = tuple(args.counts)
    out = args.out
    if out is None:
        label = "x".join(str(c) for c in counts)
        out = args.pack.with_name(f"{args.pack.stem}_tiled_{label}.npz")
    check_outputs([out], [args.pack], parameter="--out")
    t0 = time.perf_counter()
    pack = load_pack(args.pack)
    tiled = tile(pack, counts)
    path = tiled.save(out)  # atomic: a temporary file, then a rename
    console.say(
        f"{path}: {len(pack)} particles x {math.prod(counts)} copies = {len(tiled)} "
        f"particles, {len(tiled.contacts)} contacts, base "
        f"{' x '.join(f'{b:g}' for b in tiled.scene.base)} m "
        f"({time.perf_counter() - t0:.2f} s)"
    )
    sweep_written([path], console)
    return 0
