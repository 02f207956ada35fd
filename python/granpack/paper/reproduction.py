"""`reproduce`: the paper's section 4 (examples 4.1-4.4, rotations ON and OFF), its
tables 2-13 with the paper's numbers beside ours, the figures, the 2D mass conventions
and ``report.md``, as ``granpack paper`` makes them."""

from __future__ import annotations

import time
from collections.abc import Iterable
from pathlib import Path

import numpy as np

from .._console import Console
from .._outputs import (
    RUN_FILES,
    analyze_packs,
    dev_changes,
    dev_note,
    locked,
    sweep_temporaries,
    unsettled_as_notes,
)
from .._validate import InvalidParameterError, as_int, as_real, check_outputs

__all__ = ["reproduce", "paper_phi", "PAPER_EXAMPLES", "PAPER_PACKS", "QUICK_PACKS"]

PAPER_EXAMPLES = {"4.1": (2, 3), "4.2": (4, 5), "4.3": (6, 7), "4.4": (8, 9)}
"""The paper's examples and the numbers of their figures (rotations ON, OFF)."""
PAPER_PACKS = 10
"""Packs per case in the paper."""
QUICK_PACKS = 2
"""Packs per case of a quick run (``quick=True``, ``granpack paper --quick``)."""


def reproduce(
    out: str | Path,
    *,
    quick: bool = False,
    packs: int | None = None,
    examples: Iterable[str] | None = None,
    seed: int = 0,
    workers: int | None = None,
    scheduler: str | None = None,
    write_on_workers: bool = False,
    fast: bool = False,
    settle_time: float | None = None,
    scale: float | None = None,
    quiet: bool = False,
) -> Path:
    """Runs the paper's examples with rotations ON and OFF and writes everything under
    `out`; returns the path of ``out/report.md``. ``granpack paper`` is this function.

    Every finished pack is on disk at once, and a second call with the same arguments
    skips the packs already there (a quick run's packs are the first ones of the full
    run). One run at a time writes into `out`: a second one is refused while the first
    holds the folder's lock.

    Parameters
    ----------
    out : str or Path
        Output folder: ``packs/``, ``micro/``, ``tables/``, ``figures/`` and
        ``report.md``; created if needed.
    quick : bool
        Default False. `QUICK_PACKS` (2) packs per case instead of the paper's
        `PAPER_PACKS` (10), same scenes and physics.
    packs : int or None
        Packs per case in [1, 100 000]; default None: 10, or 2 when `quick`.
    examples : str, iterable of str or None
        Among "4.1", "4.2", "4.3", "4.4"; default None: all four.
    seed : int
        Master seed in [0, 2^64 - 1], default 0; pack k of each case uses random
        stream k.
    workers : int or None
        Local worker processes; default None: one per core.
    scheduler : str or None
        Address of a Dask distributed scheduler (``tcp://host:8786``) to run the packs
        on instead of local processes (needs ``granpack[dask]``); default None.
    write_on_workers : bool
        Only with `scheduler`. Default False: the packs travel back and this process
        saves them. True: each Dask worker saves its pack under ``out/packs`` itself;
        `out` must be on a file system the workers share.
    fast : bool
        Default False. Runs ``PackScene.fast()`` of each scene (docs/performance.md, "The fast
        settings").
    settle_time, scale : float or None
        Development options, not the paper's physics: seconds of jamming per layer, and
        a factor on the base and the height. The report flags them. Default None.
    quiet : bool
        Default False. True prints nothing but errors; otherwise progress and notes go to
        stderr, the run's summary lines to stdout.

    Returns
    -------
    Path
        ``out/report.md``.
    """
    out = Path(out)
    if examples is None:
        examples = sorted(PAPER_EXAMPLES)
    examples = [examples] if isinstance(examples, str) else list(examples)
    unknown = [ex for ex in examples if ex not in PAPER_EXAMPLES]
    if unknown or not examples:
        raise InvalidParameterError(
            f"invalid examples = {unknown or examples!r}: choose among {', '.join(PAPER_EXAMPLES)}",
            parameter="examples",
            value=examples,
            expected=", ".join(PAPER_EXAMPLES),
        )
    if packs is not None:
        from ..ensemble import MAX_PACKS

        packs = as_int("packs", packs, 1, MAX_PACKS)
    seed = as_int("seed", seed, 0, 2**64 - 1)
    if settle_time is not None:
        settle_time = as_real("settle_time", settle_time, 0.0, lo_open=True, unit="s")
    if scale is not None:
        scale = as_real("scale", scale, 0.0, lo_open=True)
    n_packs = packs if packs is not None else (QUICK_PACKS if quick else PAPER_PACKS)
    from ..ensemble import check_write_on_workers

    check_write_on_workers(write_on_workers, scheduler)
    examples = sorted(set(examples), key=list(PAPER_EXAMPLES).index)
    console = Console(quiet)
    check_outputs([out / f for f in RUN_FILES], [], "--out")  # a folder it cannot write
    with locked(out):
        sweep_temporaries(out, console)
        return _reproduce_into(
            out,
            console,
            examples=examples,
            n_packs=n_packs,
            quick=quick,
            seed=seed,
            workers=workers,
            scheduler=scheduler,
            write_on_workers=write_on_workers,
            fast=fast,
            settle_time=settle_time,
            scale=scale,
        )


