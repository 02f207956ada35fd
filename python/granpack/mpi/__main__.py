"""``mpiexec -n N python -m granpack.mpi SCENE.toml PACK.npz``: the LAMMPS deposit as an
MPI job (`granpack.mpi.launch.job_main`)."""

import sys

from .launch import job_main

sys.exit(job_main(sys.argv[1:]))
