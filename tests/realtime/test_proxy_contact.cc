// The sliding (proxy) contact on the lattice cantilever's top face (a plate clamped at x = 0, every
// unclamped vertex a candidate with its exact residual compliance and the cross compliances): force
// continuity while sliding at 0.1 m/s against the snap contact's step, Coulomb friction (stick
// below the static limit, the dynamic limit while sliding), the felt stiffness along a slide
// against the exact compliance of the blended load, a slide across a VOI boundary, two HIPs sliding
// with their cross terms, the passivity observer over a 10 s session, and no allocation in ticks.
#include "allocation_counter.h"
#include "test_support.h"

#include <algorithm>
#include <functional>

using modalrt::BasisContent;
using modalrt::LatticeOptions;

namespace
{
  constexpr double T = 1e-3; // [s] 1 kHz

  LatticeOptions plate_options()
  {
    LatticeOptions o;
    o.nx             = 13; // 16.7 mm between vertices along x, 25 mm across
    o.all_candidates = true;
    o.patch_radius   = 0.02;
    return o;
  }

  double top(const LatticeOptions &o) { return o.thickness; }

  modalrt_kernel_def proxy_def(double mu_s, double mu_d, std::uint32_t hips = 1)
  {
    modalrt_kernel_def def = modalrt_kernel_default_def();
    def.hip_capacity       = hips;
    def.contact_mode       = MODALRT_CONTACT_PROXY;
    def.static_friction    = mu_s;
    def.dynamic_friction   = mu_d;
    def.switch_rule        = MODALRT_SWITCH_NEVER;
    def.snap_distance      = 0.03; // the lattice is coarse
    return def;
  }

  // A HIP's path: position and velocity at time t.
  using Path = std::function<void(double t, double x[3], double v[3])>;

  // Along a straight line at `speed` from (x0, y0) to (x1, y1) (velocity eased in and out over 50
  // ms), after 0.3 s pressing in to `depth` below the top at (x0, y0) and 0.2 s holding there.
  Path line_path(double x0, double y0, double x1, double y1, double z_top, double depth, double speed)
  {
    return [=](double t, double x[3], double v[3]) {
      const double press = std::min(1.0, t / 0.3), ease = press * press * (3 - 2 * press);
      const double travel = std::hypot(x1 - x0, y1 - y0), ramp = 0.05, cruise = travel / speed - ramp;
      const double s = std::max(0.0, t - 0.5);
      double       along, rate;
      if (s < ramp) // velocity speed (3 tau^2 - 2 tau^3): distance speed ramp (tau^3 - tau^4 / 2)
        {
          const double tau = s / ramp;
          along = speed * ramp * (tau * tau * tau - 0.5 * tau * tau * tau * tau), rate = speed * tau * tau * (3 - 2 * tau);
        }
      else if (s < ramp + cruise)
        along = 0.5 * speed * ramp + speed * (s - ramp), rate = speed;
      else
        {
          const double tau = std::min(1.0, (s - ramp - cruise) / ramp), u = 1 - tau;
          along = travel - speed * ramp * (u * u * u - 0.5 * u * u * u * u), rate = speed * u * u * (3 - 2 * u);
        }
      const double ex = travel > 0.0 ? (x1 - x0) / travel : 0.0, ey = travel > 0.0 ? (y1 - y0) / travel : 0.0;
      x[0] = x0 + ex * along, x[1] = y0 + ey * along, x[2] = z_top + 0.001 - (0.001 + depth) * ease;
      v[0] = ex * rate, v[1] = ey * rate, v[2] = t < 0.3 ? -(0.001 + depth) * 6 * press * (1 - press) / 0.3 : 0.0;
    };
  }

  // Along x from x0 to x1 at y.
  Path slide_path(double x0, double x1, double y, double z_top, double depth, double speed)
  {
    return line_path(x0, y, x1, y, z_top, depth, speed);
  }

  double path_duration(double x0, double x1, double speed) { return 0.5 + std::fabs(x1 - x0) / speed + 0.05; }

  struct SlideRecord
  {
    double max_step       = 0.0; // [N] largest |F_n - F_(n-1)| after the press (stuck, sliding or not in contact)
    double sliding_step   = 0.0; // [N] the same over ticks that slide, and whose previous tick slid
    double min_energy     = 0.0; // [J] lowest passivity observer value
    std::uint32_t switches = 0, triangles = 0;
    std::vector<std::uint32_t> heaviest; // vertices that were the proxy's heaviest corner
    bool   stayed_in_contact = true;
  };

