// The last phase: the mode shapes and the validation error fields as a VTU, for ParaView.
#pragma once

#include "output/vtu_file.h"
#include "scene/linear_tet.h"
#include "space/backend.h"

#include <deal.II/numerics/data_out.h>

#include <algorithm>
#include <cstdint>
#include <memory>
#include <string>
#include <unordered_map>

namespace modal_haptics
{
  namespace space_phases
  {
    // DataOut that hands its built patches over (the fields' values at the output's points, their
    // names and vector ranges, and its VTK flags): a VTU written from them needs neither the mesh nor
    // the vectors they came from, so it can be written on another thread while they are gone.
    class VtuOutput : public dealii::DataOut<3>
    {
    public:
      struct Patches
      {
        std::vector<dealii::DataOutBase::Patch<3, 3>> patches;
        std::vector<std::string>                      names;
        std::vector<std::tuple<unsigned int, unsigned int, std::string,
                               dealii::DataComponentInterpretation::DataComponentInterpretation>>
                                      vector_ranges;
        dealii::DataOutBase::VtkFlags flags;

        // Uncompressed: appended raw binary (vtu_file.h), what deal.II's base64 would be less a
        // quarter; compressed ('Output/VTU compression'), or patches it does not know: deal.II's.
        void write(std::ostream &out) const
        {
          if (flags.compression_level == dealii::DataOutBase::VtkFlags::no_compression && appendable())
            vtu_file::write(out, appended_grid());
          else
            dealii::DataOutBase::write_vtu(patches, names, vector_ranges, flags, out);
        }

        // Linear or quadratic tets that carry their points, as build_patches_at_nodes makes them.
        bool appendable() const
        {
          return std::all_of(patches.begin(), patches.end(), [&](const auto &p) {
            return p.reference_cell == dealii::ReferenceCells::Tetrahedron && p.points_are_available &&
                   (p.n_subdivisions == 1 || p.n_subdivisions == 2) &&
                   p.data.n_rows() == names.size() + 3 && p.data.n_cols() == (p.n_subdivisions == 1 ? 4u : 10u);
          });
        }

        // The patches' points as Float32 rows (x, y, z, then every data row), each distinct row
        // once: neighbouring cells share their nodes' rows exactly (the same DoF values, the same
        // coordinates from the same two or three vertices), so a P2 mesh keeps about one row in five.
        // Where a field jumps between cells the rows differ and both stay.
        struct SharedPoints
        {
          unsigned int               width = 0;
          std::vector<float>         rows;         // width floats per distinct point
          std::vector<std::int32_t>  connectivity; // per patch point, its distinct row
        };

        SharedPoints shared_points() const
        {
          SharedPoints shared;
          const unsigned int data_rows = names.size();
          shared.width                 = data_rows + 3;
          std::unordered_map<std::string, std::int32_t> index_of;
          std::vector<float>                            row(shared.width);
          for (const auto &p : patches)
            for (unsigned int j = 0; j < p.data.n_cols(); ++j)
              {
                for (unsigned int d = 0; d < 3; ++d)
                  row[d] = float(p.data(data_rows + d, j));
                for (unsigned int r = 0; r < data_rows; ++r)
                  row[3 + r] = float(p.data(r, j));
                std::string key(reinterpret_cast<const char *>(row.data()), row.size() * sizeof(float));
                const auto [at, added] = index_of.emplace(std::move(key), std::int32_t(index_of.size()));
                if (added)
                  shared.rows.insert(shared.rows.end(), row.begin(), row.end());
                shared.connectivity.push_back(at->second);
              }
          return shared;
        }

