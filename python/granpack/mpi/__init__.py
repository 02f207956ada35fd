"""granpack's layer loop with LAMMPS as its DEM, over MPI (docs/mpi.md)."""