  // Runs `paths` (one per HIP) for `duration` s of impedance ticks; `each` sees every tick's outputs.
  SlideRecord run_slide(modalrt_kernel *k, const std::vector<Path> &paths, double duration,
                        const std::function<void(int, const modalrt_hip_output *)> &each = nullptr)
  {
    SlideRecord                     rec;
    const std::uint32_t             n = std::uint32_t(paths.size());
    std::vector<modalrt_hip_input>  in(n);
    std::vector<modalrt_hip_output> out(n), previous(n);
    std::uint32_t                   last_triangle = MODALRT_NONE;
    const int                       ticks         = int(std::lround(duration / T));
    for (int tick = 0; tick < ticks; ++tick)
      {
        for (std::uint32_t h = 0; h < n; ++h)
          in[h] = modalrt_hip_input{}, paths[h](tick * T, in[h].position, in[h].velocity);
        ENSURE(modalrt_kernel_tick_impedance(k, in.data(), n, out.data()) == MODALRT_OK);
        for (std::uint32_t h = 0; h < n && tick > 500; ++h)
          {
            const double step = test::distance(out[h].force, previous[h].force);
            rec.max_step      = std::max(rec.max_step, step);
            if (out[h].flags & previous[h].flags & MODALRT_HIP_SLIDING)
              rec.sliding_step = std::max(rec.sliding_step, step);
            rec.stayed_in_contact = rec.stayed_in_contact && out[h].in_contact == 1;
          }
        if (out[0].in_contact && out[0].proxy_triangle != last_triangle)
          ++rec.triangles, last_triangle = out[0].proxy_triangle;
        if (out[0].in_contact && std::find(rec.heaviest.begin(), rec.heaviest.end(), out[0].active_vertex) == rec.heaviest.end())
          rec.heaviest.push_back(out[0].active_vertex);
        modalrt_kernel_stats stats;
        modalrt_kernel_get_stats(k, &stats);
        rec.min_energy = std::min(rec.min_energy, stats.passivity_energy);
        rec.switches   = std::uint32_t(stats.switch_count);
        if (each)
          each(tick, out.data());
        previous = out;
      }
    return rec;
  }

  // 1. Force continuity: the largest force change per tick while sliding at 0.1 m/s over the plate,
  // against the snap contact dragged along the same path (released at release_drag_distance).
  void force_continuity()
  {
    const LatticeOptions o = plate_options();
    modalrt_basis       *b = test::load(modalrt::make_lattice_cantilever(o));
    const Path           path = slide_path(0.03, 0.11, 0.025, top(o), 0.002, 0.1);
    const double         duration = path_duration(0.03, 0.11, 0.1);
    const char          *names[3] = {"proxy, frictionless", "proxy, mu_s = mu_d = 0.3", "snap"};
    double               sliding[2] = {0.0, 0.0}, snap = 0.0;
    for (int mode = 0; mode < 3; ++mode)
      {
        modalrt_kernel_def def = mode == 0 ? proxy_def(0.0, 0.0) : proxy_def(0.3, 0.3);
        if (mode == 2)
          def.contact_mode = MODALRT_CONTACT_SNAP;
        modalrt_kernel   *k   = test::create(b, def);
        const SlideRecord rec = run_slide(k, {path}, duration);
        std::printf("  slide 0.08 m at 0.1 m/s, 2 mm deep, %s: largest force change per tick %.3e N sliding, %.3e N "
                    "overall; %zu vertices passed, in contact throughout: %d\n",
                    names[mode], rec.sliding_step, rec.max_step, rec.heaviest.size(), int(rec.stayed_in_contact));
        if (mode < 2)
          {
            ENSURE(rec.stayed_in_contact);
            ENSURE(rec.heaviest.size() >= 5); // it passed the vertices of the row
            sliding[mode] = rec.sliding_step;
          }
        else
          snap = rec.max_step;
        modalrt_kernel_destroy(k);
      }
    // [N] per tick: 0.5 % of the ~2 N normal force, where a stuck proxy pulled at 0.1 m/s changes by
    // K v T = 0.1 N per tick and the snap contact steps by the device's 10 N at its release.
    ENSURE(sliding[0] > 0.0 && sliding[0] < 0.01 && sliding[1] > 0.0 && sliding[1] < 0.01);
    ENSURE(snap > 100 * std::max(sliding[0], sliding[1]));
    modalrt_basis_destroy(b);
  }

