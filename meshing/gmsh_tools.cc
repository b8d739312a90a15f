#include "gmsh_tools.h"

#include <gmsh.h>
#include <mrt/atomic_file.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <set>

namespace modal_haptics::meshing::detail
{
  namespace
  {
    int open_sessions = 0;

    using Matrix3 = std::array<std::array<double, 3>, 3>;

    double determinant(const Matrix3 &m)
    {
      return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
             m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    }

    Matrix3 product(const Matrix3 &a, const Matrix3 &b)
    {
      Matrix3 c{};
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
          for (int k = 0; k < 3; ++k)
            c[i][j] += a[i][k] * b[k][j];
      return c;
    }

    Matrix3 inverse(const Matrix3 &m)
    {
      const double det = determinant(m);
      Matrix3      inv{};
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
          {
            // cofactor of m[j][i], via cyclic indices
            const int r1 = (j + 1) % 3, r2 = (j + 2) % 3, c1 = (i + 1) % 3, c2 = (i + 2) % 3;
            inv[i][j] = (m[r1][c1] * m[r2][c2] - m[r1][c2] * m[r2][c1]) / det;
          }
      return inv;
    }

    double frobenius_norm(const Matrix3 &m)
    {
      double sum = 0.;
      for (const auto &row : m)
        for (const double v : row)
          sum += v * v;
      return std::sqrt(sum);
    }

    // Edge matrix (columns b-a, c-a, d-a) of a tet.
    Matrix3 edge_matrix(const Point3 &a, const Point3 &b, const Point3 &c, const Point3 &d)
    {
      Matrix3 e{};
      for (int i = 0; i < 3; ++i)
        {
          e[i][0] = b[i] - a[i];
          e[i][1] = c[i] - a[i];
          e[i][2] = d[i] - a[i];
        }
      return e;
    }

    // Maps the regular unit-edge tet onto the reference directions, so that the condition number
    // is measured against the ideal element and not against the right-angled reference tet.
    const Matrix3 &inverse_regular_tet()
    {
      static const Matrix3 w_inverse = inverse(edge_matrix({0., 0., 0.}, {1., 0., 0.}, {0.5, std::sqrt(3.) / 2., 0.},
                                                           {0.5, std::sqrt(3.) / 6., std::sqrt(2. / 3.)}));
      return w_inverse;
    }

    std::vector<int> group_entities(int dim, int tag)
    {
      std::vector<int> entities;
      gmsh::model::getEntitiesForPhysicalGroup(dim, tag, entities);
      return entities;
    }


    std::set<std::pair<int, std::string>> groups_added; // by complete_physical_groups

    // The physical groups of dimension 'dim' that hold no entity: gmsh loads 'Physical
    // Surface("wall") = {};' as a name without a group, which getPhysicalGroups omits.
    std::vector<std::string> empty_named_groups(const int dim)
    {
      int           largest = 0;
      std::set<int> held;
      for (const auto &[tag, name] : physical_groups(dim))
        {
          largest = std::max(largest, tag);
          held.insert(tag);
        }
      std::vector<std::string> empty;
      for (int tag = 1; tag <= largest + 64; ++tag)
        {
          std::string name;
          gmsh::model::getPhysicalName(dim, tag, name);
          if (!name.empty() && held.count(tag) == 0)
            empty.push_back(name);
        }
      return empty;
    }

    // Adds 'faces' to the surface group "free", creating it when it does not exist.
    void add_to_free_group(const std::vector<int> &faces)
    {
      int              free_tag = 0, largest_tag = 0;
      std::vector<int> members  = faces;
      for (const auto &[tag, name] : physical_groups(2))
        {
          largest_tag = std::max(largest_tag, tag);
          if (name == "free")
            free_tag = tag;
        }
      if (free_tag > 0)
        {
          const auto existing = group_entities(2, free_tag);
          members.insert(members.end(), existing.begin(), existing.end());
          gmsh::model::removePhysicalGroups({{2, free_tag}});
        }
      else
        {
          free_tag = largest_tag + 1;
          groups_added.insert({2, "free"});
        }
      add_named_group(2, members, "free", free_tag);
    }
  } // namespace

  std::vector<std::pair<int, std::string>> physical_groups(const int dim)
  {
    DimTags groups;
    gmsh::model::getPhysicalGroups(groups, dim);
    std::vector<std::pair<int, std::string>> named;
    for (const auto &[d, tag] : groups)
      {
        std::string name;
        gmsh::model::getPhysicalName(d, tag, name);
        named.emplace_back(tag, name);
      }
    return named;
  }

  bool gmsh_log_shown = false; // show_gmsh_log

  GmshSession::GmshSession(const bool verbose)
  {
    if (open_sessions++ == 0)
      {
        // No user configuration files: the mesh must depend on the settings only.
        gmsh::initialize(0, nullptr, false);
        gmsh::option::setNumber("General.Terminal", verbose ? 1 : 0);
        // 2: errors and warnings; 5 (gmsh's default): also its progress and information lines.
        gmsh::option::setNumber("General.Verbosity", gmsh_log_shown ? 5 : 2);
      }
  }