        // Each patch a VTK_TETRA or VTK_QUADRATIC_TETRA, whose node order is FE_SimplexP's support
        // points', on the shared points; the fields as deal.II names them (vectors, then scalars).
        vtu_file::Grid appended_grid() const
        {
          auto           shared = std::make_shared<const SharedPoints>(shared_points());
          vtu_file::Grid grid;
          grid.n_points = shared->rows.size() / shared->width;
          grid.n_cells  = patches.size();
          std::vector<std::int32_t> offsets;
          std::vector<std::uint8_t> types;
          std::int32_t              end = 0;
          for (const auto &p : patches)
            {
              offsets.push_back(end += std::int32_t(p.data.n_cols()));
              types.push_back(p.n_subdivisions == 1 ? 10 : 24);
            }
          grid.points       = columns(shared, "", 0, 3);
          grid.connectivity = vtu_file::owned_array("connectivity", 1, shared->connectivity);
          grid.offsets      = vtu_file::owned_array("offsets", 1, std::move(offsets));
          grid.types        = vtu_file::owned_array("types", 1, std::move(types));
          std::vector<bool> in_a_vector(names.size(), false);
          for (const auto &[first, last, name, interpretation] : vector_ranges)
            {
              grid.point_data.push_back(columns(shared, name, 3 + first, last - first + 1));
              std::fill(in_a_vector.begin() + first, in_a_vector.begin() + last + 1, true);
            }
          for (unsigned int row = 0; row < names.size(); ++row)
            if (!in_a_vector[row])
              grid.point_data.push_back(columns(shared, names[row], 3 + row, 1));
          return grid;
        }

        // Columns first, first + 1, ... of the shared rows, point by point: written in chunks, never
        // copied whole.
        static vtu_file::Array columns(const std::shared_ptr<const SharedPoints> &shared, const std::string &name,
                                       const unsigned int first, const unsigned int count)
        {
          vtu_file::Array a;
          a.type       = "Float32";
          a.name       = name;
          a.components = count;
          a.bytes      = std::uint64_t(shared->rows.size() / shared->width) * count * sizeof(float);
          a.write      = [shared, first, count](std::ostream &out) {
            std::vector<float> chunk;
            const auto         flush = [&] {
              out.write(reinterpret_cast<const char *>(chunk.data()), std::streamsize(chunk.size() * sizeof(float)));
              chunk.clear();
            };
            for (std::size_t at = 0; at < shared->rows.size(); at += shared->width)
              {
                chunk.insert(chunk.end(), shared->rows.begin() + at + first, shared->rows.begin() + at + first + count);
                if (chunk.size() >= 65536)
                  flush();
              }
            flush();
          };
          return a;
        }
      };

      void set_vtk_flags(const dealii::DataOutBase::VtkFlags &flags)
      {
        flags_for_vtu = flags;
        set_flags(flags);
      }

      // What build_patches(mapping, degree) makes of DoF fields of FESystem(FE_SimplexP(degree), 3) on
      // a linear-geometry tet mesh, read at the DoFs instead of evaluated through FEValues. A patch's
      // points are FE_SimplexP(degree)'s support points (deal.II's choice for simplex patches of
      // 'degree' subdivisions), where each shape function is 1 or 0, so a field's value at point j is
      // its DoF j (a -0 written as +0, which deal.II's sum over the shape functions makes of it).
      // Every simplex patch carries its points (deal.II stores them for any cell that is not a
      // hypercube), as the linear mapping computes them (point_in_linear_tet). 'fields' are those
      // added, in their order. build_patches was most of the VTU phase (docs/performance.md, the
      // mode-shape VTU files); precompute.vtu_patches compares both VTU files byte for byte.
      void build_patches_at_nodes(const dealii::DoFHandler<3>                    &dof_handler,
                                  const std::vector<const dealii::Vector<double> *> &fields)
      {
        const auto &fe = dof_handler.get_fe();
        AssertThrow(fe.n_base_elements() == 1 && fe.n_components() == 3 &&
                      fe.base_element(0).reference_cell() == dealii::ReferenceCells::Tetrahedron,
                    dealii::ExcMessage("build_patches_at_nodes: FESystem(FE_SimplexP, 3) on tets is expected"));
        const auto                                   &scalar = fe.base_element(0);
        const auto                                   &unit   = scalar.get_unit_support_points();
        const unsigned int                            rows   = 3 * fields.size();
        std::vector<dealii::types::global_dof_index> dofs(fe.n_dofs_per_cell());
        this->patches.clear();
        for (const auto &cell : dof_handler.active_cell_iterators())
          {
            if (!cell->is_locally_owned())
              continue;
            dealii::DataOutBase::Patch<3, 3> patch;
            patch.reference_cell = cell->reference_cell();
            patch.n_subdivisions = scalar.degree;
            patch.patch_index    = this->patches.size();
            for (unsigned int v = 0; v < 4; ++v)
              patch.vertices[v] = cell->vertex(v);
            patch.points_are_available = true;
            patch.data.reinit(rows + 3, unit.size());
            cell->get_dof_indices(dofs);
            for (unsigned int i = 0; i < dofs.size(); ++i)
              {
                const auto [component, point] = fe.system_to_component_index(i);
                for (unsigned int f = 0; f < fields.size(); ++f)
                  patch.data(3 * f + component, point) = 0. + (*fields[f])[dofs[i]]; // -0 as +0, as the sum does
              }
            for (unsigned int j = 0; j < unit.size(); ++j)
              {
                const dealii::Point<3> x = point_in_linear_tet(cell, unit[j]);
                for (unsigned int d = 0; d < 3; ++d)
                  patch.data(rows + d, j) = x[d];
              }
            this->patches.push_back(std::move(patch));
          }
      }

