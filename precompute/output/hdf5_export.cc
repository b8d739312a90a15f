// The HDF5 research artifact (exporters.h: write_hdf5_file, write_hdf5_file_parallel; layout in
// docs/hdf5-layout.md), written to a temporary file and renamed.
#include "output/atomic_file.h"
#include "output/exporters.h"

#include <deal.II/base/hdf5.h>
#include <deal.II/base/mpi.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>

namespace modal_haptics
{
  using dealii::ExcMessage;

  // ---------------------------------------------------------------------------------------------
  // HDF5
  // ---------------------------------------------------------------------------------------------
  namespace
  {
    // Who writes what. A serial file: this process writes everything. A parallel file (every call
    // collective, on every process of the communicator): process 0 writes the datasets every process
    // holds in full, the others take part with empty selections, and each process writes its own rows
    // of the per-vertex and per-tet datasets (ModalSpaceResult::owned_rows).
    struct Writers
    {
      bool writes_whole_arrays = true;
    };

    template <typename T>
    void write_array(const dealii::HDF5::Group &group, const std::string &name, const std::vector<T> &data,
                     std::vector<hsize_t> dimensions, const Writers &writers = {})
    {
      std::size_t size = 1;
      for (const auto d : dimensions)
        size *= d;
      AssertThrow(size == data.size(), dealii::ExcInternalError());
      auto dataset = group.create_dataset<T>(name, dimensions);
      if (data.empty())
        return;
      if (writers.writes_whole_arrays)
        dataset.write(data);
      else
        dataset.template write_none<T>();
    }

    // A dataset of shape (blocks, n, width), or (n, width) for blocks = 0, of which this process
    // holds the rows 'rows' of n (all of them if 'rows' is null), block by block. Each block is one
    // collective write of the rows' elements (an HDF5 point selection), so the coordinates never
    // take more than three times a block of this process's rows.
    template <typename T>
    void write_rows(const dealii::HDF5::Group &group, const std::string &name, const std::vector<T> &data,
                    const hsize_t blocks, const hsize_t n, const hsize_t width, const std::vector<unsigned int> *rows)
    {
      if (rows == nullptr)
        {
          write_array(group, name, data, blocks == 0 ? std::vector<hsize_t>{n, width} : std::vector<hsize_t>{blocks, n, width});
          return;
        }
      auto dataset = group.create_dataset<T>(name, blocks == 0 ? std::vector<hsize_t>{n, width} :
                                                                 std::vector<hsize_t>{blocks, n, width});
      const std::size_t block_size = rows->size() * width;
      std::vector<hsize_t> coordinates;
      for (hsize_t b = 0; b < std::max<hsize_t>(blocks, 1); ++b)
        {
          if (block_size == 0)
            {
              dataset.template write_none<T>();
              continue;
            }
          coordinates.clear();
          for (const unsigned int row : *rows)
            for (hsize_t c = 0; c < width; ++c)
              {
                if (blocks > 0)
                  coordinates.push_back(b);
                coordinates.push_back(row);
                coordinates.push_back(c);
              }
          dataset.write_selection(std::vector<T>(data.begin() + b * block_size, data.begin() + (b + 1) * block_size),
                                  coordinates);
        }
    }

    // The nonlinear force-displacement curve of each validity contact: a group per contact.
    void write_validity(dealii::HDF5::Group &space, const ModalSpaceResult &s, const Writers &w)
    {
      if (s.validity.empty())
        return;
      auto validity = space.create_group("validity");
      for (const auto &curve : s.validity)
        {
          auto          c = validity.create_group("vertex_" + std::to_string(curve.vertex));
          const hsize_t m = curve.forces.size();
          c.set_attribute("vertex", curve.vertex);
          c.set_attribute("material", curve.material);
          c.set_attribute("linear_compliance_m_per_n", curve.linear_compliance);
          c.set_attribute("force_limit_n", curve.force_limit);
          c.set_attribute("force_reached_n", curve.force_reached);
          c.set_attribute("stop_reason", curve.stop_reason.empty() ? std::string("none") : curve.stop_reason);
          write_array(c, "direction", std::vector<double>(curve.direction.begin(), curve.direction.end()), {3}, w);
          write_array(c, "force_n", curve.forces, {m}, w);
          write_array(c, "displacement_m", curve.displacements, {m}, w);
          write_array(c, "newton_iterations", curve.newton_iterations, {m}, w);
          write_array(c, "validity_force_n", std::vector<double>(curve.validity_force.begin(), curve.validity_force.end()),
                      {3}, w);
          for (const auto &[name, estimate] : {std::make_pair("second_order_exact", &curve.estimate_exact),
                                               std::make_pair("second_order_modal", &curve.estimate_modal),
                                               std::make_pair("third_order_exact", &curve.estimate_third_order)})
            {
              c.set_attribute(std::string(name) + "_c2_m_per_n2", estimate->c2);
              if (estimate->c3 != 0.)
                c.set_attribute(std::string(name) + "_c3_m_per_n3", estimate->c3);
              write_array(c, std::string(name) + "_validity_force_n",
                          std::vector<double>(estimate->validity_force.begin(), estimate->validity_force.end()), {3}, w);
            }
        }
    }

