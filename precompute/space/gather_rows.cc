// gather_rows_on_root (distributed_space.h): a distributed space's rows of the per-vertex and
// per-tet data, each process's own, gathered on process 0 in mesh order.
#include "space/distributed_space.h"

#include <deal.II/base/mpi.h>

#include <algorithm>
#include <vector>

namespace modal_haptics
{
  void gather_rows_on_root(ModalSpaceResult &space, const MPI_Comm comm)
  {
    if (!space.owned_rows)
      return;
    const auto vertices    = dealii::Utilities::MPI::gather(comm, space.owned_rows->vertices);
    const auto coordinates = dealii::Utilities::MPI::gather(comm, space.mesh_vertices);
    const auto modes       = dealii::Utilities::MPI::gather(comm, space.modes_at_vertices);
    const auto tets        = dealii::Utilities::MPI::gather(comm, space.owned_rows->tets);
    const auto tet_rows    = dealii::Utilities::MPI::gather(comm, space.mesh_tets);
    space.owned_rows.reset();
    if (dealii::Utilities::MPI::this_mpi_process(comm) != 0)
      return;
    const std::size_t r = space.eigenvalues.size(), nv = space.n_vertices;
    space.mesh_vertices.assign(3 * nv, 0.);
    space.modes_at_vertices.assign(r * nv * 3, 0.);
    space.mesh_tets.assign(4 * std::size_t(space.n_cells), 0);
    for (std::size_t p = 0; p < vertices.size(); ++p)
      {
        const std::size_t owned = vertices[p].size();
        for (std::size_t k = 0; k < owned; ++k)
          for (unsigned int c = 0; c < 3; ++c)
            {
              const std::size_t v = vertices[p][k];
              space.mesh_vertices[3 * v + c] = coordinates[p][3 * k + c];
              for (std::size_t i = 0; i < r; ++i)
                space.modes_at_vertices[(i * nv + v) * 3 + c] = modes[p][(i * owned + k) * 3 + c];
            }
        for (std::size_t k = 0; k < tets[p].size(); ++k)
          std::copy_n(&tet_rows[p][4 * k], 4, &space.mesh_tets[4 * std::size_t(tets[p][k])]);
      }
  }
} // namespace modal_haptics
