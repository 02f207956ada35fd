"""The layer loop on LAMMPS over MPI: its contact law, setup and driver."""