def _case_dir(example: str, rotations: bool) -> str:
    return f"{example}-{'on' if rotations else 'off'}"


def _reproduce_into(
    out: Path,
    console: Console,
    *,
    examples: list[str],
    n_packs: int,
    quick: bool,
    seed: int,
    workers: int | None,
    scheduler: str | None,
    write_on_workers: bool,
    fast: bool,
    settle_time: float | None,
    scale: float | None,
) -> Path:
    from .. import plot, tables
    from ..ensemble import ensemble_tasks, run_tasks
    from ..scene import PackScene
    from . import mass2d, report

    cases = [(ex, rot) for ex in examples for rot in (True, False)]

    scenes = {}
    for ex, rot in cases:
        base = PackScene.preset(ex).replace(rotations=rot, seed=seed, stream=0)
        dev = dev_changes(base, settle_time, scale)
        scene = base.replace(**dev) if dev else base
        scenes[ex, rot] = scene.fast() if fast else scene
    tasks = []
    for (ex, rot), scene in scenes.items():
        label = f"{ex} {'ON' if rot else 'OFF'}"
        tasks += ensemble_tasks(scene, n_packs, out / "packs" / _case_dir(ex, rot), seed, label)

    # The 2D cases again under the other mass convention (docs/physics.md): cheap beside
    # the 3D cases, and the paper does not say which convention it used.
    other = mass2d.other_convention_tasks(scenes, n_packs, out / "packs", seed)
    other_tasks = [t for ts in other.values() for t in ts]

    t0 = time.perf_counter()
    console.say(
        f"granpack paper: examples {' '.join(examples)}, rotations ON and OFF, "
        f"{n_packs} pack(s) each ({len(tasks)} packs"
        + (f", and {len(other_tasks)} under the other 2D mass convention" if other_tasks else "")
        + f") -> {out}"
        + (" [quick: fewer packs than the paper's 10, same physics]" if quick else "")
    )
    with unsettled_as_notes(console):
        run_tasks(
            tasks + other_tasks,
            scheduler=scheduler,
            workers=workers,
            progress=console.progress_mode(),
            write_on_workers=write_on_workers,
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
        quick=quick,
        records=records,
        paper_phi=ref_phi,
        table_files=table_files,
        figures=figures,
        wall_time=time.perf_counter() - t0,
        pack_time=t_packs,
        dev_changes=dev_note(settle_time, scale),
        seed=seed,
        mass_2d=mass_2d,
    )
    return rep


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