    void write_space(dealii::HDF5::Group &spaces, const ModalSpaceResult &s, const unsigned int nv, const Writers &w)
    {
      auto g = spaces.create_group(s.name);
      const hsize_t r = s.eigenvalues.size(), nc = s.candidates.size(), nval = s.validation.size();
      g.set_attribute("index", s.index);
      g.set_attribute("degree", s.degree);
      g.set_attribute("n_dofs", s.n_dofs);
      g.set_attribute("mass_kg", s.mass);
      const auto *vertex_rows = s.owned_rows ? &s.owned_rows->vertices : nullptr;
      write_rows(g, "mesh_vertices", s.mesh_vertices, 0, s.n_vertices, 3, vertex_rows);
      write_rows(g, "mesh_tets", s.mesh_tets, 0, s.n_cells, 4, s.owned_rows ? &s.owned_rows->tets : nullptr);
      write_array(g, "clamped_dofs", s.clamped_dofs, {s.clamped_dofs.size()}, w);
      write_array(g, "eigenvalues", s.eigenvalues, {r}, w);
      write_array(g, "frequencies_hz", s.frequencies_hz, {r}, w);
      write_array(g, "damping_ratios", s.damping_ratios, {r}, w);
      // r = 0 cannot happen (select_modes keeps at least one), so the blocks are the modes.
      write_rows(g, "modes_at_vertices", s.modes_at_vertices, r, s.n_vertices, 3, vertex_rows);
      write_array(g, "display_modes", s.display_modes, {nv, 3, r}, w);
      write_array(g, "candidate_vertices", s.candidates, {nc}, w);
      write_array(g, "candidate_modes", s.candidate_modes, {nc, 3, r}, w);
      write_array(g, "candidate_compliance", s.candidate_compliance, {nc, 3, 3}, w);
      write_array(g, "cross_offsets", s.cross_offsets, {s.cross_offsets.size()}, w);
      write_array(g, "cross_neighbours", s.cross_neighbours, {s.cross_neighbours.size()}, w);
      write_array(g, "cross_blocks", s.cross_blocks, {s.cross_neighbours.size(), 3, 3}, w);
      if (s.far_rank > 0)
        write_array(g, "far_compliance", s.far_compliance, {nc, 3, s.far_rank}, w);
      write_array(g, "felt_stiffness", s.felt_stiffness, {s.felt_stiffness.size()}, w);
      write_array(g, "modal_only_stiffness", s.modal_only_stiffness, {s.modal_only_stiffness.size()}, w);
      if (!s.validity_force.empty())
        write_array(g, "validity_force", s.validity_force, {nv, 3}, w);
      write_array(g, "participation", s.participation, {r, 6}, w);
      write_array(g, "centre_of_mass", std::vector<double>(s.centre_of_mass.begin(), s.centre_of_mass.end()), {3}, w);
      write_array(g, "inertia", std::vector<double>(s.inertia.begin(), s.inertia.end()), {3, 3}, w);
      std::vector<unsigned int> cases;
      std::vector<double>       response;
      for (const auto &vc : s.validation)
        {
          cases.push_back(vc.vertex);
          cases.push_back(vc.direction);
          response.insert(response.end(), vc.full_response.begin(), vc.full_response.end());
        }
      write_array(g, "validation_cases", cases, {nval, 2}, w);
      write_array(g, "validation_response", response, {nval, 3}, w);
      write_validity(g, s, w);
    }
  } // namespace

