// One modal space computed by every process of an MPI communicator: a fully distributed mesh,
// Trilinos matrices, MUMPS (its own interface, symmetric; or Trilinos Amesos' LU) for the shift-invert
// factorization, and the serial path's block Krylov eigensolver over its block solves (PARPACK with
// 'Modes/Eigensolver = arpack'). It runs the same phases as compute_modal_space (modal_space.h) and returns the same
// ModalSpaceResult, complete on every process: what the serial exporters need is evaluated where a
// process owns the cell and summed over the processes (docs/cluster.md says what that costs).
#pragma once

#include "parameters/scene_parameters.h"
#include "results/space_result.h"
#include "scene/display_surface.h"

#include <deal.II/base/timer.h>

#include <deal.II/base/mpi.h>

namespace modal_haptics
{
  ModalSpaceResult compute_modal_space_distributed(const SceneParameters &scene,
                                                   const ContactSurface  &display,
                                                   const SpaceTask       &task,
                                                   const std::string     &vtu_file,
                                                   dealii::TimerOutput   &timer,
                                                   bool                   verbose,
                                                   MPI_Comm               comm);

  // A distributed space keeps only each process's own rows of the per-vertex and per-tet data
  // (ModalSpaceResult::owned_rows). What one file or the serial exporters take (a scenario job's
  // partial result, the serial path's space handed over to MUMPS) gets every row, in mesh order,
  // on process 0 (collective).
  void gather_rows_on_root(ModalSpaceResult &space, MPI_Comm comm);
} // namespace modal_haptics