  // 1b. Slides exactly along mesh edges and through vertices, 6 mm deep (1.7 to 6 N) at 0.05 m/s with
  // friction: along the middle row of edges (y = 25 mm; from between vertices, and from a vertex to a
  // vertex), along a column of edges (x = 100 mm, from the plate's side to the other through a
  // vertex), along a line of cell diagonals (through 3 vertices) and along the plate's side (a
  // boundary edge), against the same slide between the rows (y = 12.5 mm). Each must slide as
  // anywhere else: the proxy reaches the end of the path (within the friction cone's offset, mu_s F_n
  // / K), never enters again the triangle it left before the last one (no hand-back) and changes
  // triangle at most twice per vertex passed (plus 2), stays in contact, with the force continuity
  // of a slide (< 0.01 N per tick, as force_continuity; past the slide's first 0.1 s: leaving a
  // vertex at the plate's side near the clamp at 4 to 5 N, static to dynamic friction steps by up
  // to 0.017 N, as it did before) and its passivity. (Before the walk's edge and vertex rules, the
  // slides along the middle row stalled at x = 166 mm, handed between two triangles every tick,
  // 199 triangle changes, and were released.)
  void along_edges_and_through_vertices()
  {
    const LatticeOptions o  = plate_options();
    modalrt_basis       *b  = test::load(modalrt::make_lattice_cantilever(o));
    const double         dx = o.length / (o.nx - 1), dy = o.width / (o.ny - 1), mu_s = 0.3, mu_d = 0.2;
    const double         K = modalrt_kernel_default_def().coupling_stiffness;
    struct Line
    {
      const char *name;
      double      x0, y0, x1, y1;
    } lines[] = {
      {"between rows of edges (reference)", 0.19, 0.5 * dy, 0.03, 0.5 * dy},
      {"along the middle row of edges", 0.19, dy, 0.03, dy},
      {"along the row, vertex to vertex", 11 * dx, dy, 2 * dx, dy},
      {"along a column of edges", 6 * dx, 0.0, 6 * dx, 2 * dy},
      {"along cell diagonals", 4 * dx, 0.0, 6 * dx, 2 * dy},
      {"along the side (boundary edges)", 0.19, 0.0, 0.03, 0.0},
    };
    for (const Line &line : lines)
      {
        modalrt_kernel   *k = test::create(b, proxy_def(mu_s, mu_d));
        const double      speed = 0.05, travel = std::hypot(line.x1 - line.x0, line.y1 - line.y0);
        const Path        path = line_path(line.x0, line.y0, line.x1, line.y1, top(o), 0.006, speed);
        std::uint32_t     before[2] = {MODALRT_NONE, MODALRT_NONE}, returns = 0, changes = 0;
        double            sliding_step = 0.0; // past the slide's first 0.1 s
        modalrt_hip_output last{};
        const SlideRecord rec = run_slide(k, {path}, 0.5 + travel / speed + 0.3, [&](int tick, const modalrt_hip_output *out) {
          if (tick >= 600 && out[0].flags & last.flags & MODALRT_HIP_SLIDING)
            sliding_step = std::max(sliding_step, test::distance(out[0].force, last.force));
          if (out[0].in_contact && out[0].proxy_triangle != before[0])
            {
              returns += out[0].proxy_triangle == before[1];
              ++changes;
              before[1] = before[0], before[0] = out[0].proxy_triangle;
            }
          last = out[0];
        });
        const double normal = last.force[2], offset = std::hypot(last.position[0] - line.x1, last.position[1] - line.y1);
        std::printf("  %s, (%.1f, %.1f) -> (%.1f, %.1f) mm: proxy %.2f mm from the end (friction cone %.2f mm), %u "
                    "triangle changes (%u back to the one before), %zu vertices passed; largest force change per tick "
                    "%.3e N sliding past the first 0.1 s (%.3e N from the start); passivity observer lowest %.1e J; in "
                    "contact throughout: %d\n",
                    line.name, 1e3 * line.x0, 1e3 * line.y0, 1e3 * line.x1, 1e3 * line.y1, 1e3 * offset,
                    1e3 * mu_s * normal / K, changes, returns, rec.heaviest.size(), sliding_step, rec.sliding_step,
                    rec.min_energy, int(rec.stayed_in_contact));
        ENSURE(rec.stayed_in_contact && normal > 1.0);
        ENSURE(offset <= mu_s * normal / K + 5e-4);
        ENSURE(returns == 0 && changes <= 2 * rec.heaviest.size() + 2);
        ENSURE(sliding_step < 0.01 && rec.min_energy >= -1e-4);
        modalrt_kernel_destroy(k);
      }
    modalrt_basis_destroy(b);
  }

  double tangential(const modalrt_hip_output &o) { return std::hypot(o.force[0], o.force[1]); }

  // 2. Friction: pulled sideways below mu_s F_n the proxy does not move; pulled along at 0.02 m/s
  // it slides with |F_t| = mu_d F_n.
  void friction()
  {
    const LatticeOptions o = plate_options();
    modalrt_basis       *b = test::load(modalrt::make_lattice_cantilever(o));
    const double         mu_s = 0.5, mu_d = 0.3, x0 = 0.05, y = 0.0125;
    modalrt_kernel      *k = test::create(b, proxy_def(mu_s, mu_d));
    double               pull = 0.0, held_weights[3] = {0, 0, 0}, worst_ratio = 0.0;
    std::uint32_t        held_triangle = MODALRT_NONE;
    bool                 stuck = true;
    int                  sliding_ticks = 0;
    double               t0 = 0.0; // each run_slide starts at 0: later ones stay pressed
    const Path           press = slide_path(x0, x0, y, top(o), 0.002, 0.1);
    const Path           path = [&](double t, double x[3], double v[3]) {
      press(std::min(t + t0, 0.5), x, v);
      x[0] += pull;
    };
    run_slide(k, {path}, 1.0, [&](int tick, const modalrt_hip_output *out) {
      if (tick == 999) // settled: pull sideways to 60 % of the static limit
        pull = 0.6 * mu_s * out[0].force[2] / 1000.0, held_triangle = out[0].proxy_triangle,
        std::copy_n(out[0].proxy_weights, 3, held_weights);
    });
    t0                      = 1.0;
    const SlideRecord below = run_slide(k, {path}, 0.3, [&](int, const modalrt_hip_output *out) {
      stuck = stuck && out[0].proxy_triangle == held_triangle && !(out[0].flags & MODALRT_HIP_SLIDING) &&
              std::equal(held_weights, held_weights + 3, out[0].proxy_weights);
    });
    ENSURE(stuck && below.stayed_in_contact);
    double ratio_below = 0.0;
    const Path drag = [&](double t, double x[3], double v[3]) {
      path(0.0, x, v);
      x[0] += 0.02 * t, v[0] = 0.02;
    };
    run_slide(k, {drag}, 0.5, [&](int tick, const modalrt_hip_output *out) {
      if (tick == 0)
        ratio_below = tangential(out[0]) / out[0].force[2];
      if (tick < 100 || !(out[0].flags & MODALRT_HIP_SLIDING))
        return;
      ++sliding_ticks;
      worst_ratio = std::max(worst_ratio, std::fabs(tangential(out[0]) / out[0].force[2] - mu_d) / mu_d);
    });
    std::printf("  friction mu_s %.1f, mu_d %.1f: pulled to F_t/F_n = %.3f the proxy stays; dragged at 0.02 m/s it "
                "slides (%d ticks) with F_t/F_n within %.2e of mu_d\n",
                mu_s, mu_d, ratio_below, sliding_ticks, worst_ratio);
    ENSURE(ratio_below > 0.25 && ratio_below < mu_s);
    ENSURE(sliding_ticks == 400);
    ENSURE(worst_ratio < 0.01);
    modalrt_kernel_destroy(k);
    modalrt_basis_destroy(b);
  }

