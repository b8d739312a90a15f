// modal-study: what the real-time kernel costs on one basis file. The precompute never includes the
// kernel (docs/architecture.md): bench-basis-cost (benchmarks/realtime), a program of the kernel's
// side, times it and prints one JSON line, which this file reads. No deal.II here but its exceptions.
#include "study/modal_study.h"

#include <deal.II/base/exceptions.h>

#include <nlohmann/json.hpp>

#include <iomanip>

namespace modal_haptics
{
  using dealii::ExcMessage;

  namespace
  {
    // bench-basis-cost's line: {"tick_p50_ns": .., ..., "display_vertices": ..}.
    KernelCost parse_kernel_cost(const std::string &line, const std::string &program)
    {
      try
        {
          const auto json = nlohmann::json::parse(line);
          KernelCost cost;
          cost.tick_p50_ns           = json.at("tick_p50_ns").get<double>();
          cost.tick_p99_ns           = json.at("tick_p99_ns").get<double>();
          cost.corrected_tick_p50_ns = json.at("corrected_tick_p50_ns").get<double>();
          cost.corrected_tick_p99_ns = json.at("corrected_tick_p99_ns").get<double>();
          cost.display_ms            = json.at("display_ms").get<double>();
          cost.display_vertices      = json.at("display_vertices").get<unsigned int>();
          return cost;
        }
      catch (const nlohmann::json::exception &e)
        {
          AssertThrow(false, ExcMessage(program + " printed what modal-study cannot read (" + e.what() + "): '" +
                                        line + "'"));
        }
      return {};
    }
  } // namespace

  // bench-basis-cost installed in <prefix>/libexec/modal-haptics (found from <prefix>/bin/modal-study),
  // beside this program, or where the build put it (the build passes both places).
  KernelCost measure_kernel(const std::string &basis_file, const Contact &contact, const unsigned int ticks)
  {
    const std::string program =
      find_companion("bench-basis-cost", {".", MODAL_HAPTICS_HELPERS_FROM_BIN}, MODAL_HAPTICS_HELPERS_DIR, "").string();
    std::ostringstream direction;
    direction << std::setprecision(17) << contact.direction[0] << ',' << contact.direction[1] << ','
              << contact.direction[2];
    std::string line;
    const int   status = run_child({program, "--basis", basis_file, "--vertex", std::to_string(contact.vertex),
                                    "--direction", direction.str(), "--ticks", std::to_string(ticks)},
                                   &line, "");
    AssertThrow(status == 0, ExcMessage(program + " failed on " + basis_file + " (exit status " +
                                        std::to_string(status) + "; its message is above)."));
    return parse_kernel_cost(line, program);
  }
} // namespace modal_haptics
