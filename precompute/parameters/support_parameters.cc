// Parsing 'Geometry/Supports' (supports.h): each entry's selection and restraint, every complaint
// naming the entry.
#include "scene/supports.h"

#include <deal.II/base/exceptions.h>
#include <deal.II/base/utilities.h>

#include <cmath>
#include <cstdlib>
#include <map>
#include <sstream>

namespace modal_haptics
{
  using namespace dealii;

  // ---- Parsing ---------------------------------------------------------------------------------
  namespace
  {
    std::vector<std::string> words_of(const std::string &text)
    {
      std::istringstream       in(text);
      std::vector<std::string> words;
      for (std::string word; in >> word;)
        words.push_back(word);
      return words;
    }

    // Reads the entry's words one by one, naming the entry in every complaint.
    class EntryReader
    {
    public:
      EntryReader(const std::string &entry, const std::string &part)
        : entry(entry)
        , words(words_of(part))
      {}
      bool        done() const { return next == words.size(); }
      std::string word(const std::string &what)
      {
        AssertThrow(!done(), ExcMessage(where() + ": " + what + " is missing."));
        return words[next++];
      }
      double number(const std::string &what)
      {
        const std::string w = word(what);
        char             *end = nullptr;
        const double      x   = std::strtod(w.c_str(), &end);
        AssertThrow(end && *end == '\0' && std::isfinite(x),
                    ExcMessage(where() + ": " + what + " must be a number, not '" + w + "'."));
        return x;
      }
      meshing::Point3 point(const std::string &what)
      {
        return {{number(what + " (x)"), number(what + " (y)"), number(what + " (z)")}};
      }
      void finish() const
      {
        AssertThrow(done(), ExcMessage(where() + ": unexpected '" + words[next] + "'."));
      }
      std::string where() const { return "'Geometry/Supports' entry '" + entry + "'"; }

    private:
      const std::string              entry;
      const std::vector<std::string> words;
      std::size_t                    next = 0;
    };

    Tensor<1, 3> tensor(const meshing::Point3 &p) { return Tensor<1, 3>({p[0], p[1], p[2]}); }

    Tensor<1, 3> unit_vector(const meshing::Point3 &p, const EntryReader &reader, const std::string &what)
    {
      const Tensor<1, 3> v = tensor(p);
      AssertThrow(v.norm() > 0., ExcMessage(reader.where() + ": the " + what + " must not be zero."));
      return v / v.norm();
    }

    SupportSelection parse_selection(EntryReader &in)
    {
      using Kind = SupportSelection::Kind;
      static const std::map<std::string, Kind> kinds = {{"surface", Kind::surface}, {"curve", Kind::curve},
                                                        {"point", Kind::point},     {"box", Kind::box},
                                                        {"nodes", Kind::nodes},     {"plane", Kind::plane},
                                                        {"normal", Kind::normal}};
      const std::string word = in.word("the selection");
      const auto        kind = kinds.find(word);
      AssertThrow(kind != kinds.end(),
                  ExcMessage(in.where() + ": unknown selection '" + word +
                             "' (known: surface NAME, curve NAME, point NAME, box x0 y0 z0 x1 y1 z1, nodes x0 y0 z0 "
                             "x1 y1 z1, plane px py pz nx ny nz, normal nx ny nz ANGLE)."));
      SupportSelection s;
      s.kind = kind->second;
      switch (s.kind)
        {
          case Kind::surface:
          case Kind::curve:
          case Kind::point:
            s.name = in.word("the group's name");
            break;
          case Kind::box:
          case Kind::nodes:
            s.lower = in.point("the box's first corner");
            s.upper = in.point("the box's second corner");
            for (unsigned int d = 0; d < 3; ++d)
              if (s.lower[d] > s.upper[d])
                std::swap(s.lower[d], s.upper[d]);
            break;
          case Kind::plane:
            s.point     = in.point("the plane's point");
            s.direction = in.point("the plane's normal");
            unit_vector(s.direction, in, "plane's normal");
            break;
          case Kind::normal:
            s.direction     = in.point("the direction");
            s.angle_degrees = in.number("the angle [degrees]");
            unit_vector(s.direction, in, "direction");
            AssertThrow(s.angle_degrees >= 0. && s.angle_degrees < 180.,
                        ExcMessage(in.where() + ": the angle must lie in [0, 180) degrees."));
            break;
        }
      in.finish();
      return s;
    }

