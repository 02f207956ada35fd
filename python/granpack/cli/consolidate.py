"""``granpack consolidate``: a pack driven by servo walls to a target stress, in static
equilibrium (a sample for an element test)."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from .._console import Console
from .._outputs import say_removed
from .._validate import check_outputs
from ..history import stage_table

HELP = "consolidate a pack to a target stress with servo walls, until it is at rest"
DESCRIPTION = (
    "Closes the pack's container with a lid and moves the controlled walls with a servo "
    "until every controlled stress is within --stress-tol of its target and the "
    "unbalanced-force ratio is at most --unbalanced-tol, for --hold checks in a row. "
    "Modes: oedometric (the lid alone, K0), isotropic (the lid and the side walls), "
    "anisotropic (the lid at --stress, the side walls at --lateral). The stage's settings "
    "and the stress state it reached go into the new pack file's record."
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from .. import _core

    c = _core.DEFAULT_CONSOLIDATE
    p = parser
    p.add_argument("pack", type=Path, metavar="PACK", help="a pack file (.npz)")
    p.add_argument(
        "--stress", type=float, required=True, help="target stress on the lid, sigma_zz (Pa)"
    )
    p.add_argument(
        "--mode",
        choices=_core.CONSOLIDATION_MODES,
        default=c["mode"],
        help=f"default: {c['mode']}",
    )
    p.add_argument(
        "--lateral",
        type=float,
        nargs="+",
        default=None,
        metavar="SIGMA",
        help="anisotropic mode: the side walls' target (Pa): one value, or sigma_xx sigma_yy",
    )
    p.add_argument(
        "--gravity",
        choices=("on", "off"),
        default=None,
        help="gravity during the stage (default: off above 100 times the weight stress)",
    )
    for option, key, kind in (
        ("--stress-tol", "stress_tol", float),
        ("--unbalanced-tol", "unbalanced_tol", float),
        ("--max-steps", "max_steps", int),
    ):
        p.add_argument(option, type=kind, default=c[key], help=f"default: {c[key]:g}")
    p.add_argument(
        "--max-wall-speed",
        type=float,
        default=None,
        help="largest wall speed (m/s); default: quasi-static, inertial number 1e-3",
    )
    p.add_argument(
        "--out",
        type=Path,
        default=None,
        help="output pack file (default: <PACK stem>_consolidated.npz beside PACK)",
    )
    p.add_argument(
        "--target-phi",
        type=float,
        default=None,
        metavar="PHI",
        help="a density target, phi between the floor and the lid: the friction is lowered "
        "under the servo until it is reached, then restored (docs/density.md)",
    )
    p.add_argument(
        "--density-tol",
        type=float,
        default=_core.DEFAULT_DENSITY_TOL,
        help=f"default: {_core.DEFAULT_DENSITY_TOL:g}",
    )
    p.add_argument("-q", "--quiet", action="store_true", help="print nothing but errors")


def run(args: argparse.Namespace, console: Console) -> int:
    from .._files import remove_stale_temporaries
    from ..consolidation import consolidate
    from ..pack import load_pack

    out = args.out
    if out is None:
        out = args.pack.with_name(f"{args.pack.stem}_consolidated.npz")
    check_outputs([out], [args.pack], parameter="--out")
    t0 = time.perf_counter()
    pack = load_pack(args.pack)
    lateral = args.lateral
    if lateral is not None and len(lateral) == 1:
        lateral = lateral[0]
    done = consolidate(
        pack,
        args.stress,
        args.mode,
        lateral=lateral,
        gravity=None if args.gravity is None else args.gravity == "on",
        stress_tol=args.stress_tol,
        unbalanced_tol=args.unbalanced_tol,
        max_steps=args.max_steps,
        max_wall_speed=args.max_wall_speed,
        target_phi=args.target_phi,
        density_tol=args.density_tol,
    )
    path = done.save(out)  # atomic: a temporary file, then a rename
    r = stage_table(done, "consolidate")
    assert r is not None
    stresses = ", ".join(f"{n} {v:.6g}" for n, v in r["wall_stress"].items())
    console.say(
        f"{path}: {len(done)} particles, {r['mode']} to {args.stress:g} Pa in "
        f"{r['steps']} steps (dt {r['dt']:.3g} s, {time.perf_counter() - t0:.1f} s); "
        f"phi {r['phi']:.4f}, e {r['void_ratio']:.4f}, K0 {r['k0']:.3f}, unbalanced "
        f"{r['unbalanced']:.2e}; wall stresses (Pa): {stresses}"
    )
    say_removed(remove_stale_temporaries(path.parent, of=[path.name]), path.parent, console)
    return 0