  GmshSession::~GmshSession()
  {
    if (--open_sessions == 0)
      gmsh::finalize();
  }

  void call_gmsh(const std::string &context, const std::function<void()> &block)
  {
    try
      {
        block();
      }
    catch (const MeshingError &)
      {
        throw;
      }
    catch (const std::string &message)
      {
        throw MeshingError(context + ": gmsh: " + message);
      }
    catch (const std::exception &e)
      {
        throw MeshingError(context + ": gmsh: " + e.what());
      }
  }

  std::string gmsh_version()
  {
    std::string version;
    gmsh::option::getString("General.Version", version);
    return version;
  }

  std::vector<int> entities_inside_box(const int dim, const Point3 &lower, const Point3 &upper, const double tolerance)
  {
    DimTags found;
    gmsh::model::getEntitiesInBoundingBox(lower[0] - tolerance, lower[1] - tolerance, lower[2] - tolerance,
                                          upper[0] + tolerance, upper[1] + tolerance, upper[2] + tolerance, found, dim);
    std::vector<int> tags;
    for (const auto &dim_tag : found)
      tags.push_back(dim_tag.second);
    return tags;
  }

  std::vector<int> boundary_faces()
  {
    DimTags volumes, faces;
    gmsh::model::getEntities(volumes, 3);
    gmsh::model::getBoundary(volumes, faces, true, false, false);
    std::set<int> tags;
    for (const auto &dim_tag : faces)
      tags.insert(std::abs(dim_tag.second));
    return {tags.begin(), tags.end()};
  }

  void add_named_group(const int dim, const std::vector<int> &entities, const std::string &name, const int tag)
  {
    if (entities.empty())
      return;
    const std::set<int> unique(entities.begin(), entities.end());
    gmsh::model::addPhysicalGroup(dim, {unique.begin(), unique.end()}, tag);
    gmsh::model::setPhysicalName(dim, tag, name);
  }

  std::vector<std::pair<int, std::string>> require_named_groups(const std::string &context)
  {
    std::set<std::string> held_names;
    for (int dim = 0; dim <= 3; ++dim)
      for (const auto &[tag, name] : physical_groups(dim))
        {
          if (name.empty())
            throw MeshingError(context + ": physical group of dimension " + std::to_string(dim) + " with tag " +
                               std::to_string(tag) + " has no name; name every group, e.g. Physical Surface(\"clamp\", " +
                               std::to_string(tag) + ") = {...};");
          held_names.insert(name);
        }
    std::vector<std::pair<int, std::string>> empty;
    for (int dim = 0; dim <= 3; ++dim)
      for (const auto &name : empty_named_groups(dim))
        empty.emplace_back(dim, name);
    // Removed, so that no mesh carries a name without elements (readers accept one silently); gmsh
    // removes a name in every dimension, so one that a group of another dimension holds stays.
    for (const auto &[dim, name] : empty)
      if (held_names.count(name) == 0)
        gmsh::model::removePhysicalName(name);
    return empty;
  }

  std::string empty_group_words(const int dim, const std::string &name)
  {
    static const char *const kinds[4]    = {"point", "curve", "surface", "volume"};
    static const char *const keywords[4] = {"Point", "Curve", "Surface", "Volume"};
    const int                d           = std::clamp(dim, 0, 3);
    return std::string("the physical ") + kinds[d] + " '" + name + "' holds no " + kinds[d] + " (gmsh loads 'Physical " +
           keywords[d] + "(\"" + name + "\") = {};' without a word)";
  }

  bool added_by_program(const int dim, const std::string &name)
  {
    return groups_added.count({dim, name}) > 0;
  }

  void complete_physical_groups()
  {
    groups_added.clear();
    if (physical_groups(3).empty())
      {
        DimTags          volumes;
        std::vector<int> tags;
        gmsh::model::getEntities(volumes, 3);
        for (const auto &dim_tag : volumes)
          tags.push_back(dim_tag.second);
        add_named_group(3, tags, "part", 1);
        groups_added.insert({3, "part"});
      }

    std::set<int> covered;
    for (const auto &group : physical_groups(2))
      for (const int face : group_entities(2, group.first))
        covered.insert(face);
    std::vector<int> uncovered;
    for (const int face : boundary_faces())
      if (covered.count(face) == 0)
        uncovered.push_back(face);
    if (!uncovered.empty())
      add_to_free_group(uncovered);
  }

