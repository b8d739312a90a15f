// modal-study: what the real-time kernel (modalrt) costs on one basis file. No deal.II here but its
// exceptions (the study reports every error alike).
#include "study/modal_study.h"

#include <modalrt/modalrt.h>

#include <deal.II/base/exceptions.h>

#include <algorithm>
#include <chrono>

namespace modal_haptics
{
  using dealii::ExcMessage;

  namespace
  {
    void check_kernel(const int status, const std::string &what)
    {
      AssertThrow(status >= 0, ExcMessage("modalrt: " + what + " failed: " + modalrt_last_error_message()));
    }

    template <typename Work>
    double median_seconds(const unsigned int repetitions, const Work &work)
    {
      std::vector<double> seconds;
      for (unsigned int k = 0; k < repetitions; ++k)
        {
          const auto start = std::chrono::steady_clock::now();
          work();
          seconds.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
        }
      std::sort(seconds.begin(), seconds.end());
      return seconds[seconds.size() / 2];
    }

    // A kernel on `basis` with one HIP in contact at `vertex`, pushing with 1 N along `direction`.
    struct PressingKernel
    {
      modalrt_kernel   *kernel = nullptr;
      modalrt_hip_input input{};

      PressingKernel(const modalrt_basis *basis, const unsigned int vertex, const std::array<double, 3> &direction,
                     const bool corrected)
      {
        modalrt_kernel_def def    = modalrt_kernel_default_def();
        def.time_step             = 1e-3;
        def.hip_capacity          = 1;
        def.auto_release          = 0;
        def.use_static_correction = corrected ? 1 : 0;
        check_kernel(modalrt_kernel_create(basis, &def, &kernel), "kernel_create");
        check_kernel(modalrt_kernel_contact_begin(kernel, 0, vertex), "kernel_contact_begin");
        const double *rest = modalrt_basis_display_vertices(basis) + 3 * std::size_t(vertex);
        for (unsigned int c = 0; c < 3; ++c)
          input.position[c] = rest[c], input.force[c] = -direction[c];
      }
      ~PressingKernel() { modalrt_kernel_destroy(kernel); }
      PressingKernel(const PressingKernel &) = delete;
      PressingKernel &operator=(const PressingKernel &) = delete;

      int tick()
      {
        modalrt_hip_output output{};
        return modalrt_kernel_tick_admittance(kernel, &input, 1, &output);
      }

      // p50 and p99 [ns] of `ticks` ticks after a warm-up (caches, branch predictors, clock).
      std::array<double, 2> time_ticks(const unsigned int ticks)
      {
        for (unsigned int k = 0; k < ticks / 10; ++k)
          check_kernel(tick(), "kernel_tick_admittance");
        std::vector<double> nanoseconds(ticks);
        for (auto &ns : nanoseconds)
          {
            const auto start  = std::chrono::steady_clock::now();
            const int  status = tick();
            ns = std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - start).count();
            check_kernel(status, "kernel_tick_admittance");
          }
        std::sort(nanoseconds.begin(), nanoseconds.end());
        return {{nanoseconds[ticks / 2], nanoseconds[std::size_t(ticks) * 99 / 100]}};
      }
    };
  } // namespace

  KernelCost measure_kernel(const std::string &basis_file, const Contact &contact, const unsigned int ticks)
  {
    modalrt_thread_enable_flush_to_zero();
    modalrt_basis *basis = nullptr;
    check_kernel(modalrt_basis_load(basis_file.c_str(), &basis), "basis_load(" + basis_file + ")");
    KernelCost cost;
    {
      PressingKernel plain(basis, contact.vertex, contact.direction, false);
      const auto     p = plain.time_ticks(ticks);
      cost.tick_p50_ns = p[0], cost.tick_p99_ns = p[1];
    }
    PressingKernel corrected(basis, contact.vertex, contact.direction, true);
    const auto     p = corrected.time_ticks(ticks);
    cost.corrected_tick_p50_ns = p[0], cost.corrected_tick_p99_ns = p[1];

    // The display of the pressed part: every vertex, static correction near the contact included.
    modalrt_basis_info info{};
    check_kernel(modalrt_basis_get_info(basis, &info), "basis_get_info");
    cost.display_vertices = info.display_vertex_count;
    modalrt_snapshot *snapshot = nullptr;
    check_kernel(modalrt_snapshot_create(corrected.kernel, &snapshot), "snapshot_create");
    check_kernel(modalrt_kernel_snapshot_read(corrected.kernel, snapshot), "kernel_snapshot_read");
    std::vector<float> displacements(3 * std::size_t(info.display_vertex_count));
    cost.display_ms = 1e3 * median_seconds(15, [&] {
                        check_kernel(modalrt_display_reconstruct(snapshot, 0, info.display_vertex_count, 0,
                                                                 displacements.data()),
                                     "display_reconstruct");
                      });
    modalrt_snapshot_destroy(snapshot);
    modalrt_basis_destroy(basis);
    return cost;
  }
} // namespace modal_haptics
