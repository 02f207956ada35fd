"""`generate_ensemble`: an ensemble of packs of one scene written with everything made
of them (the packs, their microstructure, the tables, the pictures and report.md), as
``granpack generate`` writes it."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from ._console import Console
from ._outputs import analyze_packs, locked, sweep_temporaries, unsettled_as_notes
from ._validate import InvalidParameterError, as_int
from .generation import check_engine
from .scene import PackScene

__all__ = ["generate_ensemble"]


def generate_ensemble(
    scene: PackScene,
    out: str | Path,
    *,
    packs: int = 1,
    seed: int | None = None,
    name: str | None = None,
    figures: bool = True,
    workers: int | None = None,
    scheduler=None,
    write_on_workers: bool = False,
    dev_note: dict | None = None,
    quiet: bool = False,
    engine: str = "granpack",
    ranks: int = 1,
    mpiexec: str | None = None,
) -> Path:
    """Makes `packs` packs of `scene` (each by `granpack.generate`: the deposit, then the
    stages the scene lists) and writes under `out` each pack (``packs/``), its
    microstructure (``micro/``), the ensemble tables (``tables/``), the pictures
    (``figures/``), the resolved scene (``scene.toml``) and ``report.md``; returns the
    report's path. ``granpack generate`` is this function.

    A second call with the same arguments skips the packs already there. One run at a
    time writes into `out`: a second one is refused while the first holds the folder's
    lock.

    Parameters
    ----------
    scene : PackScene
    out : str or Path
        Output folder; created if needed.
    packs : int
        Ensemble size, in [1, `granpack.ensemble.MAX_PACKS`]. Default 1.
    seed : int or None
        Master seed in [0, 2^64 - 1]; pack k uses its random stream k. Default None: the
        scene's seed. The scene's own stream is not used (a note says so where it is
        not 0).
    name : str or None
        The scene's name in the report and the pictures. Default None: the folder's.
    figures : bool
        Default True. False skips the pictures.
    workers : int or None
        Local worker processes; default None: one per core (with the LAMMPS engine, one
        per `ranks` cores).
    scheduler : str, distributed.Client or None
        Address of a Dask distributed scheduler (``tcp://host:8786``), or a client of
        one (such as `granpack.cluster.batch_cluster`'s); default None.
    write_on_workers : bool
        Only with `scheduler`. Default False: the packs travel back and this process
        saves them. True: each Dask worker saves its pack under ``out/packs`` itself and
        sends back a few numbers; `out` must be on a file system the workers share.
    dev_note : dict or None
        The development options that changed the scene, as the report flags them
        (option: what it did). Default None: none.
    quiet : bool
        Default False. True prints nothing but errors; otherwise progress and notes go to
        stderr, the run's summary lines to stdout.
    engine, ranks, mpiexec
        The DEM of every pack's layer loop, as `granpack.generate` takes them: granpack's
        engine (default), or ``engine="lammps"`` on `ranks` MPI ranks a pack.

    Returns
    -------
    Path
        ``out/report.md``.
    """
    from .ensemble import MAX_PACKS, check_write_on_workers

    if not isinstance(scene, PackScene):
        raise InvalidParameterError(
            f"invalid scene = {scene!r}: must be a granpack.PackScene", parameter="scene"
        )
    out = Path(out)
    packs = as_int("packs", packs, 1, MAX_PACKS)
    seed = scene.seed if seed is None else as_int("seed", seed, 0, 2**64 - 1)
    name = out.name if name is None else name
    check_write_on_workers(write_on_workers, scheduler)
    check_engine(scene, engine, ranks, mpiexec)
    engine_kw = {} if engine == "granpack" else dict(engine=engine, ranks=ranks, mpiexec=mpiexec)
    console = Console(quiet)
    if scene.stream != 0:
        # An ensemble numbers its packs' streams itself: the scene's is replaced, said.
        console.note(
            f"the scene's stream = {scene.stream} is not used: pack k of the ensemble takes "
            "stream k (0, 1, ...) of the master seed; to vary the packs, give --seed",
            name,
        )
        console.flush_notes()
    scene = scene.replace(seed=seed, stream=0)
    with locked(out):
        sweep_temporaries(out, console)
        return _generate_into(
            console,
            scene,
            name,
            seed,
            out,
            packs,
            figures,
            workers,
            scheduler,
            write_on_workers,
            dev_note,
            engine_kw,
        )


def _generate_into(
    console: Console,
    scene: PackScene,
    name: str,
    seed: int,
    out: Path,
    packs: int,
    figures: bool,
    workers: int | None,
    scheduler,
    write_on_workers: bool,
    dev_note: dict | None,
    engine: dict,
) -> Path:
    from . import plot, report, tables
    from ._files import atomic_write
    from .ensemble import ensemble_tasks, run_tasks

    scene_text = scene.to_toml().encode()
    scene_file = out / "scene.toml"
    t0 = time.perf_counter()
    tasks = ensemble_tasks(scene, packs, out / "packs", seed, engine=engine)
    console.say(f"granpack generate: {packs} pack(s) of {name} -> {out}")
    with unsettled_as_notes(console):
        paths = run_tasks(
            tasks,
            scheduler=scheduler,
            workers=workers,
            progress=console.progress_mode(),
            write_on_workers=write_on_workers,
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

    made: list[Path] = []
    if figures:
        fig_dir = out / "figures"
        for (pack, _, _), path in zip(results, paths, strict=True):
            label = f"{name}, rotations {'ON' if scene.rotations else 'OFF'}, {path.stem}"
            made += _pack_figures(pack, path, fig_dir, label)
        made.append(
            plot.save(
                plot.analysis_figure([p for p, _, _ in results], ms, title=f"{name}: structure"),
                fig_dir / "analysis.png",
            )
        )
        phis = [rec["phi"] for rec in records]
        made.append(
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
        figures=made,
        wall_time=time.perf_counter() - t0,
        dev_changes=dev_note or {},
    )
    phi = np.array([rec["phi"] for rec in records])
    sd = f" ± {phi.std(ddof=1):.4f}" if phi.size > 1 else ""
    console.say(f"phi = {phi.mean():.4f}{sd} over {phi.size} pack(s)")
    return Path(rep)


def _fresh(target: Path, source: Path) -> bool:
    """True if `target` exists and is not older than `source` (work to skip on rerun)."""
    return target.exists() and target.stat().st_mtime >= source.stat().st_mtime


def _pack_figures(pack, path: Path, fig_dir: Path, label: str) -> list[Path]:
    """pack_k.png, normals_k.png, forces_k.png for one pack (skipped when newer than
    the pack file)."""
    from . import plot

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