  namespace
  {
    // deal.II 9.4's HDF5Object::set_attribute<std::string> never closes the string datatype it
    // creates, and that datatype keeps the file open inside HDF5 after the File object is gone: HDF5
    // then writes the rest of the file at exit, after it was renamed into place, where a failure (a
    // full disk) leaves a truncated .h5 under its final name and nobody told. Nothing else of HDF5 is
    // open once the File is destroyed, so the datatypes still open are those and are closed here.
    void close_leaked_string_types()
    {
      const ssize_t count = H5Fget_obj_count(H5F_OBJ_ALL, H5F_OBJ_DATATYPE);
      std::vector<hid_t> types(count > 0 ? std::size_t(count) : 0);
      H5Fget_obj_ids(H5F_OBJ_ALL, H5F_OBJ_DATATYPE, types.size(), types.data());
      for (const hid_t type : types)
        H5Tclose(type);
    }
  } // namespace

  namespace
  {
    // Everything but the file: the same calls on every process of a parallel file.
    void write_hdf5_contents(dealii::HDF5::File &file, const SceneParameters &scene, const PrecomputeResults &results,
                             const Writers &w)
    {
      file.set_attribute("scene", scene.scene_name);
      file.set_attribute("format_version", std::string("1.0"));
      file.set_attribute("units", std::string("SI: m, kg, s, N, Pa"));
      auto material = file.create_group("material");
      material.set_attribute("youngs_modulus_pa", scene.material.youngs_modulus);
      material.set_attribute("poissons_ratio", scene.material.poissons_ratio);
      material.set_attribute("density_kg_m3", scene.material.density);

      const auto &d       = results.display;
      auto        display = file.create_group("display_surface");
      display.set_attribute("patch_radius_m", d.patch_radius);
      write_array(display, "vertices", flatten(d.vertices), {d.n_vertices(), 3}, w);
      write_array(display, "triangles", flatten(d.triangles), {d.triangles.size(), 3}, w);
      write_array(display, "region", d.region, {d.n_vertices()}, w);
      write_array(display, "vertex_area", d.vertex_area, {d.n_vertices()}, w);
      write_array(display, "patch_offsets", d.patch_offsets, {d.patch_offsets.size()}, w);
      write_array(display, "patch_vertices", d.patch_vertices, {d.patch_vertices.size()}, w);
      write_array(display, "patch_weights", d.patch_weights, {d.patch_weights.size()}, w);

      auto spaces = file.create_group("spaces");
      for (const auto &s : results.spaces)
        write_space(spaces, s, d.n_vertices(), w);
      auto transfer = file.create_group("transfer");
      for (const auto &t : results.transfers)
        write_array(transfer, results.spaces[t.to].name + "__from__" + results.spaces[t.from].name, t.values,
                    {t.rows, t.columns}, w);
    }

    // HDF5 writes much of the file when it closes it, and deal.II's File cannot report a failure there
    // (its destructor drops H5Fclose's status). A file HDF5 still holds now is one it failed to
    // finish; one it can open again is whole (it refuses a file shorter than the end it recorded).
    void check_hdf5_file_complete(const std::string &filename, const std::string &temporary)
    {
      close_leaked_string_types();
      const bool  closed = H5Fget_obj_count(H5F_OBJ_ALL, H5F_OBJ_ALL) == 0;
      const hid_t check  = closed ? H5Fopen(temporary.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT) : -1;
      AssertThrow(check >= 0, dealii::ExcMessage("Writing '" + filename + "' failed: HDF5 could not complete the "
                                                 "file (disk full?); the previous file is kept."));
      H5Fclose(check);
    }
  } // namespace

  void write_hdf5_file(const std::string &filename, const SceneParameters &scene, const PrecomputeResults &results,
                       StagedFiles &staged)
  {
    const std::string temporary = staged.stage(filename);
    {
      dealii::HDF5::File file(temporary, dealii::HDF5::File::FileAccessMode::create);
      write_hdf5_contents(file, scene, results, Writers{});
    }
    check_hdf5_file_complete(filename, temporary);
  }

  void write_hdf5_file_parallel(const std::string &filename, const SceneParameters &scene,
                                const PrecomputeResults &results, StagedFiles *staged, const MPI_Comm comm)
  {
    const bool  first     = dealii::Utilities::MPI::this_mpi_process(comm) == 0;
    std::string temporary = first ? staged->stage(filename) : std::string();
    temporary             = dealii::Utilities::MPI::broadcast(comm, temporary, 0);
    {
      // No exception may leave this block: deal.II aborts if one is thrown while parallel HDF5
      // objects are alive, and leaves a corrupt file (FACTS).
      dealii::HDF5::File file(temporary, dealii::HDF5::File::FileAccessMode::create, comm);
      write_hdf5_contents(file, scene, results, Writers{first});
    }
    if (first)
      check_hdf5_file_complete(filename, temporary);
  }
} // namespace modal_haptics
