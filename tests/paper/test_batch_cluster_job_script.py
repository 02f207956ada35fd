"""`granpack.cluster.batch_cluster`: the SLURM and PBS job scripts it sets up (cores,
memory, walltime, the engine's thread count), read from dask-jobqueue's own
``job_script()``. Nothing is submitted."""

from __future__ import annotations

import re

import pytest

import granpack as gp
from granpack.cluster import (
    BYTES_PER_PARTICLE_RESIDENT,
    WORKER_BASE_BYTES,
    batch_cluster,
    pack_memory,
)

pytest.importorskip("dask_jobqueue")

#: The cluster's scheduler starts in this process: its web server on a free port, so that
#: it never meets another one on the default 8787.
QUIET = {"scheduler_options": {"dashboard_address": ":0"}}


def _script(system: str, **kw) -> str:
    cluster = batch_cluster(system, **kw, **QUIET)
    try:
        return cluster.job_script()
    finally:
        cluster.close()


def test_slurm_job_books_threads_times_packs_cores_and_sets_the_engine_threads():
    text = _script(
        "slurm",
        memory_per_pack="3GiB",
        threads_per_pack=4,
        packs_per_job=2,
        walltime="02:30:00",
        queue="compute",
        account="soil-lab",
        job_extra_directives=["--constraint=haswell"],
        job_script_prologue=["module load python/3.12"],
    )
    lines = text.splitlines()
    assert "#SBATCH --cpus-per-task=8" in lines  # 4 threads x 2 packs
    assert "#SBATCH --mem=6G" in lines  # 3 GiB x 2 packs
    assert "#SBATCH -t 02:30:00" in lines
    assert "#SBATCH -p compute" in lines and "#SBATCH -A soil-lab" in lines
    assert "#SBATCH --constraint=haswell" in lines
    # the engine's threads per pack, set before the worker starts, then the user's lines
    exports = [ln for ln in lines if ln.startswith(("export ", "module "))]
    assert exports == [
        "export RAYON_NUM_THREADS=4",
        "export MALLOC_ARENA_MAX=1",
        "export OMP_NUM_THREADS=1",
        "module load python/3.12",
    ]
    worker = lines[-1]
    assert lines.index(exports[-1]) < len(lines) - 1
    # one pack per worker process: 2 processes of 4 Dask threads, 3 GiB each
    assert "distributed.cli.dask_worker" in worker
    assert re.search(r"--nworkers 2\b", worker) and re.search(r"--nthreads 4\b", worker)
    assert "--memory-limit 3.00GiB" in worker


def test_pbs_job_books_the_same_resources():
    text = _script("pbs", memory_per_pack="6GiB", threads_per_pack=8, walltime="12:00:00")
    lines = text.splitlines()
    assert "#PBS -l select=1:ncpus=8:mem=6144MB" in lines
    assert "#PBS -l walltime=12:00:00" in lines
    assert "export RAYON_NUM_THREADS=8" in lines
    assert re.search(r"--nthreads 8\b", lines[-1]) and "--nworkers" not in lines[-1]
    assert "--memory-limit 6.00GiB" in lines[-1]


def test_memory_from_the_scene_covers_its_particles():
    # 4.3 on a 4 m x 4 m base, 2 m high: about 358 000 spheres, 1.07e9 bytes at 3 kB
    # each, on top of the worker's 1 GiB: 3 GiB booked
    scene = gp.PackScene.preset("4.3").replace(base=(4.0, 4.0), height=2.0)
    n = scene.estimated_particles()
    need = WORKER_BASE_BYTES + BYTES_PER_PARTICLE_RESIDENT * n
    booked = pack_memory(scene)
    assert booked % 2**30 == 0 and need <= booked < need + 2**30
    assert 3.5e5 < n < 3.7e5 and booked == 3 * 2**30
    text = _script("slurm", scene=scene, threads_per_pack=2)
    assert f"#SBATCH --mem={booked // 2**30}G" in text.splitlines()
    assert f"--memory-limit {booked / 2**30:.2f}GiB" in text


@pytest.mark.parametrize(
    ("kw", "parameter"),
    [
        ({"system": "sge", "memory_per_pack": "4GiB"}, "system"),
        ({"memory_per_pack": None}, "memory_per_pack"),
        ({"memory_per_pack": "lots"}, "memory_per_pack"),
        ({"memory_per_pack": 1000}, "memory_per_pack"),
        ({"memory_per_pack": "4GiB", "threads_per_pack": 0}, "threads_per_pack"),
        ({"memory_per_pack": "4GiB", "packs_per_job": 2.5}, "packs_per_job"),
        ({"memory_per_pack": "4GiB", "walltime": "4h"}, "walltime"),
        (
            {"memory_per_pack": "4GiB", "job_script_prologue": "module load x"},
            "job_script_prologue",
        ),
        ({"scene": "4.3"}, "scene"),
    ],
)
def test_bad_settings_are_clear_errors(kw, parameter):
    with pytest.raises(gp.InvalidParameterError, match=f"invalid {parameter}") as err:
        batch_cluster(**kw, **QUIET)
    assert err.value.parameter == parameter