  // 2b. The friction cone at the hand under a haptic scale (omega.x: stable stiffness 5 N/mm, the
  // part's coupling 200 times the band's top). The same slide at 0.1 m/s as force_continuity, 1 mm
  // deep, with the band's top at the stiffest vertex of the row (the whole row within the band) and
  // at half of it (the stable-stiffness wall holds the normal force at the hand): at every tick in
  // contact whose force at the hand presses by more than 0.05 N, |F_t| <= mu_s F_n at the hand
  // (the top face's normal is z), to 1 % of mu_s F_n. Before the friction test used the force the
  // step solves, the proxy stuck whenever the explicit guess K (x_hip - proxy) of the stiff
  // coupling did not press, and the hand felt the part dragged sideways: F_t / F_n up to 20 in the
  // default scene's slide.
  void friction_cone_at_the_hand()
  {
    const LatticeOptions o = plate_options();
    modalrt_basis       *b = test::load(modalrt::make_lattice_cantilever(o));
    const double         mu_s = 0.3, mu_d = 0.2, x0 = 0.03, x1 = 0.11, y = 0.025;
    double               stiffest = 0.0;
    for (std::uint32_t i = 0; i < o.nx; ++i)
      {
        const std::uint32_t v = modalrt::lattice_display_vertex(o, i, 1);
        const double       *x = modalrt_basis_display_vertices(b) + 3 * v;
        double              G[9];
        if (x[0] < x0 || x[0] > x1)
          continue;
        ENSURE(modalrt_basis_contact_compliance(b, 0, v, G, nullptr) == MODALRT_OK);
        stiffest = std::max(stiffest, 1.0 / G[8]);
      }
    ENSURE(stiffest > 0.0);
    const Path   path     = slide_path(x0, x1, y, top(o), 0.001, 0.1);
    const double duration = path_duration(x0, x1, 0.1);
    for (double band_share : {1.0, 0.5})
      {
        modalrt_kernel_def def = proxy_def(mu_s, mu_d);
        ENSURE(modalrt_device_profile_find("omega.x", &def.device) == MODALRT_OK);
        def.haptic_scale = def.device.max_stiffness / (band_share * stiffest);
        modalrt_kernel *k     = test::create(b, def);
        double          worst = 0.0, lowest = 0.0;
        int             ticks = 0, outside = 0, walled = 0, sliding = 0;
        const SlideRecord rec = run_slide(k, {path}, duration, [&](int, const modalrt_hip_output *out) {
          const double normal = out[0].force[2], across = tangential(out[0]);
          if (!out[0].in_contact || normal <= 0.05)
            return;
          ++ticks;
          walled += (out[0].flags & MODALRT_HIP_BEYOND_RANGE) != 0;
          sliding += (out[0].flags & MODALRT_HIP_SLIDING) != 0;
          worst = std::max(worst, across / normal);
          outside += across > 1.01 * mu_s * normal;
        });
        modalrt_kernel_stats stats;
        modalrt_kernel_get_stats(k, &stats);
        lowest = stats.min_hip_passivity_energy;
        std::printf("  omega.x, band's top %.0f %% of the row's stiffest (%.4g N/mm), s = %.4g: %d ticks pressing, %d "
                    "walled, %d sliding; largest F_t / F_n at the hand %.4f (mu_s %.1f), %d ticks outside the cone; "
                    "lowest observer %.3g J; in contact throughout: %d\n",
                    100 * band_share, 1e-3 * stiffest, def.haptic_scale, ticks, walled, sliding, worst, mu_s, outside,
                    lowest, int(rec.stayed_in_contact));
        ENSURE(rec.stayed_in_contact && ticks > 500 && sliding > 100);
        ENSURE(band_share == 1.0 || walled > 100);
        ENSURE(outside == 0 && worst <= 1.01 * mu_s);
        modalrt_kernel_destroy(k);
      }
    modalrt_basis_destroy(b);
  }