    // 'fix COMPONENTS [in frame e1 e2 | in cylinder origin axis]'
    void parse_fixed_components(EntryReader &in, SupportRestraint &r)
    {
      const std::string components = in.word("the components to fix (e.g. 'z', 'xy', 'r')");
      if (!in.done())
        {
          AssertThrow(in.word("'in'") == "in", ExcMessage(in.where() + ": expected 'in frame ...' or 'in cylinder ...'."));
          const std::string frame = in.word("the frame ('frame' or 'cylinder')");
          if (frame == "frame")
            {
              r.frame              = SupportRestraint::Frame::cartesian;
              r.e1                 = unit_vector(in.point("the frame's first axis"), in, "first axis");
              const Tensor<1, 3> b = tensor(in.point("the frame's second axis"));
              r.e2                 = b - (b * r.e1) * r.e1;
              AssertThrow(r.e2.norm() > 1e-6 * b.norm(),
                          ExcMessage(in.where() + ": the frame's axes must not be parallel."));
              r.e2 /= r.e2.norm();
            }
          else if (frame == "cylinder")
            {
              r.frame  = SupportRestraint::Frame::cylinder;
              r.origin = Point<3>(tensor(in.point("the axis' point")));
              r.axis   = unit_vector(in.point("the axis' direction"), in, "axis' direction");
            }
          else
            AssertThrow(false, ExcMessage(in.where() + ": unknown frame '" + frame + "' (known: frame, cylinder)."));
        }
      const std::string names = r.frame == SupportRestraint::Frame::cylinder ? "rtz" : "xyz";
      for (const char c : components)
        {
          const auto d = names.find(c);
          AssertThrow(d != std::string::npos,
                      ExcMessage(in.where() + ": component '" + std::string(1, c) + "' is not one of '" + names +
                                 "' (the " + (names == "rtz" ? "cylinder's" : "frame's") + " components)."));
          r.components[d] = true;
        }
      in.finish();
    }

    SupportRestraint parse_restraint(EntryReader &in)
    {
      using Kind = SupportRestraint::Kind;
      SupportRestraint  r;
      const std::string word = in.word("the restraint");
      if (word == "clamp")
        r.kind = Kind::clamp;
      else if (word == "roller" || word == "slider")
        r.kind = Kind::roller;
      else if (word == "symmetry")
        r.kind = Kind::symmetry;
      else if (word == "fix")
        {
          r.kind = Kind::fix;
          parse_fixed_components(in, r);
        }
      else if (word == "elastic")
        {
          r.kind                 = Kind::elastic;
          r.normal_stiffness     = in.number("the normal stiffness [N/m^3]");
          r.tangential_stiffness = in.number("the tangential stiffness [N/m^3]");
          AssertThrow(r.normal_stiffness >= 0. && r.tangential_stiffness >= 0. &&
                        r.normal_stiffness + r.tangential_stiffness > 0.,
                      ExcMessage(in.where() + ": the stiffnesses must be >= 0 and not both 0 [N/m^3]."));
        }
      else
        AssertThrow(false, ExcMessage(in.where() + ": unknown restraint '" + word +
                                      "' (known: clamp, fix COMPONENTS [in frame e1 e2 | in cylinder p a], roller, "
                                      "symmetry, elastic KN KT)."));
      in.finish();
      return r;
    }
  } // namespace

  std::vector<Support> parse_supports(const std::string &text)
  {
    std::vector<Support> supports;
    for (const std::string &entry : Utilities::split_string_list(text, ';'))
      {
        if (entry.empty())
          continue;
        const auto colon = entry.find(':');
        AssertThrow(colon != std::string::npos,
                    ExcMessage("'Geometry/Supports' entry '" + entry + "': write '<selection> : <restraint>', e.g. "
                               "'surface clamp : clamp' or 'curve edges : fix z'."));
        Support s;
        s.text  = entry;
        s.index = supports.size();
        EntryReader selection(entry, entry.substr(0, colon)), restraint(entry, entry.substr(colon + 1));
        s.selection = parse_selection(selection);
        s.restraint = parse_restraint(restraint);
        const bool on_faces = s.selection.selects_faces();
        AssertThrow(on_faces || (s.restraint.kind != SupportRestraint::Kind::roller &&
                                 s.restraint.kind != SupportRestraint::Kind::symmetry &&
                                 s.restraint.kind != SupportRestraint::Kind::elastic),
                    ExcMessage(selection.where() + ": a roller, a symmetry or an elastic support needs faces (a "
                               "surface, box, plane or normal selection): curves and points have no normal or area."));
        supports.push_back(s);
      }
    return supports;
  }

  std::vector<Support> clamp_group_supports(const std::vector<std::string> &groups)
  {
    std::string text;
    for (const auto &group : groups)
      text += (text.empty() ? "" : "; ") + ("surface " + group + " : clamp");
    return parse_supports(text);
  }

} // namespace modal_haptics
