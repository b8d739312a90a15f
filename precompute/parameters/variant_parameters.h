// Design variants (subsection "Variants" of a scene's .prm, docs/precompute.md): other designs of the
// same part, each the scene as written with some entries of 'Geometry' or 'Material' set otherwise.
// The scene as written is the base design. Its own header, not scene_parameters.h: only the programs
// that run the variants read them (scene_parameters.cc declares the subsection with the scene's, and
// includes this, so this names SceneParameters without including its header).
#pragma once

#include <deal.II/base/parameter_handler.h>

#include <iosfwd>
#include <memory>
#include <string>
#include <vector>

namespace modal_haptics
{
  struct SceneParameters; // parameters/scene_parameters.h

  // One entry set otherwise, as a .prm's 'set' line would set it.
  struct VariantOverride
  {
    std::string entry; // its path: "Material/Young's modulus", "Geometry/Ribbed panel/Rib thicknesses"
    std::string value; // the text after '=', in the entry's unit
  };

  struct DesignVariant
  {
    std::string                  name;    // letters, digits, '_' and '-': its folder <output>/variants/<name>
    std::string                  section; // "Variants/Variant 2", for messages
    std::vector<VariantOverride> overrides;
  };

  // Up to this many variants, each of up to this many overrides.
  constexpr unsigned int max_variants = 6, max_variant_overrides = 8;

  // The subsection "Variants": the designs compared with the base, and the noise floor of that
  // comparison (the base meshed again with every mesh size scaled: another mesh, the same design).
  struct VariantParameters
  {
    std::vector<DesignVariant> variants;
    bool   noise_floor            = false;
    double noise_floor_mesh_scale = 1.03; // on 'Meshing/Coarse size' and every VOI's 'Fine size' [-]

    bool any() const { return !variants.empty() || noise_floor; }

    static void declare_parameters(dealii::ParameterHandler &prm);
    // Throws ExcMessage naming parameter_file, the entry and its value.
    void parse_parameters(dealii::ParameterHandler &prm, const std::string &parameter_file);
  };

  // A scene made from the base's file: its parameters and the handler they were read from (its
  // used_parameters.prm is printed from it).
  struct VariantScene
  {
    std::string                               name;
    std::vector<VariantOverride>              overrides;
    std::unique_ptr<SceneParameters>          scene;
    std::unique_ptr<dealii::ParameterHandler> prm;
  };

  // The base's file read again into a fresh handler, its own variants emptied (a variant's folder
  // holds one design), the overrides set as the file would set them (each checked against its
  // entry's pattern), then parsed and checked as a scene with 'output_directory' as its folder.
  // Refused with ExcMessage naming the file, the variant, the entry and the value. 'design_only'
  // refuses entries outside 'Geometry' and 'Material': a variant is another design, not another
  // discretisation (the noise floor's run sets mesh sizes, with it false).
  VariantScene read_variant_scene(const SceneParameters &base, const std::string &name,
                                  const std::vector<VariantOverride> &overrides, const std::string &output_directory,
                                  bool design_only = true);

  // The noise floor's overrides: 'Meshing/Coarse size' and each VOI's 'Fine size' (the base's as
  // parsed, from 'base' and its handler 'prm') times 'scale'.
  std::vector<VariantOverride> noise_floor_overrides(const dealii::ParameterHandler &prm, const SceneParameters &base,
                                                     double scale);

  // used_parameters.prm: every parameter as ParameterHandler prints it (Text), the subsection
  // 'Variants' only where it declares a variant or the noise floor: a scene without variants lists
  // what it listed before they existed.
  void print_used_parameters(const dealii::ParameterHandler &prm, std::ostream &out);
} // namespace modal_haptics
