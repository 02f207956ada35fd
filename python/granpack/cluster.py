"""Dask clusters on a batch system (SLURM or PBS) for ensembles of packs, by dask-jobqueue
(``pip install "granpack[cluster]"``).

`batch_cluster` builds a ``dask_jobqueue.SLURMCluster`` or ``PBSCluster`` whose batch jobs
each run `packs_per_job` Dask worker processes, one pack at a time each:

* a worker process has ``threads_per_pack`` Dask threads and the job books
  ``threads_per_pack * packs_per_job`` cores; the job's environment sets
  ``RAYON_NUM_THREADS = threads_per_pack``, so each pack's engine uses that many threads
  and the packs of one job do not oversubscribe its cores (Dask's threads only start the
  task; the engine's own threads do the work);
* ``MALLOC_ARENA_MAX=1``: glibc's one arena, which keeps a pack's resident memory near
  the live one (see ``granpack._malloc``), as the ``granpack`` command sets for itself;
* the memory per worker from the scene when given (`pack_memory`), so that Dask's
  memory monitor, which stops a worker past 95 % of its share, leaves the pack alone.

Nothing is submitted until ``cluster.scale(jobs=N)`` (or ``cluster.adapt(...)``);
``cluster.job_script()`` shows the script each job runs. Then run the ensemble with
``scheduler=cluster.scheduler_address`` and ``write_on_workers=True``: the workers that
made the packs write them on the cluster's shared file system (docs/ensembles.md, "On a
batch cluster")::

    from granpack.cluster import batch_cluster
    from granpack import generate_ensemble

    cluster = batch_cluster("slurm", scene=scene, threads_per_pack=4, walltime="04:00:00",
                            queue="compute", account="my-project")
    cluster.scale(jobs=10)
    generate_ensemble(scene, "/scratch/me/runs/4.3", packs=100,
                      scheduler=cluster.scheduler_address, write_on_workers=True)
    cluster.close()
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from typing import Any

from ._validate import GranpackError, InvalidParameterError, as_int
from .scene import PackScene

__all__ = ["batch_cluster", "pack_memory", "SYSTEMS", "BYTES_PER_PARTICLE_RESIDENT"]

#: The batch systems `batch_cluster` builds a cluster for, and dask-jobqueue's class.
SYSTEMS = {"slurm": "SLURMCluster", "pbs": "PBSCluster"}

#: Resident bytes per particle to book for a worker: the engine's peak resident set with
#: glibc's one arena is about 2.0 kB a particle (``granpack._malloc``), and half as much
#: again leaves room for the pack's arrays while it is saved.
BYTES_PER_PARTICLE_RESIDENT = 3000

#: Bytes a worker process takes before any pack: Python, numpy, polars, Dask's worker.
WORKER_BASE_BYTES = 1 << 30

_WALLTIME = re.compile(r"^(\d+-)?\d{1,3}(:\d{2}){0,2}$")


def pack_memory(scene: PackScene) -> int:
    """Bytes of memory to book for one worker process that makes packs of `scene`:
    `WORKER_BASE_BYTES` plus `BYTES_PER_PARTICLE_RESIDENT` per estimated particle
    (``scene.estimated_particles()``), rounded up to whole GiB."""
    if not isinstance(scene, PackScene):
        raise InvalidParameterError(
            f"invalid scene = {scene!r}: must be a granpack.PackScene", parameter="scene"
        )
    need = WORKER_BASE_BYTES + BYTES_PER_PARTICLE_RESIDENT * scene.estimated_particles()
    return math.ceil(need / 2**30) * 2**30


def batch_cluster(
    system: str = "slurm",
    *,
    scene: PackScene | None = None,
    memory_per_pack: str | int | None = None,
    threads_per_pack: int = 4,
    packs_per_job: int = 1,
    walltime: str = "04:00:00",
    queue: str | None = None,
    account: str | None = None,
    job_extra_directives: Sequence[str] = (),
    job_script_prologue: Sequence[str] = (),
    **kwargs: Any,
):
    """A dask-jobqueue cluster of batch jobs that make granpack packs, one pack per Dask
    worker process. Builds the cluster object and its scheduler (in this process); submits
    no job.

    Parameters
    ----------
    system : str
        "slurm" (``SLURMCluster``, sbatch) or "pbs" (``PBSCluster``, qsub). Default "slurm".
    scene : PackScene or None
        The scene of the packs, which sizes the memory (`pack_memory`) when
        `memory_per_pack` is not given. Default None.
    memory_per_pack : str, int or None
        Memory for one worker process (one pack at a time): bytes, or a size such as
        "8GiB". Default None: `pack_memory(scene)`; one of the two is needed.
    threads_per_pack : int
        The engine's threads for one pack (``RAYON_NUM_THREADS`` in the job's environment),
        and the cores booked per worker process, in [1, 1024]. Default 4.
    packs_per_job : int
        Worker processes (packs at a time) in one batch job, in [1, 1024]. Default 1. A job
        books ``threads_per_pack * packs_per_job`` cores and ``memory_per_pack *
        packs_per_job`` memory.
    walltime : str
        Each job's time limit, ``[D-]HH:MM:SS`` (SLURM's ``-t``, PBS's ``walltime``).
        Default "04:00:00". Give it room for the longest pack: a pack in progress when
        its job ends is made again by another worker.
    queue, account : str or None
        The partition or queue (``-p``, ``-q``) and the account to charge (``-A``).
        Default None: the batch system's defaults (or dask-jobqueue's configuration).
    job_extra_directives : sequence of str
        More directives for the job's header, without their prefix (e.g.
        ``["--constraint=haswell"]`` for SLURM, ``["-m abe"]`` for PBS). Default none.
    job_script_prologue : sequence of str
        Shell lines run before the worker starts (``module load ...``, ``source
        venv/bin/activate``), after granpack's own ``export`` lines. Default none.
    **kwargs
        Passed to dask-jobqueue's class (``python=``, ``interface=``,
        ``log_directory=``, ``scheduler_options=``, ...).

    Returns
    -------
    dask_jobqueue.SLURMCluster or dask_jobqueue.PBSCluster
        ``cluster.scale(jobs=N)`` submits N jobs; ``cluster.job_script()`` shows one.
    """
    if system not in SYSTEMS:
        raise InvalidParameterError(
            f"invalid system = {system!r}: choose among {', '.join(map(repr, SYSTEMS))}",
            parameter="system",
        )
    try:
        import dask_jobqueue
    except ImportError:
        raise GranpackError(
            "batch_cluster needs dask-jobqueue: pip install 'granpack[cluster]'"
        ) from None
    threads = as_int("threads_per_pack", threads_per_pack, 1, 1024)
    per_job = as_int("packs_per_job", packs_per_job, 1, 1024)
    if not isinstance(walltime, str) or not _WALLTIME.match(walltime):
        raise InvalidParameterError(
            f"invalid walltime = {walltime!r}: expected [D-]HH:MM:SS, e.g. '04:00:00'",
            parameter="walltime",
        )
    if memory_per_pack is None:
        if scene is None:
            raise InvalidParameterError(
                "invalid memory_per_pack = None without a scene: give memory_per_pack "
                "(e.g. '8GiB') or the scene, which sizes it",
                parameter="memory_per_pack",
            )
        per_pack = pack_memory(scene)
    else:
        per_pack = _bytes("memory_per_pack", memory_per_pack)
    for name, lines in (
        ("job_extra_directives", job_extra_directives),
        ("job_script_prologue", job_script_prologue),
    ):
        if isinstance(lines, str) or not all(isinstance(x, str) for x in lines):
            raise InvalidParameterError(
                f"invalid {name} = {lines!r}: must be a list of strings", parameter=name
            )
    cls = getattr(dask_jobqueue, SYSTEMS[system])
    prologue = [
        f"export RAYON_NUM_THREADS={threads}",
        "export MALLOC_ARENA_MAX=1",
        # numpy's BLAS, if threaded, would compete with the engine for the cores
        "export OMP_NUM_THREADS=1",
        *job_script_prologue,
    ]
    return cls(
        cores=threads * per_job,
        processes=per_job,
        memory=f"{math.ceil(per_pack * per_job / 2**20)}MiB",
        walltime=walltime,
        queue=queue,
        account=account,
        job_extra_directives=list(job_extra_directives),
        job_script_prologue=prologue,
        **kwargs,
    )


def _bytes(name: str, value: str | int) -> int:
    """A memory size: bytes (int) or a size Dask reads ("8GiB", "500MB")."""
    if isinstance(value, bool):
        value = str(value)
    if isinstance(value, int):
        n = value
    else:
        from dask.utils import parse_bytes

        try:
            n = int(parse_bytes(value))
        except (ValueError, TypeError, AttributeError):
            n = -1
    if n < 2**27:
        raise InvalidParameterError(
            f"invalid {name} = {value!r}: expected a memory size of at least 128 MiB, "
            "as bytes or a string such as '8GiB'",
            parameter=name,
        )
    return n
