// The exporters of the kernel's .mrt basis file (docs/basis-format.md) and report.json
// (docs/report-schema.md), each written to a temporary file and renamed (the HDF5 file's:
// hdf5_export.cc).
#include "output/atomic_file.h"
#include "output/exporters.h"
#include "output/vtu_file.h"
#include "solvers/factorization.h"
#include "results/quantile.h"

#include <deal.II/base/mpi.h>

#include <mrt/writer.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <iomanip>

namespace modal_haptics
{
  using dealii::ExcMessage;

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
          space.cross_offsets.assign(s.cross_offsets.begin(), s.cross_offsets.end());
          space.cross_neighbours.assign(s.cross_neighbours.begin(), s.cross_neighbours.end());
          space.cross_blocks         = s.cross_blocks;
          space.far_compliance       = s.far_compliance;
          space.felt_stiffness       = s.felt_stiffness;
          space.validity_force       = s.validity_force;
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
  // report.json, written by nlohmann/json: keys in the order given here (ordered_json), doubles in
  // the shortest form that reads back to the same double, non-finite numbers as null (the library's
  // dump writes NaN and infinities as null).
  // ---------------------------------------------------------------------------------------------
  namespace
  {
    using Json = nlohmann::ordered_json;

    std::uintmax_t file_size(const std::string &name)
    {
      std::error_code error;
      const auto      size = std::filesystem::file_size(name, error);
      return error ? 0 : size;
    }

    Json validation_json(const std::vector<ValidationCase> &cases)
    {
      Json validation = Json::array();
      for (const auto &vc : cases)
        validation.push_back({{"vertex", vc.vertex},
                              {"direction", std::string(1, "xyz"[vc.direction])},
                              {"full_contact_response_m_per_n", vc.full_response},
                              {"contact_rel_error_modal", vc.contact_rel_error_modal},
                              {"contact_rel_error_corrected", vc.contact_rel_error_corrected},
                              {"field_rel_error_modal", vc.field_rel_error_modal},
                              {"field_max_error_modal", vc.field_max_error_modal},
                              {"field_rel_error_corrected", vc.field_rel_error_corrected},
                              {"correction_field_vertices", vc.correction_field_vertices},
                              {"energy_rel_error_modal", vc.energy_rel_error_modal},
                              {"solve_relative_residual", vc.solve_relative_residual}});
      return validation;
    }

    // A validity departure (validity_departures[k]) in percent: 1, 5, 10.
    int departure_percent(const std::size_t k) { return int(std::lround(100. * validity_departures[k])); }

    // {"1_percent": F1, "5_percent": F5, "10_percent": F10}; infinity (not reached) is null.
    Json forces_json(const std::array<double, 3> &forces)
    {
      Json json = Json::object();
      for (unsigned int k = 0; k < validity_departures.size(); ++k)
        json[std::to_string(departure_percent(k)) + "_percent"] = forces[k];
      return json;
    }

    // An estimate at a validity contact and its relative error against the full solve's forces
    // (null where either is not reached: the full one beyond the force limit or where it stopped).
    Json estimate_json(const ValidityCurve::SeriesEstimate &estimate, const ValidityCurve &curve)
    {
      Json error = Json::object();
      for (unsigned int k = 0; k < validity_departures.size(); ++k)
        {
          const double full = curve.validity_force[k], e = estimate.validity_force[k];
          const bool   reached = std::isfinite(full) && (curve.stop_reason.empty() || full < curve.force_reached);
          error[std::to_string(departure_percent(k)) + "_percent"] =
            reached && std::isfinite(e) ? Json(e / full - 1.) : Json();
        }
      Json json = {{"c2_m_per_n2", estimate.c2},
                   {"validity_force_n", forces_json(estimate.validity_force)},
                   {"rel_error", error}};
      if (estimate.c3 != 0.)
        json["c3_m_per_n3"] = estimate.c3;
      return json;
    }

