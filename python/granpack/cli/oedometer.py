"""``granpack oedometer``: oedometric loading and unloading of a consolidated pack, with
its table, lab report and figure."""

from __future__ import annotations

import argparse
import inspect

from .._console import Console
from . import _element

HELP = "oedometric loading and unloading of a consolidated pack"
DESCRIPTION = (
    "Takes the lid of a consolidated pack (granpack consolidate) through each of "
    "--stresses in turn with its servo, each held to equilibrium, the side walls fixed "
    "(a periodic cell keeps its periods). Writes the pack at the last stress (its "
    "history holds the test's record), the table (CSV: the sample at the start, then "
    "one row per stress), the lab report (JSON: Cc, Cs, K0) and the figure (PNG: e "
    "against log sigma_v); "
    "docs/element_tests.md defines each quantity."
)

#: The function's arguments and the options that give them, for the errors.
OPTIONS = {
    "stresses": "--stresses",
    "stress_tol": "--stress-tol",
    "unbalanced_tol": "--unbalanced-tol",
    "max_steps": "--max-steps",
    "wall_friction": "--wall-friction",
}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from .. import _core
    from ..element import oedometer

    c = _core.DEFAULT_CONSOLIDATE
    p = parser
    _element.add_common(
        p,
        "oedometer",
        wall_friction=inspect.signature(oedometer).parameters["wall_friction"].default,
    )
    p.add_argument(
        "--stresses",
        type=_element.stresses,
        required=True,
        metavar="LIST",
        help="the stresses (Pa; N/m in 2D) to hold in turn, separated by commas, e.g. "
        "25e3,50e3,100e3,200e3,100e3,50e3",
    )
    for option, key, kind in (
        ("--stress-tol", "stress_tol", float),
        ("--unbalanced-tol", "unbalanced_tol", float),
        ("--max-steps", "max_steps", int),
    ):
        p.add_argument(option, type=kind, default=c[key], help=f"per stress; default: {c[key]:g}")


def run(args: argparse.Namespace, console: Console) -> int:
    from ..element import oedometer

    return _element.run_test(
        args,
        console,
        "oedometer",
        lambda pack: oedometer(
            pack,
            args.stresses,
            stress_tol=args.stress_tol,
            unbalanced_tol=args.unbalanced_tol,
            max_steps=args.max_steps,
            wall_friction=args.wall_friction,
        ),
        OPTIONS,
    )
