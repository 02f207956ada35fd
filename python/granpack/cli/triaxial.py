"""``granpack triaxial``: a drained triaxial compression (biaxial in 2D) of a consolidated
pack, with its table, lab report and figure."""

from __future__ import annotations

import argparse
import inspect

from .._console import Console
from . import _element

HELP = "drained triaxial (2D: biaxial) compression of a consolidated pack"
DESCRIPTION = (
    "Moves the lid of a consolidated pack (granpack consolidate) down at a constant "
    "strain rate, given as an inertial number, while the side walls' servo holds the "
    "confining stress sigma_3 (or the one that keeps p constant), to --axial-strain. "
    "Writes the sheared pack (its history holds the test's record), the table of the "
    "path (CSV, one row per check), the lab report (JSON: friction and dilatancy "
    "angles, E_50) and the figure (PNG: q, eps_v and the fabric against eps_a); "
    "docs/element_tests.md defines each quantity."
)

#: The function's arguments and the options that give them, for the errors.
OPTIONS = {
    "confining": "--confining",
    "axial_strain": "--axial-strain",
    "inertial_number": "--inertial-number",
    "checks": "--checks",
    "wall_friction": "--wall-friction",
}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from ..element import triaxial

    # the function's defaults, one place for both
    d = {k: v.default for k, v in inspect.signature(triaxial).parameters.items()}
    p = parser
    _element.add_common(p, "triaxial", wall_friction=d["wall_friction"])
    p.add_argument(
        "--confining",
        type=float,
        default=None,
        metavar="PA",
        help="sigma_3, the side walls' stress (Pa; N/m in 2D) (default: the "
        "consolidation's lateral target; an oedometric sample needs it)",
    )
    p.add_argument(
        "--axial-strain",
        type=float,
        default=d["axial_strain"],
        metavar="X",
        help=f"the final axial strain (H0 - H)/H0, in (0, 1) (default {d['axial_strain']:g})",
    )
    p.add_argument(
        "--inertial-number",
        type=float,
        default=d["inertial_number"],
        metavar="I",
        help=f"the loading rate, in (0, 0.1] (default {d['inertial_number']:g}: quasi-static)",
    )
    p.add_argument(
        "--constant-p",
        action="store_true",
        help="hold the mean stress p at its start value instead of sigma_3",
    )
    p.add_argument(
        "--checks",
        type=int,
        default=d["checks"],
        metavar="N",
        help=f"rows of the table along the path, the start included (default {d['checks']})",
    )


def run(args: argparse.Namespace, console: Console) -> int:
    from ..element import triaxial

    return _element.run_test(
        args,
        console,
        "triaxial",
        lambda pack: triaxial(
            pack,
            args.confining,
            axial_strain=args.axial_strain,
            inertial_number=args.inertial_number,
            constant_p=args.constant_p,
            checks=args.checks,
            wall_friction=args.wall_friction,
        ),
        OPTIONS,
    )