    // The nonlinear solves at the validity contacts (docs/report-schema.md, "validity").
    Json validity_json(const std::vector<ValidityCurve> &curves)
    {
      Json validity = Json::array();
      for (const auto &c : curves)
        {
          const Json forces = forces_json(c.validity_force);
          validity.push_back({{"vertex", c.vertex},
                              {"direction", c.direction},
                              {"material", c.material},
                              {"linear_compliance_m_per_n", c.linear_compliance},
                              {"force_limit_n", c.force_limit},
                              {"force_reached_n", c.force_reached},
                              {"stop_reason", c.stop_reason.empty() ? Json() : Json(c.stop_reason)},
                              {"validity_force_n", forces},
                              {"force_n", c.forces},
                              {"displacement_m", c.displacements},
                              {"newton_iterations", c.newton_iterations},
                              {"newton_residuals", c.newton_residuals},
                              {"newton_felt_errors", c.newton_felt_errors},
                              {"seconds", c.seconds},
                              {"second_order_exact", estimate_json(c.estimate_exact, c)},
                              {"second_order_modal", estimate_json(c.estimate_modal, c)},
                              {"third_order_exact", estimate_json(c.estimate_third_order, c)},
                              {"estimate_s", c.estimate_seconds},
                              {"cubic_term_check", c.cubic_term_check},
                              {"modal_cubic_check", c.modal_cubic_check},
                              {"quadratic_term_check", c.quadratic_term_check}});
        }
      return validity;
    }

    Json mesh_json(const meshing::ScenarioMesh &mesh)
    {
      return {{"file", std::filesystem::path(mesh.msh_file).filename().string()},
              {"n_nodes", mesh.statistics.n_nodes},
              {"n_tets", mesh.statistics.n_tets},
              {"min_quality", mesh.statistics.min_quality},
              {"mean_quality", mesh.statistics.mean_quality},
              {"max_quality", mesh.statistics.max_quality},
              {"reused", mesh.statistics.reused},
              {"made_in_child_process", mesh.statistics.made_in_child_process},
              {"seconds", mesh.statistics.seconds}};
    }

    Json eigensolver_json(const ModalSpaceResult &s)
    {
      return {{"method", s.eigensolver_method + " + " + s.factorization.method},
              {"factor_nonzeros", s.factorization.factor_nonzeros},
              {"factor_flops", s.factorization.factor_flops},
              {"analyze_s", s.factorization.analyze_seconds},
              {"factorize_s", s.factorization.factorize_seconds},
              {"arpack_s", s.eigensolve_iteration_seconds},
              {"operator_applications", s.n_operator_applications},
              {"solved_vectors", s.factorization.n_solved_vectors},
              {"solve_s", s.factorization.solve_seconds},
              {"solve_threads", s.factorization.solve_threads},
              {"mass_products_s", s.mass_product_seconds},
              {"orthogonalization_s", s.orthogonalization_seconds}};
    }

    Json static_correction_json(const ModalSpaceResult &s, const SceneParameters &scene)
    {
      const std::size_t r = s.eigenvalues.size(), nc = s.candidates.size(), pairs = s.cross_neighbours.size();
      const std::size_t bytes = 4 * nc + 8 * (3 * r + 9 + 3 * s.far_rank) * nc +
                                (s.cross_offsets.empty() ? 0 : 4 * (nc + 1) + 76 * pairs);
      return {{"n_candidates", nc},
              {"cross_compliance", !s.cross_offsets.empty()},
              {"cross_compliance_radius_m", scene.contact.cross_compliance ? scene.contact.cross_compliance_radius * scene.length_unit : 0.},
              {"cross_compliance_pairs", pairs},
              {"seconds_per_load", s.correction_seconds_per_candidate},
              {"refinement_steps", s.static_solve_iterations},
              {"bytes_per_candidate", nc ? bytes / nc : 0}};
    }

