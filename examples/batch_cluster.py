"""An ensemble on a SLURM or PBS batch cluster through Dask (dask-jobqueue), each worker
writing the packs it made into the shared output folder.

    pip install "granpack[cluster]"
    python examples/batch_cluster.py [OUTPUT_FOLDER] [slurm | pbs | local]

Run it on the cluster's login node, with OUTPUT_FOLDER on the shared file system. The
batch system defaults to slurm where ``sbatch`` is on the PATH, pbs where ``qsub`` is,
and else "local": two worker processes on this machine stand in for the batch jobs, to
try the recipe anywhere (the job script that SLURM would run is printed all the same).
Writes the packs (``packs/``), their microstructure, tables and report.md into
OUTPUT_FOLDER (default: a new temporary folder); a second run skips the packs there.
"""

import shutil
import sys
import tempfile
from pathlib import Path

import numpy as np

import granpack as gp
from granpack.cluster import batch_cluster

PACKS = 3

# A small 2D pack of the paper's 4.1 so that the recipe runs in seconds; on a cluster,
# your scene (e.g. gp.PackScene.preset("4.3").fast()) and a hundred packs.
SCENE = gp.PackScene.preset("4.1").replace(base=(0.4,), height=0.25, settle_time=1.0)

# Each job: 2 packs at a time, 4 engine threads each (8 cores booked), 4 hours at most.
SETTINGS = dict(scene=SCENE, threads_per_pack=4, packs_per_job=2, walltime="04:00:00")
# Your site's settings go here, e.g. queue="compute", account="my-project",
# job_script_prologue=["source /home/me/granpack-env/bin/activate"].


def main() -> None:
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(tempfile.mkdtemp(prefix="granpack-"))
    if len(sys.argv) > 2:
        system = sys.argv[2]
    else:
        system = "slurm" if shutil.which("sbatch") else "pbs" if shutil.which("qsub") else "local"

    if system == "local":
        from distributed import LocalCluster

        # what each SLURM job would run (printing it submits nothing)
        shown = batch_cluster("slurm", **SETTINGS, scheduler_options={"dashboard_address": ":0"})
        print(shown.job_script())
        shown.close()
        cluster = LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0"
        )
    else:
        cluster = batch_cluster(system, **SETTINGS)
        print(cluster.job_script())
        cluster.scale(jobs=2)  # or cluster.adapt(minimum_jobs=0, maximum_jobs=10)

    with cluster:
        gp.generate_ensemble(
            SCENE,
            out,
            packs=PACKS,
            figures=False,
            scheduler=cluster.scheduler_address,
            write_on_workers=True,  # the workers write out/packs/pack_k.npz themselves
        )

    phi = np.array([gp.load_pack(p).phi for p in sorted((out / "packs").glob("pack_*.npz"))])
    print(
        f"{phi.size} packs written by the workers, phi = {phi.mean():.4f} ± {phi.std(ddof=1):.4f}"
    )


if __name__ == "__main__":  # the local worker processes import this file again
    main()
