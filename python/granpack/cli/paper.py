"""``granpack paper``: the paper's section 4 reproduced, examples 4.1-4.4 with rotations
on and off (`granpack.paper.reproduce`)."""

from __future__ import annotations

import argparse
from pathlib import Path

from .._console import Console
from ..paper.reproduction import PAPER_EXAMPLES, PAPER_PACKS, QUICK_PACKS
from . import _args

HELP = "reproduce the paper's section 4 (examples 4.1-4.4, rotations on and off)"
DESCRIPTION = (
    "Runs the paper's examples 4.1-4.4 with rotations ON and OFF, n packs "
    "each, and writes tables 2-13 with the paper's numbers beside ours, the extra "
    "microstructure tables, the figures, and report.md under --out."
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    pp = parser
    pp.add_argument(
        "--out",
        type=Path,
        default=Path("granpack-paper"),
        help="output folder (default: granpack-paper)",
    )
    pp.add_argument(
        "--packs",
        type=_args.packs,
        default=None,
        help=f"packs per case (default {PAPER_PACKS}, as in the paper; {QUICK_PACKS} with --quick)",
    )
    pp.add_argument(
        "--quick",
        action="store_true",
        help=f"{QUICK_PACKS} packs per case instead of {PAPER_PACKS} (same scenes and physics): "
        "a first look in a fifth of the time",
    )
    pp.add_argument(
        "--examples",
        nargs="+",
        choices=sorted(PAPER_EXAMPLES),
        default=sorted(PAPER_EXAMPLES),
        metavar="EX",
        help="examples to run (default: all of 4.1 4.2 4.3 4.4)",
    )
    pp.add_argument("--seed", type=_args.seed, default=0, help="master seed (default 0)")
    _args.add_run_options(pp)


def run(args: argparse.Namespace, console: Console) -> int:
    from ..paper import reproduce

    report = reproduce(
        args.out,
        quick=args.quick,
        packs=args.packs,
        examples=args.examples,
        seed=args.seed,
        workers=args.workers,
        scheduler=args.scheduler,
        write_on_workers=args.write_on_workers,
        fast=args.fast,
        settle_time=args.settle_time,
        scale=args.scale,
        quiet=console.quiet,
    )
    console.say(f"report: {report}")
    return 0