    // The far-field coupling: its rank and cost, and its error by distance against exact columns.
    Json far_field_json(const ModalSpaceResult &s)
    {
      Json bands = Json::array();
      for (const auto &b : s.far_field_bands)
        bands.push_back({{"from_m", b.from},
                         {"to_m", b.to > 1e29 ? Json() : Json(b.to)},
                         {"pairs", b.pairs},
                         {"median_error", b.median_error},
                         {"p95_error", b.p95_error},
                         {"max_error", b.max_error},
                         {"median_modes_alone", b.median_modes_alone},
                         {"p95_modes_alone", b.p95_modes_alone}});
      Json far = {{"rank", s.far_rank},
                  {"seconds", s.far_field_seconds},
                  {"sampled_vertices", s.far_field_sampled},
                  {"rms_error", s.far_field_rms_error},
                  {"rms_modes_alone", s.far_field_rms_modes_alone},
                  {"error_by_distance", bands}};
      if (!s.far_field_left_out.empty())
        far["left_out"] = s.far_field_left_out;
      return far;
    }

    // The coordinate axis nearest to a unit vector: "+z", "-x", ...
    std::string nearest_axis(const std::array<double, 3> &n)
    {
      const auto by_magnitude = [](const double a, const double b) { return std::abs(a) < std::abs(b); };
      const int  axis         = int(std::max_element(n.begin(), n.end(), by_magnitude) - n.begin());
      return std::string(n[axis] < 0. ? "-" : "+") + "xyz"[axis];
    }

    // The felt-stiffness map of a space over its own region (its VOI; the global space: outside every
    // VOI): the range, what the modes alone would give at the same vertices, the softest and the
    // stiffest spots.
    Json felt_stiffness_json(const ModalSpaceResult &s, const ContactSurface &display)
    {
      std::vector<unsigned int> region;
      for (unsigned int v = 0; v < s.felt_stiffness.size(); ++v)
        if (display.region[v] == s.index && s.felt_stiffness[v] > 0.)
          region.push_back(v);
      if (region.empty())
        return nullptr;
      std::sort(region.begin(), region.end(), [&](const unsigned int a, const unsigned int b) {
        return s.felt_stiffness[a] < s.felt_stiffness[b];
      });
      std::vector<double> ratios; // modal-only over felt
      for (const unsigned int v : region)
        if (s.modal_only_stiffness[v] > 0.)
          ratios.push_back(s.modal_only_stiffness[v] / s.felt_stiffness[v]);
      std::sort(ratios.begin(), ratios.end());
      // Where a spot faces says which way it is pressed (along -normal): in a box region the softest
      // spot may be on the plate's underside or on a rib's side.
      const std::vector<double> normals = vertex_normals(display);
      const auto                spot    = [&](const unsigned int v) {
        const std::array<double, 3> n{{normals[3 * v], normals[3 * v + 1], normals[3 * v + 2]}};
        return Json{{"vertex", v},
                    {"position_m", display.vertices[v]},
                    {"normal", n},
                    {"facing", nearest_axis(n)},
                    {"stiffness_n_per_mm", s.felt_stiffness[v] * 1e-3},
                    {"modal_only_n_per_mm", s.modal_only_stiffness[v] * 1e-3}};
      };
      Json softest = Json::array(), stiffest = Json::array();
      for (std::size_t k = 0; k < std::min<std::size_t>(5, region.size()); ++k)
        {
          softest.push_back(spot(region[k]));
          stiffest.push_back(spot(region[region.size() - 1 - k]));
        }
      const auto ratio_at = [&](const double q) { return ratios.empty() ? 0. : ratios[quantile_rank(ratios.size(), q)]; };
      const std::size_t off_by_8_percent =
        std::count_if(ratios.begin(), ratios.end(), [](const double x) { return std::abs(x - 1.) > 0.08; });
      return {{"n_vertices", region.size()},
              {"min_n_per_mm", s.felt_stiffness[region.front()] * 1e-3},
              {"median_n_per_mm", s.felt_stiffness[region[quantile_rank(region.size(), 0.5)]] * 1e-3},
              {"max_n_per_mm", s.felt_stiffness[region.back()] * 1e-3},
              {"modal_only_ratio_median", ratio_at(0.5)},
              {"modal_only_ratio_max", ratio_at(1.)},
              {"modal_only_off_by_more_than_8_percent", ratios.empty() ? 0. : double(off_by_8_percent) / ratios.size()},
              {"softest", softest},
              {"stiffest", stiffest}};
    }

