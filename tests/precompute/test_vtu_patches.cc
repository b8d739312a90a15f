// The VTU of the mode shapes written from patches read at the DoFs (VtuOutput::build_patches_at_nodes,
// precompute/space/space_phases.h) is byte for byte the one deal.II's DataOut::build_patches(mapping,
// degree) makes, on a distorted tet mesh whose cells lie both inside and at the boundary, for P1 and
// P2 and three vector fields of random values (one with entries -0, as a mode flipped in sign has
// where it is clamped).
#include "checks.h"
#include "space/phase_output.h"

#include <deal.II/dofs/dof_handler.h>
#include <deal.II/fe/fe_simplex_p.h>
#include <deal.II/fe/fe_system.h>
#include <deal.II/fe/mapping_fe.h>
#include <deal.II/grid/grid_generator.h>
#include <deal.II/grid/grid_tools.h>
#include <deal.II/grid/tria.h>
#include <deal.II/lac/vector.h>
#include <deal.II/numerics/data_out.h>

#include <random>
#include <sstream>
#include <string>
#include <vector>

using namespace dealii;
using modal_haptics::testing::check;

namespace
{
  // Both files, written alike, from the fields on a mesh of degree-'degree' elements.
  std::pair<std::string, std::string> both_vtu(const Triangulation<3> &mesh, const unsigned int degree)
  {
    const FESystem<3>   fe(FE_SimplexP<3>(degree), 3);
    const MappingFE<3>  mapping(FE_SimplexP<3>(1));
    DoFHandler<3>       dof_handler(mesh);
    dof_handler.distribute_dofs(fe);
    std::mt19937                           random(degree);
    std::uniform_real_distribution<double> uniform(-1., 1.);
    std::vector<Vector<double>>            fields(3, Vector<double>(dof_handler.n_dofs()));
    for (auto &field : fields)
      for (auto &x : field)
        x = uniform(random);
    for (types::global_dof_index i = 0; i < dof_handler.n_dofs(); i += 7)
      fields[0][i] = -0.; // a mode flipped in sign has -0 where it was clamped
    const std::vector<DataComponentInterpretation::DataComponentInterpretation> vector_field(
      3, DataComponentInterpretation::component_is_part_of_vector);
    DataOutBase::VtkFlags flags;
    flags.compression_level = DataOutBase::VtkFlags::no_compression;

    std::ostringstream by_deal_ii, at_nodes;
    for (const bool ours : {false, true})
      {
        modal_haptics::space_phases::VtuOutput data_out;
        data_out.attach_dof_handler(dof_handler);
        std::vector<const Vector<double> *> added;
        for (unsigned int f = 0; f < fields.size(); ++f)
          {
            data_out.add_data_vector(fields[f], std::vector<std::string>(3, "field_" + std::to_string(f)),
                                     DataOut<3>::type_dof_data, vector_field);
            added.push_back(&fields[f]);
          }
        if (ours)
          data_out.build_patches_at_nodes(dof_handler, added);
        else
          data_out.build_patches(mapping, degree);
        data_out.set_vtk_flags(flags);
        data_out.take_patches()->write(ours ? at_nodes : by_deal_ii);
      }
    return {by_deal_ii.str(), at_nodes.str()};
  }
} // namespace

int main()
{
  Triangulation<3> mesh;
  GridGenerator::subdivided_hyper_cube_with_simplices(mesh, 3, -0.2, 1.3);
  GridTools::distort_random(0.2, mesh, /*keep_boundary*/ false);
  unsigned int inside = 0, at_boundary = 0;
  for (const auto &cell : mesh.active_cell_iterators())
    ++(cell->at_boundary() ? at_boundary : inside);
  check(inside > 0 && at_boundary > 0, "the mesh has cells inside (" + std::to_string(inside) + ") and at the boundary (" +
                                         std::to_string(at_boundary) + ")");
  for (const unsigned int degree : {1u, 2u})
    {
      const auto [by_deal_ii, at_nodes] = both_vtu(mesh, degree);
      check(by_deal_ii.size() > 1000 && by_deal_ii == at_nodes,
            "P" + std::to_string(degree) + ": the VTU from patches read at the DoFs equals DataOut::build_patches' byte "
            "for byte (" + std::to_string(by_deal_ii.size()) + " and " + std::to_string(at_nodes.size()) + " bytes)");
    }
  return modal_haptics::testing::exit_code();
}
