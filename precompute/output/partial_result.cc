#include "output/partial_result.h"

#include "output/atomic_file.h"

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

// Every field of the results a space computes, written and read through the field lists of
// ModalBasis and SpaceDiagnostics (modal_space.h); the process-local rows are not written.
// test_scenario_jobs.py compares a merged scene with a whole-scene run, .h5, .mrt and report.json.
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
  void serialize(Archive &ar, modal_haptics::TwoContactCheck &c, const unsigned int)
  {
    ar &c.vertices &c.distance &c.rel_error_corrected &c.far &c.named &c.rel_error_without_cross;
  }

  template <class Archive>
  void serialize(Archive &ar, modal_haptics::FarFieldBand &b, const unsigned int)
  {
    ar &b.from &b.to &b.pairs &b.median_error &b.p95_error &b.max_error &b.median_modes_alone &b.p95_modes_alone;
  }

  template <class Archive>
  void serialize(Archive &ar, modal_haptics::ValidityCurve::SeriesEstimate &e, const unsigned int)
  {
    ar &e.c2 &e.c3 &e.validity_force;
  }

  template <class Archive>
  void serialize(Archive &ar, modal_haptics::ValidityCurve &c, const unsigned int)
  {
    ar &c.vertex &c.direction &c.material &c.linear_compliance &c.forces &c.displacements &c.newton_iterations;
    ar &c.newton_residuals &c.newton_felt_errors &c.force_limit &c.force_reached &c.stop_reason &c.validity_force &c.seconds;
    ar &c.estimate_exact &c.estimate_modal &c.estimate_third_order &c.estimate_seconds &c.cubic_term_check
      &c.modal_cubic_check &c.quadratic_term_check;
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
    const auto field = [&ar](const char *, auto &value) { ar &value; };
    modal_haptics::ModalBasis::for_each_field(s, field);
    modal_haptics::SpaceDiagnostics::for_each_field(s, field);
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
    const std::string format_line = "modal-haptics partial result, format 6";
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