    // The validity map over the space's region: its distribution (quantiles of each force, not
    // reached counted apart) and the lowest 1 % forces with their positions.
    Json validity_map_json(const ModalSpaceResult &s, const ContactSurface &display)
    {
      if (s.validity_force.empty())
        return s.validity_left_out.empty() ? Json() : Json({{"left_out", s.validity_left_out}});
      std::vector<unsigned int> region;
      for (unsigned int v = 0; v < display.n_vertices(); ++v)
        if (display.region[v] == s.index && s.validity_force[3 * v] > 0.)
          region.push_back(v);
      Json map = {{"n_contacts", region.size()},
                  {"n_estimated_contacts", s.validity_estimated_contacts},
                  {"tensor_s", s.validity_tensor_seconds},
                  {"per_contact_s", s.validity_seconds_per_contact}};
      if (region.empty())
        return map;
      for (unsigned int k = 0; k < validity_departures.size(); ++k)
        {
          std::vector<double> forces;
          for (const unsigned int v : region)
            forces.push_back(s.validity_force[3 * v + k]);
          std::sort(forces.begin(), forces.end());
          const auto at = [&](const double q) { return forces[quantile_rank(forces.size(), q)]; };
          map[std::to_string(departure_percent(k)) + "_percent"] = {
            {"min_n", at(0.)},       {"q05_n", at(0.05)}, {"q25_n", at(0.25)}, {"median_n", at(0.5)},
            {"q75_n", at(0.75)},     {"max_n", at(1.)},
            {"not_reached", std::count(forces.begin(), forces.end(), validity_not_reached)}};
        }
      std::sort(region.begin(), region.end(), [&](const unsigned int a, const unsigned int b) {
        return s.validity_force[3 * a] < s.validity_force[3 * b];
      });
      Json lowest = Json::array();
      for (std::size_t k = 0; k < std::min<std::size_t>(5, region.size()); ++k)
        {
          const unsigned int v = region[k];
          lowest.push_back({{"vertex", v},
                            {"position_m", display.vertices[v]},
                            {"validity_force_n", {s.validity_force[3 * v], s.validity_force[3 * v + 1], s.validity_force[3 * v + 2]}}});
        }
      map["lowest"] = lowest;
      return map;
    }

    // The modes and how they were chosen: from "n_modes" to "rigid_body_modes" in the schema.
    void add_modes(Json &space, const ModalSpaceResult &s)
    {
      space["n_modes"]                 = s.eigenvalues.size();
      space["frequencies_hz"]          = s.frequencies_hz;
      space["computed_frequencies_hz"] = s.computed_frequencies_hz;
      space["damping_ratios"]          = s.damping_ratios;
      space["cut_off_hz"]              = s.cut_off_hz;
      Json &dropped                    = space["dropped_modes"] = Json::array();
      for (const auto &dm : s.dropped_modes)
        dropped.push_back({{"index", dm.index}, {"frequency_hz", dm.frequency}, {"reason", dm.reason}});
      space["supports"]         = s.supports_summary;
      space["rigid_body_modes"] = {{"count", s.n_rigid_body_modes},
                                   {"free_motions", s.free_motions},
                                   {"computed_frequencies_hz", s.rigid_computed_frequencies_hz},
                                   {"subspace_distance", s.rigid_subspace_sine}};
    }

