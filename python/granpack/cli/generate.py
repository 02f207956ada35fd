"""``granpack generate``: an ensemble of packs of one scene, with its microstructure,
tables, pictures and report."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from .. import _core
from .._console import Console
from .._outputs import (
    analyze_packs,
    dev_changes,
    dev_note,
    locked,
    refuse_scene_among_outputs,
    same_file,
    sweep_temporaries,
    unsettled_as_notes,
)
from .._validate import GranpackError, InvalidParameterError
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
    if scene.stream != 0:
        # An ensemble numbers its packs' streams itself: the scene's is replaced, said.
        console.note(
            f"the scene's stream = {scene.stream} is not used: pack k of the ensemble takes "
            "stream k (0, 1, ...) of the master seed; to vary the packs, give --seed",
            name,
        )
        console.flush_notes()
    scene = scene.replace(seed=seed, stream=0)
    out = args.out if args.out is not None else Path(f"granpack-{name}")
    scene_text = scene.to_toml().encode()
    scene_file = out / "scene.toml"
    # The resolved scene goes to out/scene.toml: when that is the scene file given (a
    # rerun from the folder's own record), it is rewritten only if unchanged.
    source = Path(args.scene)
    if same_file(scene_file, source) and source.read_bytes() != scene_text:
        raise InvalidParameterError(
            f"invalid --out = {str(out)!r}: it would overwrite the scene file {source} with "
            "the resolved scene (out/scene.toml); choose another --out",
            parameter="out",
            value=str(out),
            expected="a folder whose scene.toml is not the scene file given",
        )
    refuse_scene_among_outputs(source, out)
    with locked(out):
        sweep_temporaries(out, console)
        return _generate_into(args, console, scene, name, seed, out, scene_file, scene_text)


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


def _generate_into(args, console, scene, name, seed, out, scene_file, scene_text) -> int:
    from .. import plot, report, tables
    from ..ensemble import ensemble_tasks, run_tasks
    from ..pack import atomic_write

    t0 = time.perf_counter()
    tasks = ensemble_tasks(scene, args.packs, out / "packs", seed)
    console.say(f"granpack generate: {args.packs} pack(s) of {name} -> {out}")
    with unsettled_as_notes(console):
        paths = run_tasks(
            tasks, scheduler=args.scheduler, workers=args.workers, progress=console.progress_mode()
        )
    # Written once the packs are there: a refused run (another scene's packs in the
    # folder) leaves the folder's scene.toml as it was.
    if not (scene_file.exists() and scene_file.read_bytes() == scene_text):
        atomic_write(scene_file, scene_text)
    results = analyze_packs(paths, out / "micro", console)
    ms = [m for _, m, _ in results]
    records = [rec for _, _, rec in results]

    df = tables.ensemble_table(ms)
    numeric = [c for c, t in zip(df.columns, df.dtypes, strict=True) if t.is_numeric()]
    summary = tables.summary(df, [c for c in numeric if c != "pack"])
    table_files = tables.write_tables({"ensemble": df, "summary": summary}, out / "tables")

    figures: list[Path] = []
    if not args.no_figures:
        fig_dir = out / "figures"
        for (pack, _, _), path in zip(results, paths, strict=True):
            label = f"{name}, rotations {'ON' if scene.rotations else 'OFF'}, {path.stem}"
            figures += _pack_figures(pack, path, fig_dir, label)
        figures.append(
            plot.save(
                plot.analysis_figure([p for p, _, _ in results], ms, title=f"{name}: structure"),
                fig_dir / "analysis.png",
            )
        )
        phis = [rec["phi"] for rec in records]
        figures.append(
            plot.save(
                plot.phi_histogram_figure(
                    {f"rotations {'ON' if scene.rotations else 'OFF'}": phis},
                    title=f"{name}: phi over {len(phis)} pack(s)",
                ),
                fig_dir / "phi_histogram.png",
            )
        )
    rep = report.ensemble_report(
        out,
        scene_name=name,
        scene=scene,
        records=records,
        table_files=table_files,
        figures=figures,
        wall_time=time.perf_counter() - t0,
        dev_changes=dev_note(args.settle_time, args.scale),
    )
    phi = np.array([rec["phi"] for rec in records])
    sd = f" ± {phi.std(ddof=1):.4f}" if phi.size > 1 else ""
    console.say(f"phi = {phi.mean():.4f}{sd} over {phi.size} pack(s)")
    console.say(f"report: {rep}")
    return 0


def _fresh(target: Path, source: Path) -> bool:
    """True if `target` exists and is not older than `source` (work to skip on rerun)."""
    return target.exists() and target.stat().st_mtime >= source.stat().st_mtime


def _pack_figures(pack, path: Path, fig_dir: Path, label: str) -> list[Path]:
    """pack_k.png, normals_k.png, forces_k.png for one pack (skipped when newer than
    the pack file)."""
    from .. import plot

    stem = path.stem
    made = []
    jobs = [
        (fig_dir / f"{stem}.png", lambda: plot.pack_figure(pack, title=label)),
        (
            fig_dir / f"{stem}_normals.png",
            lambda: plot.normals_figure(pack.contacts.particle_pairs().normal, title=label),
        ),
        (fig_dir / f"{stem}_forces.png", lambda: plot.force_chain_figure(pack, title=label)),
    ]
    for target, build in jobs:
        if not _fresh(target, path):
            plot.save(build(), target)
        made.append(target)
    return made
