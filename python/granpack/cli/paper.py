"""``granpack paper``: the paper's section 4 reproduced, examples 4.1-4.4 with rotations
on and off."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from . import _args
from ._common import analyze_packs, locked, sweep_temporaries, unsettled_as_notes
from ._console import Console

#: The paper's examples and their figure numbers (rotations ON, OFF).
PAPER_EXAMPLES = {"4.1": (2, 3), "4.2": (4, 5), "4.3": (6, 7), "4.4": (8, 9)}
PAPER_PACKS = 10
QUICK_PACKS = 2

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


def _case_dir(example: str, rotations: bool) -> str:
    return f"{example}-{'on' if rotations else 'off'}"


def run(args: argparse.Namespace, console: Console) -> int:
    with locked(args.out):
        sweep_temporaries(args.out, console)
        return _paper_into(args, console)


def _paper_into(args, console: Console) -> int:
    from .. import mass2d, plot, report, tables
    from ..ensemble import ensemble_tasks, run_tasks
    from ..scene import PackScene

    n_packs = args.packs if args.packs is not None else (QUICK_PACKS if args.quick else PAPER_PACKS)
    out: Path = args.out
    examples = sorted(set(args.examples), key=list(PAPER_EXAMPLES).index)
    cases = [(ex, rot) for ex in examples for rot in (True, False)]

    scenes = {}
    for ex, rot in cases:
        base = PackScene.preset(ex).replace(rotations=rot, seed=args.seed, stream=0)
        dev = _args.dev_changes(base, args.settle_time, args.scale)
        scene = base.replace(**dev) if dev else base
        scenes[ex, rot] = scene.fast() if args.fast else scene
    tasks = []
    for (ex, rot), scene in scenes.items():
        label = f"{ex} {'ON' if rot else 'OFF'}"
        tasks += ensemble_tasks(
            scene, n_packs, out / "packs" / _case_dir(ex, rot), args.seed, label
        )

    # The 2D cases again under the other mass convention (docs/physics.md): cheap beside
    # the 3D cases, and the paper does not say which convention it used.
    other = mass2d.other_convention_tasks(scenes, n_packs, out / "packs", args.seed)
    other_tasks = [t for ts in other.values() for t in ts]

    t0 = time.perf_counter()
    console.say(
        f"granpack paper: examples {' '.join(examples)}, rotations ON and OFF, "
        f"{n_packs} pack(s) each ({len(tasks)} packs"
        + (f", and {len(other_tasks)} under the other 2D mass convention" if other_tasks else "")
        + f") -> {out}"
        + (" [quick: fewer packs than the paper's 10, same physics]" if args.quick else "")
    )
    with unsettled_as_notes(console):
        run_tasks(
            tasks + other_tasks,
            scheduler=args.scheduler,
            workers=args.workers,
            progress=console.progress_mode(),
        )
    t_packs = time.perf_counter() - t0

    console.say("microstructure, tables and figures ...")
    by_case: dict = {}
    records: dict = {}
    figures: dict = {}
    fig_dir = out / "figures"
    for ex, rot in cases:
        case_tasks = [t for t in tasks if t.path.parent.name == _case_dir(ex, rot)]
        paths = [t.path for t in case_tasks]
        results = analyze_packs(paths, out / "micro" / _case_dir(ex, rot), console)
        by_case[ex, rot] = [m for _, m, _ in results]
        records[ex, rot] = [rec for _, _, rec in results]
        packs = [p for p, _, _ in results]
        fig_no = PAPER_EXAMPLES[ex][0 if rot else 1]
        onoff = "ON" if rot else "OFF"
        name = f"fig{fig_no}_{ex}_{onoff.lower()}"
        f = {}
        f["packs"] = plot.save(
            plot.packs_figure(
                packs,
                title=f"Fig. {fig_no}: example {ex}, rotations {onoff} ({len(packs)} packs)",
                labels=[f"pack {k + 1}: phi = {p.phi:.3f}" for k, p in enumerate(packs)],
            ),
            fig_dir / f"{name}_packs.png",
        )
        if packs[0].dim == 3:
            f["view"] = plot.save(
                plot.pack_figure(packs[0], title=f"example {ex}, rotations {onoff}, pack 1"),
                fig_dir / f"{name}_pack1_view.png",
            )
        normals = np.concatenate([p.contacts.particle_pairs().normal for p in packs])
        f["normals"] = plot.save(
            plot.normals_figure(
                normals, title=f"example {ex}, rotations {onoff}: all {len(packs)} packs"
            ),
            fig_dir / f"{name}_normals.png",
        )
        f["forces"] = plot.save(
            plot.force_chain_figure(packs[0], title=f"example {ex}, rotations {onoff}, pack 1"),
            fig_dir / f"{name}_forces.png",
        )
        f["analysis"] = plot.save(
            plot.analysis_figure(
                packs, by_case[ex, rot], title=f"example {ex}, rotations {onoff}: structure"
            ),
            fig_dir / f"{name}_analysis.png",
        )
        figures[ex, rot] = f

    paper = tables.paper_tables(by_case)
    table_files = tables.write_tables(paper, out / "tables")

    ref_phi = paper_phi()
    other_phi = {
        (ex, rot): [
            rec["phi"]
            for _, _, rec in analyze_packs(
                [t.path for t in ts],
                out / "micro" / mass2d.case_dir(ex, rot, ts[0].scene.inertia_2d),
                console,
            )
        ]
        for (ex, rot), ts in other.items()
    }
    mass_2d = mass2d.convention_table(
        scenes, {c: [r["phi"] for r in records[c]] for c in other}, other_phi, ref_phi
    )
    if mass_2d.height:
        table_files += tables.write_tables({"mass_2d": mass_2d}, out / "tables")
    for ex in examples:
        ours = {
            f"rotations {'ON' if rot else 'OFF'}": [r["phi"] for r in records[ex, rot]]
            for rot in (True, False)
        }
        ref = {
            f"rotations {'ON' if rot else 'OFF'}": ref_phi[ex, rot]
            for rot in (True, False)
            if (ex, rot) in ref_phi
        }
        figures[ex, "phi"] = plot.save(
            plot.phi_histogram_figure(ours, ref, title=f"example {ex}: phi, ours vs the paper"),
            fig_dir / f"phi_{ex}.png",
        )

    rep = report.paper_report(
        out,
        examples=examples,
        n_packs=n_packs,
        quick=args.quick,
        records=records,
        paper_phi=ref_phi,
        table_files=table_files,
        figures=figures,
        wall_time=time.perf_counter() - t0,
        pack_time=t_packs,
        dev_changes=_args.dev_note(args.settle_time, args.scale),
        seed=args.seed,
        mass_2d=mass_2d,
    )
    console.say(f"report: {rep}")
    return 0


def paper_phi() -> dict[tuple[str, bool], list[float]]:
    """The paper's per-pack phi {(example, rotations): [10 values]} (its tables 2, 5, 8
    and 11, from `granpack.tables.paper_values`)."""
    import polars as pl

    from .. import tables

    out: dict[tuple[str, bool], list[float]] = {}
    for ex, (number, _, _) in tables.PRESET_TABLES.items():
        df = tables.paper_values(number).filter(~pl.col("pack").is_in(list(tables.STAT_LABELS)))
        for rot in (True, False):
            out[ex, rot] = [float(v) for v in df[f"rotations {'ON' if rot else 'OFF'}"]]
    return out