    Json space_json(const ModalSpaceResult &s, const meshing::ScenarioMesh &mesh, const SceneParameters &scene,
                    const ContactSurface &display)
    {
      Json space = {{"name", s.name},         {"index", s.index},   {"n_vertices", s.n_vertices},
                    {"n_cells", s.n_cells},   {"n_dofs", s.n_dofs}, {"degree", s.degree},
                    {"n_clamped_dofs", s.n_clamped_dofs}};
      space["mesh"] = mesh_json(mesh);
      add_modes(space, s);
      space["orthonormality_error"]  = s.self_check.orthonormality_error;
      space["max_relative_residual"] = s.self_check.max_relative_residual;
      space["spurious_eigenvalues"]  = "none: the " + std::to_string(s.n_spurious_rows) +
                                      " constrained rows have M_ii = 0, which puts their eigenvalues at infinity";
      space["eigensolver"]       = eigensolver_json(s);
      space["static_correction"] = static_correction_json(s, scene);
      space["felt_stiffness"]    = felt_stiffness_json(s, display);
      if (!s.far_field_sampled.empty())
        space["far_field"] = far_field_json(s);
      space["mass_kg"]           = s.mass;
      space["centre_of_mass_m"]  = s.centre_of_mass;
      space["validation"]        = validation_json(s.validation);
      if (!s.validity.empty())
        space["validity"] = validity_json(s.validity);
      if (const Json map = validity_map_json(s, display); !map.is_null())
        space["validity_map"] = map;
      if (s.two_contact_rel_error_corrected >= 0.)
        space["two_contact_rel_error_corrected"] = s.two_contact_rel_error_corrected;
      Json &pairs = space["two_contact_checks"] = Json::array();
      for (const auto &check : s.two_contact_checks)
        pairs.push_back({{"vertices", check.vertices},
                         {"distance_m", check.distance},
                         {"rel_error_corrected", check.rel_error_corrected},
                         {"far", check.far},
                         {"named", check.named},
                         {"rel_error_without_cross", check.rel_error_without_cross}});
      space["timings_s"] = Json(s.timings_s);
      return space;
    }

    // The same display vertex felt from each space: the accuracy a VOI buys over the global space.
    Json cross_space_json(const PrecomputeResults &results)
    {
      Json        cross_space = Json::array();
      const auto &global      = results.spaces.front();
      for (const auto &[vertex, G_global] : global.full_compliance)
        for (const auto &s : results.spaces)
          {
            if (s.index == 0 || s.full_compliance.count(vertex) == 0)
              continue;
            const auto &G    = s.full_compliance.at(vertex);
            double      diff = 0., norm = 0.;
            for (unsigned int k = 0; k < 9; ++k)
              diff += std::pow(G_global[k] - G[k], 2), norm += G[k] * G[k];
            cross_space.push_back({{"vertex", vertex},
                                   {"region", results.spaces[results.display.region[vertex]].name},
                                   {"space", s.name},
                                   {"compliance_m_per_n", G},
                                   {"global_compliance_m_per_n", G_global},
                                   {"global_rel_difference", std::sqrt(diff / norm)}});
          }
      return cross_space;
    }

    // What every space stands on: from "schema_version" to "display_surface" in the schema.
    Json scene_json(const SceneParameters &scene, const PrecomputeResults &results)
    {
      const auto &d    = results.display;
      const auto  blas = running_blas_kernels();
      return {{"schema_version", "1.0"},
              {"scene", scene.scene_name},
              {"parameter_file", scene.parameter_file},
              {"geometry", scene.meshing.geometry},
              {"element_degree", scene.element_degree},
              {"processes",
               {{"count", results.n_processes},
                {"max_peak_memory_mb", results.max_peak_memory_mb},
                {"blas_kernels", blas.core},
                {"blas_thread_timeout", blas.spin_exponent}}},
              {"material",
               {{"youngs_modulus_pa", scene.material.youngs_modulus},
                {"poissons_ratio", scene.material.poissons_ratio},
                {"density_kg_m3", scene.material.density}}},
              {"display_surface",
               {{"n_vertices", d.n_vertices()},
                {"n_triangles", d.triangles.size()},
                {"patch_radius_m", d.patch_radius},
                {"max_patch_size", d.max_patch_size}}}};
    }
  } // namespace

