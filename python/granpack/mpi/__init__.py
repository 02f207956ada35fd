"""granpack's layer loop with LAMMPS as its DEM, over MPI: the contact law and setup
(`law`), the driver on every rank (`engine`) and the MPI job (`launch`); docs/mpi.md."""
