// The hyperelastic laws' names and the material's Lame constants (large_deformation.h). The solve
// itself: large_deformation_solve.h; the validity analysis built on it: validity_analysis.cc.
#include "nonlinear/large_deformation.h"

#include <array>
#include <string>

namespace modal_haptics
{
  namespace nonlinear
  {
    std::string law_name(const HyperelasticLaw law)
    {
      return law == HyperelasticLaw::neo_hookean ? "neo-Hookean" : "St. Venant-Kirchhoff";
    }

    std::array<double, 2> lame_constants(const MaterialParameters &material)
    {
      const double E = material.youngs_modulus, nu = material.poissons_ratio;
      return {{E / (2. * (1. + nu)), E * nu / ((1. + nu) * (1. - 2. * nu))}};
    }

    HyperelasticLaw validity_law(const SceneParameters &scene)
    {
      return scene.contact.validity_neo_hookean ? HyperelasticLaw::neo_hookean : HyperelasticLaw::saint_venant_kirchhoff;
    }
  } // namespace nonlinear
} // namespace modal_haptics
