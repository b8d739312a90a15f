// Whether an MPI launcher started this process, for choices MPI libraries constrain: OpenBLAS's
// threads (factorization.cc) and forking children that mesh beside the process (modal_precompute.cc).
#pragma once

namespace modal_haptics
{
  // Whether mpirun (Open MPI), a PMI launcher (MPICH's Hydra) or PMIx (srun) started this process:
  // what they put in the environment before MPI_Init (true for mpirun -np 1 too), as it was when the
  // process started (MPI_Init itself adds to it).
  bool started_by_mpi_launcher();
} // namespace modal_haptics