  PlainMesh read_current_mesh(const bool with_tets, const bool only_triangle_nodes)
  {
    std::vector<std::size_t> node_tags, tet_nodes, triangle_tags, triangle_nodes;
    std::vector<double>      coordinates, parametric;
    PlainMesh                mesh;
    gmsh::model::mesh::getNodes(node_tags, coordinates, parametric, -1, -1, false, false);
    if (with_tets)
      gmsh::model::mesh::getElementsByType(4, mesh.tet_tags, tet_nodes);
    gmsh::model::mesh::getElementsByType(2, triangle_tags, triangle_nodes);

    // gmsh's node tags are nearly dense: a vector indexed by tag is the cheapest map.
    const std::size_t largest_tag = node_tags.empty() ? 0 : *std::max_element(node_tags.begin(), node_tags.end());
    constexpr auto    unused      = static_cast<unsigned int>(-1);
    std::vector<std::size_t>  position_of_tag(largest_tag + 1, 0);
    std::vector<unsigned int> index_of_tag(largest_tag + 1, unused);
    std::vector<bool>         wanted(largest_tag + 1, !only_triangle_nodes);
    for (std::size_t i = 0; i < node_tags.size(); ++i)
      position_of_tag[node_tags[i]] = i;
    if (only_triangle_nodes)
      for (const std::size_t tag : triangle_nodes)
        wanted[tag] = true;

    std::vector<std::size_t> sorted_tags = node_tags;
    std::sort(sorted_tags.begin(), sorted_tags.end());
    for (const std::size_t tag : sorted_tags)
      if (wanted[tag])
        {
          const std::size_t p = position_of_tag[tag];
          index_of_tag[tag]   = static_cast<unsigned int>(mesh.nodes.size());
          mesh.nodes.push_back({coordinates[3 * p], coordinates[3 * p + 1], coordinates[3 * p + 2]});
        }

    for (std::size_t t = 0; t + 3 < tet_nodes.size(); t += 4)
      mesh.tets.push_back({index_of_tag[tet_nodes[t]], index_of_tag[tet_nodes[t + 1]], index_of_tag[tet_nodes[t + 2]],
                           index_of_tag[tet_nodes[t + 3]]});
    for (std::size_t t = 0; t < triangle_nodes.size(); t += 3)
      mesh.triangles.push_back(
        {index_of_tag[triangle_nodes[t]], index_of_tag[triangle_nodes[t + 1]], index_of_tag[triangle_nodes[t + 2]]});
    return mesh;
  }

  void write_mesh_atomically(const std::string &path)
  {
    // gmsh picks the format from the extension, so the temporary name must end in .msh too.
    const std::string temporary = mrt::temporary_name(path, ".msh");
    gmsh::option::setNumber("Mesh.MshFileVersion", 4.1);
    gmsh::option::setNumber("Mesh.Binary", 0);
    gmsh::option::setNumber("Mesh.SaveAll", 0);
    try
      {
        gmsh::write(temporary);
      }
    catch (...)
      {
        std::remove(temporary.c_str());
        throw;
      }
    if (!std::filesystem::exists(temporary))
      throw MeshingError("gmsh did not write '" + temporary + "'");
    std::string error;
    if (!mrt::commit_temporary(temporary, path, error))
      throw MeshingError(error);
  }


  double tet_sicn(const Point3 &a, const Point3 &b, const Point3 &c, const Point3 &d)
  {
    const Matrix3 s     = product(edge_matrix(a, b, c, d), inverse_regular_tet());
    const double  det_s = determinant(s);
    // |S^-1|_F = |adj S|_F / |det S|, so 3 / (|S|_F |S^-1|_F) needs no division by a zero det.
    Matrix3 adjugate{};
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        {
          const int r1 = (j + 1) % 3, r2 = (j + 2) % 3, c1 = (i + 1) % 3, c2 = (i + 2) % 3;
          adjugate[i][j] = s[r1][c1] * s[r2][c2] - s[r1][c2] * s[r2][c1];
        }
    const double norms = frobenius_norm(s) * frobenius_norm(adjugate);
    return norms > 0. ? 3. * det_s / norms : 0.;
  }

  double triangle_shape_quality(const Point3 &a, const Point3 &b, const Point3 &c)
  {
    Point3 ab, ac, bc, normal;
    for (int i = 0; i < 3; ++i)
      {
        ab[i] = b[i] - a[i];
        ac[i] = c[i] - a[i];
        bc[i] = c[i] - b[i];
      }
    normal = {ab[1] * ac[2] - ab[2] * ac[1], ab[2] * ac[0] - ab[0] * ac[2], ab[0] * ac[1] - ab[1] * ac[0]};
    const auto   squared = [](const Point3 &v) { return v[0] * v[0] + v[1] * v[1] + v[2] * v[2]; };
    const double area    = 0.5 * std::sqrt(squared(normal));
    const double edges   = squared(ab) + squared(ac) + squared(bc);
    return edges > 0. ? 4. * std::sqrt(3.) * area / edges : 0.;
  }
} // namespace modal_haptics::meshing::detail

namespace modal_haptics::meshing
{
  void show_gmsh_log(const bool shown)
  {
    detail::gmsh_log_shown = shown;
  }
} // namespace modal_haptics::meshing