  // The exact static compliance (3 x 3) between two loads spread over triangles' corners with
  // weights (a load at a vertex: that vertex, weight 1), from the lattice's own numbers: every
  // vertex is a candidate with its exact residual and the cross residuals, so sum_ij w_i w_j
  // (B_i Lambda^-1 B_j^T + C_ij) is the full model's W_a^T K^-1 W_b.
  std::vector<double> exact_compliance(const BasisContent &content, std::uint32_t space,
                                       const std::vector<std::pair<std::uint32_t, double>> &a,
                                       const std::vector<std::pair<std::uint32_t, double>> &b)
  {
    const modalrt::BasisSpaceContent &s = content.spaces[space];
    const std::size_t                 r = s.eigenvalues.size(), n3 = 3 * s.candidates.size();
    auto index = [&](std::uint32_t v) { return std::size_t(std::find(s.candidates.begin(), s.candidates.end(), v) - s.candidates.begin()); };
    std::vector<double> G(9, 0.0);
    for (const auto &[va, wa] : a)
      for (const auto &[vb, wb] : b)
        {
          const std::size_t ia = index(va), ib = index(vb);
          for (int c = 0; c < 3; ++c)
            for (int d = 0; d < 3; ++d)
              {
                double sum = s.cross_compliance[(3 * ia + c) * n3 + 3 * ib + d];
                for (std::size_t i = 0; i < r; ++i)
                  sum += s.candidate_modes[(3 * ia + c) * r + i] * s.candidate_modes[(3 * ib + d) * r + i] / s.eigenvalues[i];
                G[3 * c + d] += wa * wb * sum;
              }
        }
    return G;
  }

  std::vector<std::pair<std::uint32_t, double>> load_of(const modalrt_basis *b, const modalrt_hip_output &o)
  {
    const uint32_t *t = modalrt_basis_display_triangles(b) + 3 * o.proxy_triangle;
    return {{t[0], o.proxy_weights[0]}, {t[1], o.proxy_weights[1]}, {t[2], o.proxy_weights[2]}};
  }

  std::vector<double> rest_of(const modalrt_basis *b, const std::vector<std::pair<std::uint32_t, double>> &load)
  {
    std::vector<double> x(3, 0.0);
    for (const auto &[v, w] : load)
      for (int d = 0; d < 3; ++d)
        x[d] += w * modalrt_basis_display_vertices(b)[3 * v + d];
    return x;
  }

  // The felt static displacements under `forces` (3 per HIP) where the proxies are now: the exact
  // equilibrium (settle) and one admittance tick, which does not move a proxy.
  std::vector<modalrt_hip_output> probe(modalrt_kernel *k, std::uint32_t count, const std::vector<double> &forces)
  {
    std::vector<modalrt_hip_input>  in(count);
    std::vector<modalrt_hip_output> out(count);
    for (std::uint32_t h = 0; h < count; ++h)
      in[h] = modalrt_hip_input{}, std::copy_n(&forces[3 * h], 3, in[h].force);
    ENSURE(modalrt_kernel_settle(k, in.data(), count) == MODALRT_OK);
    ENSURE(modalrt_kernel_tick_admittance(k, in.data(), count, out.data()) == MODALRT_OK);
    return out;
  }

  // 3. The felt normal stiffness along a slide equals the exact compliance of the load at the
  // proxy, and at every vertex the proxy passed, the stored exact compliance there.
  void stiffness_along_a_slide()
  {
    const LatticeOptions o       = plate_options();
    const BasisContent   content = modalrt::make_lattice_cantilever(o);
    modalrt_basis       *b       = test::load(content);
    modalrt_kernel      *k       = test::create(b, proxy_def(0.3, 0.3));
    const Path           path    = slide_path(0.03, 0.11, 0.0125, top(o), 0.002, 0.1);
    double               worst   = 0.0;
    int                  probes  = 0;
    std::vector<std::uint32_t> passed;
    run_slide(k, {path}, path_duration(0.03, 0.11, 0.1), [&](int tick, const modalrt_hip_output *out) {
      if (out[0].in_contact && std::find(passed.begin(), passed.end(), out[0].active_vertex) == passed.end())
        passed.push_back(out[0].active_vertex);
      if (tick < 560 || tick % 97 != 0)
        return;
      const auto load = load_of(b, out[0]);
      const auto felt = probe(k, 1, {0.0, 0.0, -1.0});
      const auto G    = exact_compliance(content, 0, load, load);
      const auto rest = rest_of(b, load);
      worst = std::max(worst, std::fabs(-(felt[0].position[2] - rest[2]) - G[8]) / G[8]);
      ++probes;
    });
    double worst_vertex = 0.0;
    for (std::uint32_t v : passed)
      {
        ENSURE(modalrt_kernel_contact_begin(k, 0, v) == MODALRT_OK);
        const auto felt = probe(k, 1, {0.0, 0.0, -1.0});
        double     G[9];
        uint32_t   full_fe = 0;
        modalrt_basis_contact_compliance(b, 0, v, G, &full_fe);
        ENSURE(full_fe == 1 && felt[0].proxy_weights[0] + felt[0].proxy_weights[1] + felt[0].proxy_weights[2] == 1.0);
        worst_vertex = std::max(worst_vertex, std::fabs(-(felt[0].position[2] - modalrt_basis_display_vertices(b)[3 * v + 2]) - G[8]) / G[8]);
      }
    std::printf("  felt normal compliance along a slide: %d points within %.1e of the exact blended load's, %zu "
                "vertices passed within %.1e of their stored exact compliance\n",
                probes, worst, passed.size(), worst_vertex);
    ENSURE(probes >= 8 && passed.size() >= 5);
    ENSURE(worst < 1e-9 && worst_vertex < 1e-9);
    modalrt_kernel_destroy(k);
    modalrt_basis_destroy(b);
  }