  namespace
  {
    // The display surface's vertices and triangles, the Cells of its VTU. Float32 as the mode
    // shapes' files: a map to look at (the .h5 holds the doubles), half the bytes of Float64.
    vtu_file::Grid display_surface_grid(const ContactSurface &d)
    {
      vtu_file::Grid grid;
      grid.n_points = d.n_vertices();
      grid.n_cells  = d.triangles.size();
      std::vector<float>        points;
      std::vector<std::int32_t> connectivity, offsets;
      for (const auto &x : d.vertices)
        points.insert(points.end(), {float(x[0]), float(x[1]), float(x[2])});
      for (const auto &t : d.triangles)
        {
          connectivity.insert(connectivity.end(), {std::int32_t(t[0]), std::int32_t(t[1]), std::int32_t(t[2])});
          offsets.push_back(std::int32_t(connectivity.size()));
        }
      grid.points       = vtu_file::owned_array("", 3, std::move(points));
      grid.connectivity = vtu_file::owned_array("connectivity", 1, std::move(connectivity));
      grid.offsets      = vtu_file::owned_array("offsets", 1, std::move(offsets));
      grid.types        = vtu_file::owned_array("types", 1, std::vector<std::uint8_t>(d.triangles.size(), 5)); // VTK_TRIANGLE
      return grid;
    }

    // The display surface with point arrays (name, one value per vertex) and each vertex's region.
    void write_display_surface_vtu(const std::string &filename, const PrecomputeResults &results,
                                   const std::vector<std::pair<std::string, std::vector<double>>> &arrays,
                                   StagedFiles &staged)
    {
      const auto &d    = results.display;
      auto        grid = display_surface_grid(d);
      grid.point_data.push_back(vtu_file::owned_array(
        "region", 1, std::vector<std::uint32_t>(d.region.begin(), d.region.end())));
      for (const auto &[name, values] : arrays)
        grid.point_data.push_back(vtu_file::owned_array(name, 1, std::vector<float>(values.begin(), values.end())));
      staged.write(filename, [&](std::ostream &out) { vtu_file::write(out, grid); }, std::ios::out | std::ios::binary);
    }
  } // namespace

  void write_felt_stiffness_vtu(const std::string &filename, const PrecomputeResults &results, StagedFiles &staged)
  {
    std::vector<std::pair<std::string, std::vector<double>>> arrays;
    for (const auto &s : results.spaces)
      for (const auto &[label, map] : {std::make_pair("felt stiffness ", &s.felt_stiffness),
                                       std::make_pair("modal-only stiffness ", &s.modal_only_stiffness)})
        {
          arrays.emplace_back(label + s.name + " [N/mm]", *map);
          for (double &k : arrays.back().second)
            k *= 1e-3;
        }
    write_display_surface_vtu(filename, results, arrays, staged);
  }

  void write_validity_vtu(const std::string &filename, const PrecomputeResults &results, StagedFiles &staged)
  {
    std::vector<std::pair<std::string, std::vector<double>>> arrays;
    for (const auto &s : results.spaces)
      if (!s.validity_force.empty())
        for (unsigned int k = 0; k < validity_departures.size(); ++k)
          {
            arrays.emplace_back("validity force " + std::to_string(departure_percent(k)) +
                                  " % " + s.name + " [N]",
                                std::vector<double>());
            for (std::size_t v = 0; v < results.display.n_vertices(); ++v)
              {
                const double f = s.validity_force[3 * v + k];
                arrays.back().second.push_back(f == validity_not_reached ? -1. : f);
              }
          }
    if (!arrays.empty())
      write_display_surface_vtu(filename, results, arrays, staged);
  }

  namespace
  {
    Json overrides_json(const std::vector<std::pair<std::string, std::string>> &overrides)
    {
      Json list = Json::array();
      for (const auto &[entry, value] : overrides)
        list.push_back({{"entry", entry}, {"value", value}});
      return list;
    }

    // The % differences of some vertices, against their noise floor.
    Json difference_json(const DifferenceFigures &f)
    {
      Json figures = f.name.empty() ? Json::object() : Json{{"name", f.name}};
      figures["compared_vertices"]     = f.compared_vertices;
      figures["percent"]               = {{"median", f.median_percent}, {"p95_abs", f.p95_abs_percent}, {"max_abs", f.max_abs_percent}};
      figures["noise_floor_percent"]   = f.noise_floor_percent;
      figures["beyond_noise_vertices"] = f.beyond_noise_vertices;
      figures["difference"]            = f.verdict;
      return figures;
    }

