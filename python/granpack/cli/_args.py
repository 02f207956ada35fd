"""The commands' argument types, the options of the commands that make packs, and those
of the commands that read one pack file and write beside it."""

from __future__ import annotations

import argparse
import math
from pathlib import Path

# -- argument types ------------------------------------------------------------------------------


def on_off(value: str) -> bool:
    v = value.lower()
    if v in ("on", "true", "yes", "1"):
        return True
    if v in ("off", "false", "no", "0"):
        return False
    raise argparse.ArgumentTypeError(f"invalid value {short(value)!r}: use on or off")


def short(text: str, limit: int = 40) -> str:
    return text if len(text) <= limit else text[: limit - 3] + "..."


def positive_int(value: str) -> int:
    try:
        v = int(value)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"invalid value {short(value)!r}: expected an integer"
        ) from None
    if v < 1:
        raise argparse.ArgumentTypeError(f"invalid value {short(str(v))}: must be >= 1")
    return v


def count(hi: int, what: str):
    """An argparse type: an integer in [1, hi]; the bound keeps a typo (an extra digit
    or twenty) from starting a run that never ends."""

    def parse(value: str) -> int:
        v = positive_int(value)
        if v > hi:
            raise argparse.ArgumentTypeError(
                f"invalid value {short(str(v))}: {what} must lie in [1, {hi}]"
            )
        return v

    return parse


def packs(value: str) -> int:
    from ..ensemble import MAX_PACKS

    return count(MAX_PACKS, "packs")(value)


def workers(value: str) -> int:
    from ..ensemble import max_workers

    return count(max_workers(), "workers (four per core)")(value)


def seed(value: str) -> int:
    try:
        v = int(value)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"invalid seed {short(value)!r}: expected an integer"
        ) from None
    if not 0 <= v < 2**64:
        raise argparse.ArgumentTypeError(f"invalid seed {short(str(v))}: must lie in [0, 2^64 - 1]")
    return v


def positive_float(value: str) -> float:
    try:
        v = float(value)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"invalid value {short(value)!r}: expected a number"
        ) from None
    if not (math.isfinite(v) and v > 0):
        raise argparse.ArgumentTypeError(f"invalid value {short(value)!r}: must be > 0")
    return v


def add_quiet(p: argparse.ArgumentParser) -> None:
    p.add_argument("-q", "--quiet", action="store_true", help="print nothing but errors")


def add_pack(p: argparse.ArgumentParser, help: str) -> None:
    """The pack file a command reads (export, tile)."""
    p.add_argument("pack", type=Path, metavar="PACK", help=help)


def add_out(p: argparse.ArgumentParser, help: str) -> None:
    """--out, where a command that reads one pack writes (export, tile), and --quiet."""
    p.add_argument("--out", type=Path, default=None, help=help)
    add_quiet(p)


def add_run_options(p: argparse.ArgumentParser) -> None:
    """The options of the commands that make packs: where they run, --quiet, --fast."""
    p.add_argument(
        "--workers",
        type=workers,
        default=None,
        help="local worker processes (default: one per core)",
    )
    p.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        default=None,
        help="run the packs on this Dask distributed scheduler (e.g. tcp://host:8786) "
        "instead of local processes; needs granpack[dask]",
    )
    p.add_argument(
        "--write-on-workers",
        action="store_true",
        help="with --scheduler: each Dask worker saves its packs itself (the output folder "
        "must be on a file system the workers share, as on a batch cluster) and sends "
        "back only their numbers",
    )
    add_quiet(p)
    p.add_argument(
        "--fast",
        action="store_true",
        help="PackScene.fast(): adaptive settling, freezing of buried settled particles, "
        "a larger dt where the scene's is below 0.55 of the stable step (3D presets), "
        "and 0.75 of it once each layer has landed (ensemble statistics within one sd, "
        "see docs/performance.md)",
    )
    # Development and test knobs (not the paper's physics): hidden from --help.
    p.add_argument("--settle-time", type=positive_float, default=None, help=argparse.SUPPRESS)
    p.add_argument("--scale", type=positive_float, default=None, help=argparse.SUPPRESS)
