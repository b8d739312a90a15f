// The exporters: the HDF5 research artifact, the kernel's .mrt basis file (docs/basis-format.md)
// and report.json (docs/report-schema.md). Each is written to a temporary file and renamed.
#include "output/atomic_file.h"
#include "output/exporters.h"

#include <deal.II/base/hdf5.h>
#include <deal.II/base/mpi.h>

#include <mrt/writer.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <iomanip>
#include <sstream>

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

    std::vector<double> flatten(const std::vector<meshing::Point3> &points)
    {
      std::vector<double> flat;
      for (const auto &p : points)
        flat.insert(flat.end(), p.begin(), p.end());
      return flat;
    }

    template <std::size_t N>
    std::vector<unsigned int> flatten(const std::vector<std::array<unsigned int, N>> &rows)
    {
      std::vector<unsigned int> flat;
      for (const auto &row : rows)
        flat.insert(flat.end(), row.begin(), row.end());
      return flat;
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
      const hsize_t n_cross = s.cross_compliance.empty() ? 0 : 3 * nc;
      write_array(g, "cross_compliance", s.cross_compliance, {n_cross, n_cross}, w);
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

  // ---------------------------------------------------------------------------------------------
  // The .mrt basis file: its content, laid out and checksummed by the format's writer (mrt/)
  // ---------------------------------------------------------------------------------------------
  namespace
  {
    mrt::BasisContent basis_content(const SceneParameters &scene, const PrecomputeResults &results)
    {
      const auto       &d = results.display;
      mrt::BasisContent c;
      c.vertices       = flatten(d.vertices);
      c.triangles      = flatten(d.triangles);
      c.region         = d.region;
      c.patch_offsets  = d.patch_offsets;
      c.patch_vertices = d.patch_vertices;
      c.patch_weights  = d.patch_weights;
      const auto &global = results.spaces.front();
      c.scene_scalars  = {d.patch_radius, global.mass, global.centre_of_mass, global.inertia};
      c.float64_modes = scene.output.float64_modes;

      for (const auto &s : results.spaces)
        {
          AssertThrow(s.index == c.spaces.size(), dealii::ExcInternalError()); // space s is spaces[s]
          mrt::BasisSpaceContent space;
          space.name                 = s.name;
          space.eigenvalues          = s.eigenvalues;
          space.damping_ratios       = s.damping_ratios;
          space.display_modes        = s.display_modes;
          space.candidates           = s.candidates;
          space.candidate_modes      = s.candidate_modes;
          space.candidate_compliance = s.candidate_compliance;
          space.cross_compliance     = s.cross_compliance;
          space.participation        = s.participation;
          for (const auto &vc : s.validation)
            {
              space.validation_cases.push_back(vc.vertex);
              space.validation_cases.push_back(vc.direction);
              space.validation_response.insert(space.validation_response.end(), vc.full_response.begin(),
                                               vc.full_response.end());
            }
          c.spaces.push_back(std::move(space));
        }
      for (const auto &t : results.transfers)
        c.transfers.push_back({t.to, t.from, t.values});
      return c;
    }
  } // namespace

  void write_basis_file(const std::string &filename, const SceneParameters &scene, const PrecomputeResults &results,
                        StagedFiles &staged)
  {
    const std::vector<unsigned char> file = mrt::write_basis(basis_content(scene, results));
    staged.write(filename, [&](std::ostream &out) { out.write(reinterpret_cast<const char *>(file.data()), file.size()); },
                 std::ios::binary);
  }

  // ---------------------------------------------------------------------------------------------
  // report.json
  // ---------------------------------------------------------------------------------------------
  namespace
  {
    // A minimal JSON writer: objects and arrays are opened and closed explicitly, commas are ours.
    class Json
    {
    public:
      explicit Json(std::ostream &out) : out(out) { out << std::setprecision(17); }

      Json &begin_object(const std::string &key = "") { return open(key, '{'); }
      Json &end_object() { return close('}'); }
      Json &begin_array(const std::string &key = "") { return open(key, '['); }
      Json &end_array() { return close(']'); }

      Json &value(const std::string &key, const std::string &text)
      {
        prefix(key);
        out << quoted(text);
        return *this;
      }
      Json &value(const std::string &key, const char *text) { return value(key, std::string(text)); }
      Json &value(const std::string &key, const bool flag)
      {
        prefix(key);
        out << (flag ? "true" : "false");
        return *this;
      }
      template <typename Number, typename = std::enable_if_t<std::is_arithmetic_v<Number>>>
      Json &value(const std::string &key, const Number number)
      {
        prefix(key);
        if constexpr (std::is_floating_point_v<Number>)
          {
            if (std::isfinite(number))
              out << number;
            else
              out << "null";
          }
        else
          out << number;
        return *this;
      }
      template <typename Number>
      Json &array(const std::string &key, const std::vector<Number> &numbers)
      {
        begin_array(key);
        for (const auto x : numbers)
          value("", x);
        return end_array();
      }

    private:
      static std::string quoted(const std::string &text)
      {
        std::string q = "\"";
        for (const char c : text)
          {
            if (c == '"' || c == '\\')
              q += '\\', q += c;
            else if (static_cast<unsigned char>(c) < 0x20)
              {
                char buffer[8];
                std::snprintf(buffer, sizeof buffer, "\\u%04x", c);
                q += buffer;
              }
            else
              q += c;
          }
        return q + "\"";
      }
      void prefix(const std::string &key)
      {
        if (!first.empty())
          {
            if (!first.back())
              out << ",";
            first.back() = false;
          }
        out << "\n" << std::string(2 * first.size(), ' ');
        if (!key.empty())
          out << quoted(key) << ": ";
      }
      Json &open(const std::string &key, const char bracket)
      {
        prefix(key);
        out << bracket;
        first.push_back(true);
        return *this;
      }
      Json &close(const char bracket)
      {
        first.pop_back();
        out << "\n" << std::string(2 * first.size(), ' ') << bracket;
        if (first.empty())
          out << "\n";
        return *this;
      }

      std::ostream     &out;
      std::vector<bool> first;
    };

    std::uintmax_t file_size(const std::string &name)
    {
      std::error_code error;
      const auto      size = std::filesystem::file_size(name, error);
      return error ? 0 : size;
    }

    void write_validation(Json &json, const std::vector<ValidationCase> &cases)
    {
      json.begin_array("validation");
      for (const auto &vc : cases)
        {
          json.begin_object()
            .value("vertex", vc.vertex)
            .value("direction", std::string(1, "xyz"[vc.direction]))
            .array("full_contact_response_m_per_n", std::vector<double>(vc.full_response.begin(), vc.full_response.end()))
            .value("contact_rel_error_modal", vc.contact_rel_error_modal)
            .value("contact_rel_error_corrected", vc.contact_rel_error_corrected)
            .value("field_rel_error_modal", vc.field_rel_error_modal)
            .value("field_max_error_modal", vc.field_max_error_modal)
            .value("field_rel_error_corrected", vc.field_rel_error_corrected)
            .value("correction_field_vertices", vc.correction_field_vertices)
            .value("energy_rel_error_modal", vc.energy_rel_error_modal)
            .value("solve_relative_residual", vc.solve_relative_residual)
            .end_object();
        }
      json.end_array();
    }

    void write_space(Json &json, const ModalSpaceResult &s, const meshing::ScenarioMesh &mesh)
    {
      const auto r = s.eigenvalues.size(), nc = s.candidates.size();
      json.begin_object()
        .value("name", s.name)
        .value("index", s.index)
        .value("n_vertices", s.n_vertices)
        .value("n_cells", s.n_cells)
        .value("n_dofs", s.n_dofs)
        .value("degree", s.degree)
        .value("n_clamped_dofs", s.n_clamped_dofs);
      json.begin_object("mesh")
        .value("file", std::filesystem::path(mesh.msh_file).filename().string())
        .value("n_nodes", mesh.statistics.n_nodes)
        .value("n_tets", mesh.statistics.n_tets)
        .value("min_quality", mesh.statistics.min_quality)
        .value("mean_quality", mesh.statistics.mean_quality)
        .value("max_quality", mesh.statistics.max_quality)
        .value("reused", mesh.statistics.reused)
        .value("seconds", mesh.statistics.seconds)
        .end_object();
      json.value("n_modes", r)
        .array("frequencies_hz", s.frequencies_hz)
        .array("computed_frequencies_hz", s.computed_frequencies_hz)
        .array("damping_ratios", s.damping_ratios)
        .value("cut_off_hz", s.cut_off_hz);
      json.begin_array("dropped_modes");
      for (const auto &dm : s.dropped_modes)
        json.begin_object().value("index", dm.index).value("frequency_hz", dm.frequency).value("reason", dm.reason).end_object();
      json.end_array();
      json.value("supports", s.supports_summary);
      json.begin_object("rigid_body_modes")
        .value("count", s.n_rigid_body_modes)
        .value("free_motions", s.free_motions)
        .array("computed_frequencies_hz", s.rigid_computed_frequencies_hz)
        .value("subspace_distance", s.rigid_subspace_sine)
        .end_object();
      json.value("orthonormality_error", s.self_check.orthonormality_error)
        .value("max_relative_residual", s.self_check.max_relative_residual)
        .value("spurious_eigenvalues",
               "none: the " + std::to_string(s.n_spurious_rows) +
                 " constrained rows have M_ii = 0, which puts their eigenvalues at infinity");
      json.begin_object("eigensolver")
        .value("method", s.eigensolver_method + " + " + s.factorization.method)
        .value("factor_nonzeros", s.factorization.factor_nonzeros)
        .value("factor_flops", s.factorization.factor_flops)
        .value("analyze_s", s.factorization.analyze_seconds)
        .value("factorize_s", s.factorization.factorize_seconds)
        .value("arpack_s", s.eigensolve_iteration_seconds)
        .value("operator_applications", s.n_operator_applications)
        .value("solved_vectors", s.factorization.n_solved_vectors)
        .value("solve_s", s.factorization.solve_seconds)
        .value("solve_threads", s.factorization.solve_threads)
        .value("mass_products_s", s.mass_product_seconds)
        .value("orthogonalization_s", s.orthogonalization_seconds)
        .end_object();
      const std::size_t bytes_per_candidate = 8 * (3 * r + 9) + 4 + (s.cross_compliance.empty() ? 0 : 8 * 9 * nc);
      json.begin_object("static_correction")
        .value("n_candidates", nc)
        .value("cross_compliance", !s.cross_compliance.empty())
        .value("seconds_per_candidate", s.correction_seconds_per_candidate)
        .value("refinement_steps", s.static_solve_iterations)
        .value("bytes_per_candidate", bytes_per_candidate)
        .end_object();
      json.value("mass_kg", s.mass)
        .array("centre_of_mass_m", std::vector<double>(s.centre_of_mass.begin(), s.centre_of_mass.end()));
      write_validation(json, s.validation);
      if (s.two_contact_rel_error_corrected >= 0.)
        json.value("two_contact_rel_error_corrected", s.two_contact_rel_error_corrected);
      json.begin_object("timings_s");
      for (const auto &[phase, seconds] : s.timings_s)
        json.value(phase, seconds);
      json.end_object().end_object();
    }

    // The same display vertex felt from each space: the accuracy a VOI buys over the global space.
    void write_cross_space(Json &json, const PrecomputeResults &results)
    {
      json.begin_array("cross_space");
      const auto &global = results.spaces.front();
      for (const auto &[vertex, G_global] : global.full_compliance)
        for (const auto &s : results.spaces)
          {
            if (s.index == 0 || s.full_compliance.count(vertex) == 0)
              continue;
            const auto &G = s.full_compliance.at(vertex);
            double      diff = 0., norm = 0.;
            for (unsigned int k = 0; k < 9; ++k)
              diff += std::pow(G_global[k] - G[k], 2), norm += G[k] * G[k];
            json.begin_object()
              .value("vertex", vertex)
              .value("region", results.spaces[results.display.region[vertex]].name)
              .value("space", s.name)
              .array("compliance_m_per_n", std::vector<double>(G.begin(), G.end()))
              .array("global_compliance_m_per_n", std::vector<double>(G_global.begin(), G_global.end()))
              .value("global_rel_difference", std::sqrt(diff / norm))
              .end_object();
          }
      json.end_array();
    }
  } // namespace

  void write_report(const std::string &filename, const SceneParameters &scene, const PrecomputeResults &results,
                    StagedFiles &staged)
  {
    const std::string base = scene.output_directory + "/" + scene.scene_name;
    staged.write(filename, [&](std::ostream &out) {
      Json json(out);
      json.begin_object()
        .value("schema_version", "1.0")
        .value("scene", scene.scene_name)
        .value("parameter_file", scene.parameter_file)
        .value("geometry", scene.meshing.geometry)
        .value("element_degree", scene.element_degree);
      json.begin_object("processes")
        .value("count", results.n_processes)
        .value("max_peak_memory_mb", results.max_peak_memory_mb)
        .end_object();
      json.begin_object("material")
        .value("youngs_modulus_pa", scene.material.youngs_modulus)
        .value("poissons_ratio", scene.material.poissons_ratio)
        .value("density_kg_m3", scene.material.density)
        .end_object();
      const auto &d = results.display;
      json.begin_object("display_surface")
        .value("n_vertices", d.n_vertices())
        .value("n_triangles", d.triangles.size())
        .value("patch_radius_m", d.patch_radius)
        .value("max_patch_size", d.max_patch_size)
        .end_object();
      json.begin_array("spaces");
      for (std::size_t k = 0; k < results.spaces.size(); ++k)
        write_space(json, results.spaces[k], results.meshes.scenarios[k]);
      json.end_array();
      write_cross_space(json, results);
      json.begin_array("transfer");
      for (const auto &t : results.transfers)
        json.begin_object()
          .value("to", results.spaces[t.to].name)
          .value("from", results.spaces[t.from].name)
          .value("relative_residual", t.relative_residual)
          .end_object();
      json.end_array();
      json.begin_object("files")
        .value("h5_bytes", file_size(staged.current_path(base + ".h5")))
        .value("mrt_bytes", file_size(staged.current_path(base + ".mrt")))
        .end_object();
      json.begin_object("timings_s");
      for (const auto &[phase, seconds] : results.timings_s)
        json.value(phase, seconds);
      json.end_object();
      json.end_object();
    });
  }
} // namespace modal_haptics