  // 3b. The same over vertices without a stored block (one vertex in four a candidate), in
  // circles (turns: look-ahead missed), r = 70, twice: with their patch rows and pair blocks made at
  // the kernel's creation (the default, proxy_row_memory = 0), and with every such row built in the
  // ticks, a bounded amount ahead of the proxy (MODALRT_PROXY_ROWS_IN_TICKS). The felt normal
  // compliance where the proxy is equals the compliance of the blended load
  // (modalrt_basis_point_compliance), the ticks allocate nothing, and the two kernels render the
  // same forces (to round-off: a pair block summed with its rows in the other order).
  struct CircleRun
  {
    std::vector<double> forces; // 3 per tick
    double              worst = 0.0;
    int                 probes = 0, uncorrected = 0, failed_ticks = 0;
    std::uint64_t       allocations = 0;
  };

  CircleRun circles_over_patch_rows(std::uint32_t row_memory)
  {
    LatticeOptions o   = plate_options();
    o.all_candidates   = false;
    o.candidate_stride = 4; // a candidate in four: the others' rows are patch rows
    o.modes            = {70, 90}; // pair blocks in two chunks, spread over ticks by the budget
    modalrt_basis     *b   = test::load(modalrt::make_lattice_cantilever(o));
    modalrt_kernel_def def = proxy_def(0.3, 0.2);
    def.proxy_row_memory   = row_memory;
    modalrt_kernel    *k   = test::create(b, def);
    const double    radius = 0.02, omega = 0.1 / radius, centre[2] = {0.08, 0.025}, z_top = top(o);
    modalrt_hip_input  in{};
    modalrt_hip_output out;
    CircleRun          run;
    for (int tick = 0; tick < 3000; ++tick)
      {
        const double t = tick * T, press = std::min(1.0, t / 0.3);
        in.position[0] = centre[0] + radius * std::cos(omega * t), in.velocity[0] = -radius * omega * std::sin(omega * t);
        in.position[1] = centre[1] + radius * std::sin(omega * t), in.velocity[1] = radius * omega * std::cos(omega * t);
        in.position[2] = z_top + 0.001 - 0.003 * press, in.velocity[2] = 0.0;
        const std::uint64_t before = modalrt_tool::counted_allocations();
        modalrt_tool::count_allocations_in_this_thread(tick >= 100);
        run.failed_ticks += modalrt_kernel_tick_impedance(k, &in, 1, &out) != MODALRT_OK; // (ENSURE allocates)
        modalrt_tool::count_allocations_in_this_thread(false);
        run.allocations += modalrt_tool::counted_allocations() - before;
        run.forces.insert(run.forces.end(), out.force, out.force + 3);
        if (tick < 600 || tick % 97 != 0 || !out.in_contact)
          continue;
        const auto felt = probe(k, 1, {0.0, 0.0, -1.0});
        double     G[9];
        uint32_t   full_fe = 0;
        ENSURE(modalrt_basis_point_compliance(b, felt[0].space, felt[0].proxy_triangle, felt[0].proxy_weights, G,
                                              &full_fe) == MODALRT_OK);
        const auto rest = rest_of(b, load_of(b, felt[0]));
        run.worst = std::max(run.worst, std::fabs(-(felt[0].position[2] - rest[2]) - G[8]) / G[8]);
        run.uncorrected += full_fe == 0;
        ++run.probes;
      }
    modalrt_kernel_destroy(k);
    modalrt_basis_destroy(b);
    return run;
  }

  void stiffness_over_patch_rows()
  {
    const CircleRun stored = circles_over_patch_rows(0), in_ticks = circles_over_patch_rows(MODALRT_PROXY_ROWS_IN_TICKS);
    double force_difference = 0.0, largest = 0.0;
    for (std::size_t i = 0; i < stored.forces.size(); ++i)
      {
        force_difference = std::max(force_difference, std::fabs(stored.forces[i] - in_ticks.forces[i]));
        largest          = std::max(largest, std::fabs(stored.forces[i]));
      }
    for (const CircleRun *run : {&stored, &in_ticks})
      {
        std::printf("  circles over patch rows %s: %d points (%d not all candidates) within %.1e of the blended "
                    "load's compliance; %llu allocations in 2900 ticks\n",
                    run == &stored ? "made at creation" : "built in the ticks", run->probes, run->uncorrected,
                    run->worst, (unsigned long long)run->allocations);
        ENSURE(run->failed_ticks == 0 && run->probes >= 20 && run->uncorrected >= 10);
        ENSURE(run->worst < 1e-9 && run->allocations == 0);
      }
    std::printf("  the two kernels' forces over 3000 ticks: largest difference %.1e N (largest force %.2f N)\n",
                force_difference, largest);
    ENSURE(stored.forces.size() == in_ticks.forces.size() && largest > 0.1 && force_difference <= 1e-12 * largest);
  }

