// modal-study's outputs: reference.csv (and force_curves.csv with a force axis) and study.csv (rewritten after every point, so that a long
// study that stops keeps what it measured), then study.md and the plots by scripts/study_report.py.
#include "output/atomic_file.h"
#include "study/modal_study.h"

#include <algorithm>
#include <filesystem>
#include <iomanip>

namespace modal_haptics
{
  namespace fs = std::filesystem;

  void write_reference_table(const std::string &output_directory, const std::vector<ReferenceSolution> &references)
  {
    write_file_atomically(output_directory + "/reference.csv", [&](std::ostream &out) {
      out << "patch_radius,n_dofs,seconds,contact,vertex,felt_compliance_m_per_n,validity_force_1_percent_n,"
             "validity_force_5_percent_n,validity_force_10_percent_n,frequencies_hz\n"
          << std::setprecision(10);
      for (const auto &reference : references)
        for (std::size_t k = 0; k < reference.contacts.size(); ++k)
          {
            out << reference.patch_radius << ',' << reference.n_dofs << ',' << reference.seconds << ',' << k + 1
                << ',' << reference.contacts[k].vertex << ','
                << along(reference.contacts[k].full, reference.contacts[k].direction) << ',';
            for (unsigned int level = 0; level < 3; ++level) // empty without a force axis, inf when not reached
              {
                if (k < reference.curves.size())
                  out << reference.curves[k].validity_force[level];
                out << ',';
              }
            for (std::size_t i = 0; i < reference.frequencies_hz.size(); ++i)
              out << (i ? ";" : "") << reference.frequencies_hz[i];
            out << '\n';
          }
    });
    if (std::none_of(references.begin(), references.end(), [](const auto &r) { return !r.curves.empty(); }))
      return;
    write_file_atomically(output_directory + "/force_curves.csv", [&](std::ostream &out) {
      out << "patch_radius,contact,vertex,force_n,felt_displacement_m,linear_compliance_m_per_n,stop_reason\n"
          << std::setprecision(12);
      for (const auto &reference : references)
        for (std::size_t k = 0; k < reference.curves.size(); ++k)
          {
            const auto &curve = reference.curves[k];
            for (std::size_t i = 0; i < curve.forces.size(); ++i)
              out << reference.patch_radius << ',' << k + 1 << ',' << reference.contacts[k].vertex << ','
                  << curve.forces[i] << ',' << curve.displacements[i] << ',' << curve.linear_compliance << ','
                  << (i + 1 == curve.forces.size() ? curve.stop_reason : std::string()) << '\n';
          }
    });
  }

  void write_study_table(const std::string &output_directory, const std::vector<StudyRow> &rows,
                         const std::vector<double> &force_levels)
  {
    write_file_atomically(output_directory + "/study.csv", [&](std::ostream &out) {
      out << "point,mesh,degree,coarse_size,fine_size,patch_radius,eigensolver,r_rule,modes,n_dofs,candidates,"
             "felt_error_modal,felt_error_corrected,felt_error_modal_3x3,felt_error_corrected_3x3,"
             "truncation_error,correction_residual,display_error_modal,frequency_error_first,frequency_error_max,"
             "frequencies_compared,meshing_s,assembly_s,eigensolve_s,static_correction_s,validation_s,offline_total_s,"
             "correction_ms_per_candidate,mrt_bytes,tick_p50_ns,tick_p99_ns,corrected_tick_p50_ns,"
             "corrected_tick_p99_ns,display_ms,display_vertices,corrected_felt_compliance_m_per_n";
      for (const double force : force_levels)
        out << ",felt_error_corrected_at_" << force << "_n,felt_error_modal_at_" << force << "_n";
      out << '\n' << std::setprecision(8);
      for (const auto &row : rows)
        {
          const auto &p = row.point;
          out << p.label() << ',' << p.mesh << ',' << p.degree << ',' << p.coarse_size << ',' << p.fine_size << ','
              << p.patch_radius << ',' << p.eigensolver << ',' << row.r_rule << ',' << row.r << ',' << row.n_dofs
              << ',' << row.candidates << ',' << row.felt_error_modal << ',' << row.felt_error_corrected << ','
              << row.felt_error_modal_3x3 << ',' << row.felt_error_corrected_3x3 << ',' << row.truncation_error
              << ',' << row.correction_residual << ',' << row.display_error_modal << ','
              << row.frequency_error_first << ',' << row.frequency_error_max << ',' << row.frequencies_compared;
          for (const auto phase : {"meshing", "assembly", "eigensolve", "static_correction", "validation", "total"})
            out << ',' << row.seconds.at(phase);
          out << ',' << row.correction_ms_per_candidate << ',' << row.mrt_bytes << ',' << row.kernel.tick_p50_ns << ','
              << row.kernel.tick_p99_ns << ',' << row.kernel.corrected_tick_p50_ns << ','
              << row.kernel.corrected_tick_p99_ns << ',' << row.kernel.display_ms << ','
              << row.kernel.display_vertices << ',';
          for (std::size_t k = 0; k < row.corrected_felt_compliance.size(); ++k)
            out << (k ? ";" : "") << row.corrected_felt_compliance[k];
          for (std::size_t level = 0; level < force_levels.size(); ++level)
            out << ',' << row.felt_error_corrected_at_force[level] << ',' << row.felt_error_modal_at_force[level];
          out << '\n';
        }
    });
  }

  // scripts/study_report.py: study.md and the plots. Installed in <prefix>/share/modal-haptics/scripts
  // (found from <prefix>/bin/modal-study), else in the scripts/ folder of the source tree this program
  // was built from (the build passes both places).
  int write_report(const std::string &output_directory)
  {
    const fs::path script = find_companion("study_report.py", {MODAL_HAPTICS_SCRIPTS_FROM_BIN},
                                           MODAL_HAPTICS_SCRIPTS_DIR, " (use --no-report)");
    return run_child({"/usr/bin/python3", script.string(), output_directory}, nullptr, " (use --no-report)");
  }
} // namespace modal_haptics
