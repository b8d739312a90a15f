// Internal to the scene's parameters: the subsections of the meshing stage's structs
// (meshing_parameters.cc) that scene_parameters.cc declares and parses beside the precompute's, and
// the readers of lists and points both use.
#pragma once

#include "scene_mesher.h"

#include <deal.II/base/parameter_handler.h>

#include <string>
#include <vector>

namespace modal_haptics
{
  struct SceneParameters; // parameters/scene_parameters.h: declared only, as scene_parameters.cc includes this
}

namespace modal_haptics::parameter_sections
{
  extern const std::string point_pattern_help; // " Three comma-separated numbers x, y, z."
  extern const std::string geometry_units;     // the unit of every length of the .prm, for descriptions

  // Throws naming the entry unless 'text' holds three numbers.
  meshing::Point3     parse_point(const std::string &text, const std::string &entry);
  std::vector<double> parse_doubles(const std::string &text);

  void declare_geometry(dealii::ParameterHandler &prm); // "Geometry": source, unit, supports, the panel
  void parse_geometry(dealii::ParameterHandler &prm, SceneParameters &scene);
  void declare_meshing(dealii::ParameterHandler &prm); // "Meshing": sizes, degree, quality
  void parse_meshing(dealii::ParameterHandler &prm, SceneParameters &scene);
  void declare_scenarios(dealii::ParameterHandler &prm); // "Scenario 1" ... "Scenario N": the VOIs
  void parse_scenarios(dealii::ParameterHandler &prm, SceneParameters &scene);
} // namespace modal_haptics::parameter_sections