  // 3c. The coupling a sliding contact takes from its triangle's pair blocks (ProxyGram, summed in
  // chunks of 64 modes: r = 70 and 90 here) is the one the fixed contact sums over the modes: a
  // proxy put on a vertex (weights 0 and 1) and held there by friction while the HIP presses in and
  // out along the normal feels, tick by tick, the force of a fixed contact at that vertex.
  void proxy_at_a_vertex_is_the_fixed_contact()
  {
    LatticeOptions o = plate_options();
    o.modes          = {70, 90};
    modalrt_basis       *b      = test::load(modalrt::make_lattice_cantilever(o));
    const std::uint32_t  vertex = modalrt::lattice_display_vertex(o, 7, 1);
    const double        *x      = modalrt_basis_display_vertices(b) + 3 * vertex;
    const double        *n      = modalrt_basis_display_normals(b) + 3 * vertex;
    modalrt_kernel_def   def    = proxy_def(10.0, 10.0);
    def.auto_release            = 0;
    modalrt_kernel *kernels[2]  = {test::create(b, def), nullptr};
    def.contact_mode            = MODALRT_CONTACT_SNAP;
    kernels[1]                  = test::create(b, def);
    for (modalrt_kernel *k : kernels)
      ENSURE(modalrt_kernel_contact_begin(k, 0, vertex) == MODALRT_OK);
    double worst = 0.0, largest = 0.0;
    bool   stayed = true;
    for (int tick = 0; tick < 2000; ++tick)
      {
        const double      t = tick * T, depth = 0.002 * (1.0 - std::cos(7.0 * t)), rate = 0.014 * std::sin(7.0 * t);
        modalrt_hip_input in{};
        for (int d = 0; d < 3; ++d)
          in.position[d] = x[d] - depth * n[d], in.velocity[d] = -rate * n[d];
        modalrt_hip_output out[2];
        for (int k = 0; k < 2; ++k)
          ENSURE(modalrt_kernel_tick_impedance(kernels[k], &in, 1, &out[k]) == MODALRT_OK);
        stayed  = stayed && out[0].active_vertex == vertex && out[1].active_vertex == vertex && out[0].in_contact == 1;
        worst   = std::max(worst, test::distance(out[0].force, out[1].force));
        largest = std::max(largest, std::sqrt(out[1].force[0] * out[1].force[0] + out[1].force[1] * out[1].force[1] + out[1].force[2] * out[1].force[2]));
      }
    std::printf("  a proxy held on vertex %u against the fixed contact there, r = 70: largest force difference %.1e N "
                "(forces up to %.2f N) over 2000 ticks\n",
                vertex, worst, largest);
    ENSURE(stayed && largest > 1.0 && worst < 1e-9 * largest);
    for (modalrt_kernel *k : kernels)
      modalrt_kernel_destroy(k);
    modalrt_basis_destroy(b);
  }

  // 4. A slide from the global region into the tip VOI: the space switches during the slide, the
  // force does not step beyond the bound of a slide.
  void across_a_voi_boundary()
  {
    const LatticeOptions o = plate_options();
    modalrt_basis       *b = test::load(modalrt::make_lattice_cantilever(o));
    modalrt_kernel_def   def = proxy_def(0.3, 0.3);
    def.switch_rule          = MODALRT_SWITCH_AT_CONTACT_START;
    modalrt_kernel   *k      = test::create(b, def);
    std::uint32_t     space_before = MODALRT_NONE, space_after = MODALRT_NONE;
    const SlideRecord rec = run_slide(k, {slide_path(0.08, 0.16, 0.0125, top(o), 0.002, 0.1)},
                                      path_duration(0.08, 0.16, 0.1), [&](int tick, const modalrt_hip_output *out) {
                                        if (tick == 500)
                                          space_before = out[0].space;
                                        space_after = out[0].space;
                                      });
    modalrt_kernel_stats stats;
    modalrt_kernel_get_stats(k, &stats);
    std::printf("  slide across the VOI boundary: space %u -> %u, %u switch(es), largest force change per tick %.3e N "
                "sliding (%.3e overall), largest switch jump %.3e m\n",
                space_before, space_after, rec.switches, rec.sliding_step, rec.max_step, stats.max_switch_jump);
    ENSURE(space_before == 0 && space_after == 1 && rec.switches >= 1 && rec.stayed_in_contact);
    ENSURE(rec.sliding_step < 0.01);
    modalrt_kernel_destroy(k);
    modalrt_basis_destroy(b);
  }

