#include "partial_result.h"

#include "atomic_file.h"

#include <deal.II/base/exceptions.h>

#include <boost/archive/archive_exception.hpp>
#include <boost/archive/binary_iarchive.hpp>
#include <boost/archive/binary_oarchive.hpp>
#include <boost/serialization/array.hpp>
#include <boost/serialization/map.hpp>
#include <boost/serialization/string.hpp>
#include <boost/serialization/utility.hpp>
#include <boost/serialization/vector.hpp>

#include <mrt/crc32.h>

#include <filesystem>
#include <fstream>
#include <iterator>

// Every field of the results a space computes, in one place for writing and reading. A field added
// to ModalSpaceResult and not here is missing from merged files: test_scenario_jobs.py compares a
// merged scene with a whole-scene run, .h5, .mrt and report.json.
namespace boost::serialization
{
  template <class Archive>
  void serialize(Archive &ar, modal_haptics::DroppedMode &m, const unsigned int)
  {
    ar &m.index &m.frequency &m.reason;
  }

  template <class Archive>
  void serialize(Archive &ar, modal_haptics::ValidationCase &v, const unsigned int)
  {
    ar &v.vertex &v.direction &v.full_response &v.contact_rel_error_modal &v.contact_rel_error_corrected;
    ar &v.field_rel_error_modal &v.field_max_error_modal &v.field_rel_error_corrected &v.field_rel_error_by_modes;
    ar &v.correction_field_vertices &v.energy_rel_error_modal &v.solve_relative_residual;
  }

  template <class Archive>
  void serialize(Archive &ar, modal_haptics::EigenSelfCheck &c, const unsigned int)
  {
    ar &c.orthonormality_error &c.max_relative_residual;
  }

  template <class Archive>
  void serialize(Archive &ar, modal_haptics::FactorizationStatistics &f, const unsigned int)
  {
    ar &f.method &f.analyze_seconds &f.factorize_seconds &f.factor_nonzeros &f.factor_flops &f.solve_seconds;
    ar &f.n_solved_vectors &f.solve_threads;
  }

  template <class Archive>
  void serialize(Archive &ar, modal_haptics::ModalSpaceResult &s, const unsigned int)
  {
    ar &s.name &s.index &s.degree &s.n_vertices &s.n_cells &s.n_dofs &s.n_clamped_dofs;
    ar &s.mesh_vertices &s.mesh_tets &s.clamped_dofs;
    ar &s.computed_frequencies_hz &s.eigenvalues &s.frequencies_hz &s.damping_ratios &s.dropped_modes &s.cut_off_hz;
    ar &s.self_check &s.n_spurious_rows;
    ar &s.modes_at_vertices &s.display_modes;
    ar &s.candidates &s.candidate_modes &s.candidate_compliance &s.cross_compliance &s.full_compliance;
    ar &s.participation &s.mass &s.centre_of_mass &s.inertia &s.validation &s.two_contact_rel_error_corrected;
    ar &s.n_rigid_body_modes &s.rigid_computed_frequencies_hz &s.rigid_subspace_sine &s.static_solve_iterations;
    ar &s.factorization &s.eigensolver_method &s.n_operator_applications &s.arpack_seconds;
    ar &s.mass_product_seconds &s.orthogonalization_seconds;
    ar &s.correction_seconds_per_candidate &s.timings_s;
  }

  template <class Archive>
  void serialize(Archive &ar, modal_haptics::PartialResult &p, const unsigned int)
  {
    ar &p.scene_name &p.parameters &p.display_checksum &p.mesh_checksum &p.n_processes &p.peak_memory_mb;
    ar &p.seconds &p.space;
  }
} // namespace boost::serialization

namespace modal_haptics
{
  namespace
  {
    // The first line of every partial result file; a new layout of the archive gets a new number.
    const std::string format_line = "modal-haptics partial result, format 1";
  } // namespace

  std::string partial_result_file(const std::string &directory, const std::string &scenario)
  {
    return (std::filesystem::path(directory) / (scenario + ".partial")).string();
  }

  void write_partial_result(const std::string &filename, const PartialResult &partial)
  {
    write_file_atomically(
      filename,
      [&](std::ostream &out) {
        out << format_line << '\n';
        boost::archive::binary_oarchive archive(out);
        archive << partial;
      },
      std::ios::binary);
  }

  PartialResult read_partial_result(const std::string &filename)
  {
    std::ifstream in(filename, std::ios::binary);
    AssertThrow(in, dealii::ExcMessage("Cannot read the partial result '" + filename + "'."));
    std::string first_line;
    std::getline(in, first_line);
    AssertThrow(first_line == format_line,
                dealii::ExcMessage("'" + filename + "' is not a partial result of this modal-precompute (its first "
                                   "line is not '" + format_line + "')."));
    PartialResult partial;
    try
      {
        boost::archive::binary_iarchive archive(in);
        archive >> partial;
      }
    catch (const boost::archive::archive_exception &e)
      {
        AssertThrow(false, dealii::ExcMessage("The partial result '" + filename + "' cannot be read (" + e.what() +
                                              "): truncated, or written by another build of modal-precompute."));
      }
    return partial;
  }

  std::uint32_t display_surface_checksum(const meshing::DisplaySurface &surface)
  {
    std::uint32_t crc = 0;
    for (const auto &vertex : surface.vertices)
      crc = mrt::crc32_update(crc, vertex.data(), sizeof(vertex));
    for (const auto &triangle : surface.triangles)
      crc = mrt::crc32_update(crc, triangle.data(), sizeof(triangle));
    return crc;
  }

  std::uint32_t file_checksum(const std::string &filename)
  {
    std::ifstream in(filename, std::ios::binary);
    AssertThrow(in, dealii::ExcMessage("Cannot read '" + filename + "'."));
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    return mrt::crc32(bytes.data(), bytes.size());
  }
} // namespace modal_haptics