      std::shared_ptr<const Patches> take_patches()
      {
        auto taken = std::make_shared<Patches>(
          Patches{std::move(this->patches), get_dataset_names(), get_nonscalar_data_ranges(), flags_for_vtu});
        clear();
        return taken;
      }

    private:
      dealii::DataOutBase::VtkFlags flags_for_vtu;
    };

    // Mode shapes (frequency in the field name) and the validation error fields, for ParaView.
    template <typename Backend>
    void output_results(const Backend &b, const PhaseInputs &in, const ModalSpaceResult &result)
    {
      if (in.vtu_file.empty())
        return;
      VtuOutput data_out;
      data_out.attach_dof_handler(b.dof_handler);
      const std::vector<dealii::DataComponentInterpretation::DataComponentInterpretation> vector_field(
        3, dealii::DataComponentInterpretation::component_is_part_of_vector);
      const auto        &modes = b.kept_modes();
      const unsigned int n_vtu = std::min<unsigned int>(in.scene.output.vtu_modes, modes.size());
      std::vector<typename Backend::Field> mode_fields; // with the constrained entries filled in
      mode_fields.reserve(n_vtu);
      for (unsigned int i = 0; i < n_vtu; ++i)
        mode_fields.push_back(b.output_field(modes[i]));
      for (unsigned int i = 0; i < n_vtu; ++i)
        data_out.add_data_vector(mode_fields[i],
                                 std::vector<std::string>(3, space_parts::mode_field_name(i, result.frequencies_hz[i])),
                                 dealii::DataOut<3>::type_dof_data, vector_field);
      for (unsigned int k = 0; k < b.validation_fields.size(); ++k)
        data_out.add_data_vector(b.validation_fields[k],
                                 std::vector<std::string>(3, space_parts::validation_field_name(result.validation[k])),
                                 dealii::DataOut<3>::type_dof_data, vector_field);
      if constexpr (std::is_same_v<typename Backend::Field, dealii::Vector<double>>)
        {
          std::vector<const dealii::Vector<double> *> fields;
          for (const auto &field : mode_fields)
            fields.push_back(&field);
          for (const auto &field : b.validation_fields)
            fields.push_back(&field);
          data_out.build_patches_at_nodes(b.dof_handler, fields);
        }
      else
        data_out.build_patches(b.mapping, in.scene.element_degree);
      // 'Output/VTU compression': none by default, since zlib on one thread took more than half of
      // the phase (docs/performance.md) for files that are only viewed.
      dealii::DataOutBase::VtkFlags flags;
      switch (in.scene.output.vtu_compression)
        {
          case VtuCompression::none:
            flags.compression_level = dealii::DataOutBase::VtkFlags::no_compression;
            break;
          case VtuCompression::fast:
            flags.compression_level = dealii::DataOutBase::VtkFlags::best_speed;
            break;
          case VtuCompression::best:
            flags.compression_level = dealii::DataOutBase::VtkFlags::best_compression;
            break;
        }
      data_out.set_vtk_flags(flags);
      b.write_vtu(data_out);
    }
  } // namespace space_phases
} // namespace modal_haptics