  // 5. Two HIPs sliding in opposite directions: both slide smoothly; where they stop, what each feels
  // includes the other's load through the cross compliance of their blended loads.
  void two_hips_sliding()
  {
    const LatticeOptions o       = plate_options();
    const BasisContent   content = modalrt::make_lattice_cantilever(o);
    modalrt_basis       *b       = test::load(content);
    modalrt_kernel      *k       = test::create(b, proxy_def(0.3, 0.2, 2));
    const SlideRecord    rec     = run_slide(k,
                                             {slide_path(0.03, 0.10, 0.0125, top(o), 0.002, 0.1),
                                              slide_path(0.10, 0.03, 0.0375, top(o), 0.002, 0.1)},
                                             path_duration(0.03, 0.10, 0.1));
    const std::vector<double> forces = {0.2, -0.1, -1.0, -0.3, 0.1, -0.7};
    const auto                felt   = probe(k, 2, forces);
    double                    worst  = 0.0, cross_effect = 0.0;
    for (std::uint32_t h = 0; h < 2; ++h)
      {
        const auto load = load_of(b, felt[h]), other = load_of(b, felt[1 - h]);
        const auto G = exact_compliance(content, 0, load, load), C = exact_compliance(content, 0, load, other);
        const auto rest = rest_of(b, load);
        for (int c = 0; c < 3; ++c)
          {
            double u = 0.0, u_other = 0.0;
            for (int d = 0; d < 3; ++d)
              u += G[3 * c + d] * forces[3 * h + d], u_other += C[3 * c + d] * forces[3 * (1 - h) + d];
            worst        = std::max(worst, std::fabs(felt[h].position[c] - rest[c] - u - u_other) / G[8]);
            cross_effect = std::max(cross_effect, std::fabs(u_other) / G[8]);
          }
      }
    std::printf("  two HIPs sliding: largest force change per tick %.3e N sliding; felt static response within %.1e "
                "of the exact one (the other HIP's share up to %.1e of it)\n",
                rec.sliding_step, worst, cross_effect);
    ENSURE(rec.stayed_in_contact && rec.sliding_step < 0.01);
    ENSURE(worst < 1e-9 && cross_effect > 1e-3);
    modalrt_kernel_destroy(k);
    modalrt_basis_destroy(b);
  }

  // 6. A 10 s session at 1 kHz (circles at 0.1 m/s, the depth breathing between 1 and 3 mm, with
  // friction): the passivity observer never falls below the bound, and the ticks allocate nothing.
  void passivity_and_allocation()
  {
    const LatticeOptions o = plate_options();
    modalrt_basis       *b = test::load(modalrt::make_lattice_cantilever(o));
    modalrt_kernel_def   def = proxy_def(0.4, 0.3);
    def.switch_rule          = MODALRT_SWITCH_AT_CONTACT_START;
    modalrt_kernel *k        = test::create(b, def);
    const double    radius = 0.02, omega = 0.1 / radius, centre[2] = {0.11, 0.025};
    const double    bound  = -1e-4; // [J]
    double          lowest = 0.0, z_top = top(o);
    modalrt_hip_input  in{};
    modalrt_hip_output out;
    std::uint64_t      allocations = 0;
    int                failed_ticks = 0;
    for (int tick = 0; tick < 10000; ++tick)
      {
        const double t = tick * T, press = std::min(1.0, t / 0.3), depth = 0.002 + 0.001 * std::sin(2.0 * t);
        in.position[0] = centre[0] + radius * std::cos(omega * t), in.velocity[0] = -radius * omega * std::sin(omega * t);
        in.position[1] = centre[1] + radius * std::sin(omega * t), in.velocity[1] = radius * omega * std::cos(omega * t);
        in.position[2] = z_top + 0.001 - (0.001 + depth) * press, in.velocity[2] = -0.002 * std::cos(2.0 * t) * press;
        if (tick == 100)
          {
            allocations = modalrt_tool::counted_allocations();
            modalrt_tool::count_allocations_in_this_thread(true);
          }
        failed_ticks += modalrt_kernel_tick_impedance(k, &in, 1, &out) != MODALRT_OK; // (ENSURE allocates)
        modalrt_kernel_stats stats;
        modalrt_kernel_get_stats(k, &stats);
        lowest = std::min(lowest, stats.passivity_energy);
      }
    modalrt_tool::count_allocations_in_this_thread(false);
    allocations = modalrt_tool::counted_allocations() - allocations;
    modalrt_kernel_stats stats;
    modalrt_kernel_get_stats(k, &stats);
    std::printf("  10 s of circles at 0.1 m/s with friction: passivity observer %.4e J at the end, lowest %.3e J (bound "
                "%.0e J); %llu switches; %llu allocations in 9900 ticks\n",
                stats.passivity_energy, lowest, bound, (unsigned long long)stats.switch_count,
                (unsigned long long)allocations);
    ENSURE(failed_ticks == 0 && out.in_contact == 1 && stats.passivity_energy > 0.0 && lowest >= bound);
    ENSURE(allocations == 0);
    modalrt_kernel_destroy(k);
    modalrt_basis_destroy(b);
  }
} // namespace

int main()
{
  force_continuity();
  along_edges_and_through_vertices();
  friction();
  friction_cone_at_the_hand();
  stiffness_along_a_slide();
  stiffness_over_patch_rows();
  proxy_at_a_vertex_is_the_fixed_contact();
  across_a_voi_boundary();
  two_hips_sliding();
  passivity_and_allocation();
  return test::finish("test_proxy_contact");
}
