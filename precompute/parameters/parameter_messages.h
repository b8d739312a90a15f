// What a user reads when the .prm file itself is wrong. deal.II's parser refuses a value outside its
// Pattern, an undeclared entry or subsection in its own words ("does not match the given pattern:
// [Double 0...MAX_DOUBLE (inclusive)]"); here each is said in one form, the form of every other
// message about a value: the file and line, the entry's path, its value, what it accepts and its
// unit, and for a misspelt name the closest declared one.
#pragma once

#include <deal.II/base/parameter_handler.h>
#include <deal.II/base/patterns.h>

#include <limits>
#include <memory>
#include <string>
#include <vector>

namespace modal_haptics::parameter_messages
{
  // prm.parse_input(file), every refusal of the parser rethrown as ExcMessage in the form
  //   "scene.prm, line 12: 'Material/Density' = -1: must be a number > 0 (unit: kg/m^3)."
  //   "scene.prm, line 9: subsection 'Material' has no entry 'Youngs modulus': did you mean
  //    'Young's modulus'? ..."
  void parse_input(dealii::ParameterHandler &prm, const std::string &file);

  // prm.set() of the entry at 'path' ("Material/Young's modulus", subsections joined by '/') to
  // 'value', as a file's 'set' line would set it. A path that names no declared entry, or a value its
  // Pattern refuses, throws ExcMessage beginning with 'where' ("scene.prm, 'Variants/Variant 1'
  // ('stiff')") in the form of parse_input's messages: the entry, the value, what it accepts and its
  // unit, or the closest declared name.
  void set_entry(dealii::ParameterHandler &prm, const std::string &path, const std::string &value,
                 const std::string &where);

  // A real number in an interval whose ends are excluded: deal.II's Patterns::Double admits its
  // bounds, so "> 0" (a density) and "in (-1, 0.5)" (Poisson's ratio) need this. Its description
  // reads like deal.II's, "[Double 0...MAX_DOUBLE (exclusive)]", so both are told alike.
  class OpenInterval : public dealii::Patterns::PatternBase
  {
  public:
    explicit OpenInterval(double lower, double upper = std::numeric_limits<double>::max());
    bool        match(const std::string &text) const override;
    std::string description(OutputStyle style = Machine) const override;
    std::unique_ptr<dealii::Patterns::PatternBase> clone() const override;

  private:
    double lower, upper;
  };

  // "must be a number > 0", "must be an integer in [1, 2]", "must be one of none, display, haptic"
  // from a pattern's description (deal.II's or OpenInterval's).
  std::string allowed_values(const std::string &pattern_description);

  // The closest of a ';'-free list of names to 'name' (edit distance, case ignored), or "" when none
  // is close (more than a third of the name's letters differ).
  std::string closest_name(const std::string &name, const std::vector<std::string> &names);
} // namespace modal_haptics::parameter_messages
