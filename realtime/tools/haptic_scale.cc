#include "haptic_scale.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

namespace modalrt_tool
{
  double stiffness_band_top(const modalrt_basis *basis)
  {
    modalrt_basis_info info;
    if (modalrt_basis_get_info(basis, &info) != MODALRT_OK)
      return 0.0;
    const std::uint32_t *region = modalrt_basis_display_regions(basis);
    std::vector<double>  values;
    for (std::uint32_t v = 0; v < info.display_vertex_count; ++v)
      {
        const double *map = modalrt_basis_felt_stiffness(basis, region[v]);
        if (map && map[v] > 0.0 && std::isfinite(map[v]))
          values.push_back(map[v]);
      }
    if (values.empty())
      return 0.0;
    std::sort(values.begin(), values.end());
    const std::size_t rank = std::size_t(std::ceil(band_percentile / 100.0 * double(values.size())));
    return values[std::min(values.size(), std::max<std::size_t>(rank, 1)) - 1];
  }

  bool apply_device_profile(const std::string &name, double scale, bool impedance, const modalrt_basis *basis,
                            modalrt_kernel_def &def, std::string &error)
  {
    modalrt_device_def spec;
    if (modalrt_device_profile_find(name.c_str(), &spec) != MODALRT_OK)
      {
        error = modalrt_last_error_message();
        return false;
      }
    const bool admittance = spec.kind == MODALRT_DEVICE_ADMITTANCE;
    if (admittance == impedance)
      {
        error = "device profile '" + name + "' is an " + (admittance ? "admittance" : "impedance") +
                " device: it needs " + (admittance ? "admittance" : "impedance") + " ticks (run, serve: --mode " +
                (admittance ? "admittance" : "impedance") + "; view: " +
                (admittance ? "the default snap contact" : "--contact proxy") + ")";
        return false;
      }
    def.device           = spec;
    def.coupling_damping = std::min(def.coupling_damping, spec.max_damping);
    if (admittance)
      return true;
    const double top = stiffness_band_top(basis);
    if (scale <= 0.0 && top <= 0.0)
      {
        error = "no felt-stiffness map in the basis to scale to: give --haptic-scale";
        return false;
      }
    def.haptic_scale = scale > 0.0 ? scale : spec.max_stiffness / top;
    return true;
  }

  std::string haptic_scale_line(const std::string &profile, const modalrt_haptic_mapping &m,
                                const modalrt_kernel_def &def)
  {
    if (profile.empty() || def.haptic_scale <= 0.0)
      return "";
    char line[512];
    std::snprintf(line, sizeof line,
                  "1 N/mm at the hand = %.4g N/mm of part (%s: s = %.4g, stable stiffness %.4g N/mm, force limit %.3g N; "
                  "parts up to %.4g N/mm to scale, stiffer ones a wall at %.4g N/mm; coupling on the part %.4g N/mm, "
                  "series share at the band's top %.2f %%)",
                  1.0 / m.haptic_scale, profile.c_str(), m.haptic_scale, 1e-3 * def.device.max_stiffness,
                  def.device.max_force, 1e-3 * m.band_top_stiffness, 1e-3 * def.device.max_stiffness,
                  1e-3 * m.part_coupling_stiffness, 100.0 * m.series_share);
    return line;
  }
} // namespace modalrt_tool