    // A felt-stiffness map against the base's (pipeline/design_comparison.h), stiffness in N/mm.
    Json map_comparison_json(const MapComparisonRecord &map)
    {
      Json largest = Json::array();
      for (const auto &d : map.largest)
        largest.push_back({{"vertex", d.vertex},
                           {"position_mm", {d.position_m[0] * 1e3, d.position_m[1] * 1e3, d.position_m[2] * 1e3}},
                           {"base_n_per_mm", d.base_n_per_m * 1e-3},
                           {"variant_n_per_mm", d.variant_n_per_m * 1e-3},
                           {"percent", d.percent},
                           {"match_distance_mm", d.match_distance_m * 1e3},
                           {"beyond_noise", d.beyond_noise}});
      Json regions = Json::array();
      for (const auto &region : map.regions)
        regions.push_back(difference_json(region));
      return {{"rule", map.rule},
              {"base_vertices", map.base_vertices},
              {"match_distance_mm", {{"max", map.max_match_distance_m * 1e3}, {"p95", map.p95_match_distance_m * 1e3}}},
              {"ratio", {{"min", map.ratio_min}, {"median", map.ratio_median}, {"max", map.ratio_max}}},
              {"all", difference_json(map.all)},
              {"regions", regions},
              {"largest_differences", largest}};
    }

    // The base's report: every variant against it and the noise floor; a variant's: what it is.
    Json design_json(const DesignRecord &design)
    {
      if (!design.variant_name.empty())
        return {{"name", design.variant_name}, {"base_folder", design.base_folder}, {"overrides", overrides_json(design.overrides)}};
      Json noise = {{"measured", design.noise_floor.measured}};
      if (design.noise_floor.measured)
        {
          noise["mesh_scale"]    = design.noise_floor.mesh_scale;
          noise["folder"]        = design.noise_floor.folder;
          noise["seconds"]       = design.noise_floor.seconds;
          Json &floors = noise["floor_percent"] = Json::object(); // per region
          for (const auto &region : design.noise_floor.map.regions)
            floors[region.name] = region.p95_abs_percent;
          noise["comparison"]    = map_comparison_json(design.noise_floor.map);
        }
      Json variants = Json::array();
      for (const auto &v : design.variants)
        variants.push_back({{"name", v.name},
                            {"folder", v.folder},
                            {"overrides", overrides_json(v.overrides)},
                            {"meshes_reused", v.meshes_reused},
                            {"seconds", v.seconds},
                            {"comparison", map_comparison_json(v.map)}});
      return {{"noise_floor", noise}, {"variants", variants}};
    }
  } // namespace

  void write_report(const std::string &filename, const SceneParameters &scene, const PrecomputeResults &results,
                    StagedFiles &staged)
  {
    Json report = scene_json(scene, results);
    Json &spaces = report["spaces"] = Json::array();
    for (std::size_t k = 0; k < results.spaces.size(); ++k)
      spaces.push_back(space_json(results.spaces[k], results.meshes.scenarios[k], scene, results.display));
    report["cross_space"] = cross_space_json(results);
    Json &transfer        = report["transfer"] = Json::array();
    for (const auto &t : results.transfers)
      transfer.push_back({{"to", results.spaces[t.to].name},
                          {"from", results.spaces[t.from].name},
                          {"relative_residual", t.relative_residual}});
    const std::string base = scene.output_directory + "/" + scene.scene_name;
    report["files"]        = {{"h5_bytes", file_size(staged.current_path(base + ".h5"))},
                              {"mrt_bytes", file_size(staged.current_path(base + ".mrt"))}};
    report["timings_s"]    = Json(results.timings_s);
    if (!results.design.empty()) // a scene without variants writes what it wrote before them
      report[results.design.variant_name.empty() ? "design_variants" : "design_variant"] = design_json(results.design);
    // A string that is not UTF-8 (a path in another encoding) is written with U+FFFD where its bytes
    // are not, instead of failing the whole report.
    const std::string text = report.dump(2, ' ', false, Json::error_handler_t::replace) + "\n";
    staged.write(filename, [&](std::ostream &out) { out << text; });
  }
} // namespace modal_haptics
