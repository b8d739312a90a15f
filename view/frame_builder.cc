#include "frame_builder.h"

#include "stiffness_map.h" // realtime/tools
#include "vertex_info.h"

#include "view_json.h"
#include "view_server.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace modalrt_view
{
  namespace
  {
    int histogram_bin(double us)
    {
      if (us < 500.0)
        return std::max(0, int(us * 10.0));
      return std::min(TickHistogram::bins - 1, TickHistogram::fine_bins + int((us - 500.0) / 10.0));
    }

    double histogram_bin_centre(int b)
    {
      return b < TickHistogram::fine_bins ? (b + 0.5) / 10.0 : 500.0 + (b - TickHistogram::fine_bins + 0.5) * 10.0;
    }
  } // namespace

  void TickHistogram::add(double us)
  {
    ++count[histogram_bin(us)];
    ++n;
    max_us = std::max(max_us, us);
  }

  double TickHistogram::percentile(double p) const
  {
    const std::uint64_t target = std::uint64_t(std::ceil(p * n));
    std::uint64_t       seen   = 0;
    for (int b = 0; b < bins; ++b)
      if ((seen += count[b]) >= target && target > 0)
        return b == bins - 1 ? max_us : std::min(histogram_bin_centre(b), max_us);
    return 0.0;
  }

  void TickHistogram::clear()
  {
    std::fill(count, count + bins, 0u);
    n      = 0;
    max_us = 0.0;
  }

  void close_window(TickStats &stats, TickHistogram &durations, TickHistogram *lateness, std::uint64_t ticks,
                    double seconds)
  {
    stats.tick_p50_us = durations.percentile(0.5);
    stats.tick_p99_us = durations.percentile(0.99);
    stats.tick_max_us = durations.max_us;
    stats.late_p50_us = lateness ? lateness->percentile(0.5) : std::numeric_limits<double>::quiet_NaN();
    stats.late_p99_us = lateness ? lateness->percentile(0.99) : std::numeric_limits<double>::quiet_NaN();
    stats.late_max_us = lateness ? lateness->max_us : std::numeric_limits<double>::quiet_NaN();
    stats.rate_hz     = ticks / seconds;
    durations.clear();
    if (lateness)
      lateness->clear();
  }

  void stamp_tick(const modalrt_kernel *kernel, HapticTick &tick)
  {
    modalrt_kernel_stats ks{};
    modalrt_kernel_get_stats(kernel, &ks);
    tick.tick     = ks.tick_count;
    tick.rejected = ks.rejected_ticks;
    tick.wall_ms  = wall_clock_ms();
  }

  FrameBuilder::FrameBuilder(const modalrt_basis *basis, std::uint32_t hips, std::uint32_t validity_level)
    : basis_(basis), vertices_(modalrt_basis_display_vertices(basis)), normals_(modalrt_basis_display_normals(basis)),
      hips_(hips), validity_level_(validity_level), hip_(hips), contact_vertices_(hips), contact_corrections_(3 * std::size_t(hips))
  {}

  void FrameBuilder::update(const modalrt_snapshot *snapshot, const HapticTick &tick, const modalrt_hip_output *outputs)
  {
    tick_ = tick;
    modalrt_snapshot_get_info(snapshot, &info_);
    const double *q = modalrt_snapshot_modal_coordinates(snapshot);
    q_.assign(q, q + info_.mode_count);
    modalrt_snapshot_get_contacts(snapshot, hips_, contact_vertices_.data(), contact_corrections_.data(),
                                  &contact_count_);
    for (std::uint32_t h = 0; h < hips_; ++h)
      {
        const modalrt_hip_output &o   = outputs[h];
        Hip                      &hip = hip_[h];
        const std::uint32_t       v   = o.in_contact ? o.active_vertex : MODALRT_NONE;
        std::copy_n(o.force, 3, hip.force);
        hip.in_contact = o.in_contact;
        hip.flags      = o.flags;
        std::copy_n(o.position, 3, hip.position);
        hip.validity_force = v == MODALRT_NONE ? 0.0
                                               : modalrt_tool::contact_validity_force(basis_, info_.space, v, o.proxy_triangle,
                                                                                      o.proxy_weights, validity_level_);
        if (v == MODALRT_NONE)
          {
            hip.vertex = MODALRT_NONE;
            std::fill_n(hip.displacement, 3, 0.0);
            std::fill_n(hip.felt, 3, 0.0);
            continue;
          }
        // The kernel's own reconstruction of the active vertex from the same snapshot.
        modalrt_display_reconstruct_f64(snapshot, v, v + 1, MODALRT_DISPLAY_DISPLACEMENTS, hip.displacement);
        for (int d = 0; d < 3; ++d)
          hip.felt[d] = o.position[d] - vertices_[3 * std::size_t(v) + d];
        const bool moved = o.proxy_triangle != hip.triangle || !std::equal(hip.weights, hip.weights + 3, o.proxy_weights);
        if (v != hip.vertex || info_.space != hip.space || moved)
          {
            double rest[3], n[3], compliance = 0.0;
            bool   full_fe = false;
            const int status =
              o.proxy_triangle != MODALRT_NONE
                ? modalrt_tool::point_normal_compliance(basis_, info_.space, o.proxy_triangle, o.proxy_weights, rest, n,
                                                        compliance, full_fe)
                : modalrt_tool::normal_compliance(basis_, info_.space, v, compliance, full_fe);
            hip.static_stiffness = status == MODALRT_OK && compliance > 0.0 ? 1.0 / compliance : 0.0;
            hip.full_fe          = full_fe ? 1u : 0u;
            hip.vertex   = v;
            hip.space    = info_.space;
            hip.triangle = o.proxy_triangle;
            std::copy_n(o.proxy_weights, 3, hip.weights);
          }
      }
  }

  void FrameBuilder::frame(std::vector<unsigned char> &bytes) const
  {
    const auto put = [&bytes](const void *p, std::size_t n) {
      const auto *c = static_cast<const unsigned char *>(p);
      bytes.insert(bytes.end(), c, c + n);
    };
    const auto u32 = [&](std::uint32_t v) { put(&v, 4); };
    const auto f64 = [&](double v) { put(&v, 8); };
    u32(0x4654524Du); // "MRTF"
    u32(2);           // 2: each HIP's validity force after its static stiffness
    f64(tick_.wall_ms);
    f64(wall_clock_ms());
    f64(double(info_.tick));
    f64(info_.time);
    u32(info_.space);
    u32(std::uint32_t(q_.size()));
    u32(hips_);
    u32(contact_count_);
    const TickStats &t = tick_.stats;
    for (double v : {double(tick_.tick), double(tick_.rejected), t.tick_p50_us, t.tick_p99_us, t.tick_max_us,
                     t.late_p99_us, t.late_max_us, t.rate_hz})
      f64(v);
    put(q_.data(), 8 * q_.size());
    for (std::uint32_t k = 0; k < contact_count_; ++k)
      {
        u32(contact_vertices_[k]);
        u32(0);
        put(&contact_corrections_[3 * k], 24);
      }
    for (const Hip &hip : hip_)
      {
        u32(hip.in_contact);
        u32(hip.vertex);
        u32(hip.full_fe);
        u32(hip.flags);
        put(hip.force, 24);
        put(hip.displacement, 24);
        put(hip.felt, 24);
        f64(hip.static_stiffness);
        f64(hip.validity_force);
      }
  }

  std::string FrameBuilder::state_json() const
  {
    const TickStats &t      = tick_.stats;
    const auto       num    = [](double x) { return std::isfinite(x) ? Json(x) : Json(-1.0); }; // -1: not measured
    const auto       vector = [](const double v[3]) { return Json{Json(v[0]), Json(v[1]), Json(v[2])}; };
    Json             j;
    j["tick"]           = info_.tick;
    j["haptic_tick"]    = tick_.tick;
    j["time"]           = info_.time;
    j["space"]          = info_.space;
    j["rejected_ticks"] = tick_.rejected;
    j["tick_us"]        = {{"p50", num(t.tick_p50_us)}, {"p99", num(t.tick_p99_us)}, {"max", num(t.tick_max_us)}};
    j["lateness_us"]    = {{"p50", num(t.late_p50_us)}, {"p99", num(t.late_p99_us)}, {"max", num(t.late_max_us)}};
    j["tick_rate_hz"]   = num(t.rate_hz);
    Json &hips          = j["hips"] = Json::array();
    for (const Hip &hip : hip_)
      {
        Json h;
        h["in_contact"]               = hip.in_contact;
        h["vertex"]                   = hip.in_contact ? std::int64_t(hip.vertex) : std::int64_t(-1);
        h["full_fe"]                  = hip.full_fe;
        h["force"]                    = vector(hip.force);
        h["displacement"]             = vector(hip.displacement);
        h["felt"]                     = vector(hip.felt);
        h["static_stiffness_n_per_m"] = num(hip.static_stiffness);
        h["validity_force_n"]         = hip.validity_force;
        h["flags"]                    = hip.flags;
        h["position"]                 = vector(hip.position);
        hips.push_back(std::move(h));
      }
    return dump_json(j);
  }
} // namespace modalrt_view
