// The display surface: one conforming, outward-oriented triangulation of the part's whole boundary,
// made from gmsh's surface mesh (or from the boundary faces of a .msh input's tets) and written so that
// reading it back gives the same arrays.
#include "mesher_parts.h"

#include "gmsh_tools.h"

#include <gmsh.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <queue>
#include <unordered_map>

namespace modal_haptics::meshing::detail
{
  // ---------------------------------------------------------------------------------------------
  // The display surface: one conforming, outward-oriented triangulation of the whole boundary
  // ---------------------------------------------------------------------------------------------

  // Merges nodes with identical coordinates (entities meshed separately may duplicate them) and
  // drops the triangles that collapse.
  void merge_duplicate_vertices(DisplaySurface &surface)
  {
    std::map<Point3, unsigned int> index_of;
    std::vector<unsigned int>      new_index(surface.vertices.size());
    std::vector<Point3>            merged;
    for (std::size_t v = 0; v < surface.vertices.size(); ++v)
      {
        const auto inserted = index_of.emplace(surface.vertices[v], static_cast<unsigned int>(merged.size()));
        if (inserted.second)
          merged.push_back(surface.vertices[v]);
        new_index[v] = inserted.first->second;
      }
    std::vector<std::array<unsigned int, 3>> kept;
    for (const auto &t : surface.triangles)
      {
        const std::array<unsigned int, 3> n{new_index[t[0]], new_index[t[1]], new_index[t[2]]};
        if (n[0] != n[1] && n[1] != n[2] && n[0] != n[2])
          kept.push_back(n);
      }
    surface.vertices  = std::move(merged);
    surface.triangles = std::move(kept);
  }

  std::uint64_t edge_key(unsigned int a, unsigned int b)
  {
    if (a > b)
      std::swap(a, b);
    return (std::uint64_t(a) << 32) | b;
  }

  bool has_directed_edge(const std::array<unsigned int, 3> &t, const unsigned int a, const unsigned int b)
  {
    for (int i = 0; i < 3; ++i)
      if (t[i] == a && t[(i + 1) % 3] == b)
        return true;
    return false;
  }

  // Makes neighbouring triangles agree (a shared manifold edge is run through in opposite
  // directions) and returns the connected component of each triangle.
  std::vector<unsigned int> orient_consistently(std::vector<std::array<unsigned int, 3>> &triangles)
  {
    std::unordered_map<std::uint64_t, std::vector<unsigned int>> triangles_of_edge;
    for (unsigned int t = 0; t < triangles.size(); ++t)
      for (int i = 0; i < 3; ++i)
        triangles_of_edge[edge_key(triangles[t][i], triangles[t][(i + 1) % 3])].push_back(t);

    constexpr auto            unvisited = static_cast<unsigned int>(-1);
    std::vector<unsigned int> component(triangles.size(), unvisited);
    unsigned int              n_components = 0;
    for (unsigned int seed = 0; seed < triangles.size(); ++seed)
      {
        if (component[seed] != unvisited)
          continue;
        std::queue<unsigned int> front;
        component[seed] = n_components;
        front.push(seed);
        while (!front.empty())
          {
            const unsigned int t = front.front();
            front.pop();
            for (int i = 0; i < 3; ++i)
              {
                const unsigned int a = triangles[t][i], b = triangles[t][(i + 1) % 3];
                const auto        &sharing = triangles_of_edge[edge_key(a, b)];
                if (sharing.size() != 2) // a boundary or non-manifold edge says nothing
                  continue;
                const unsigned int n = sharing[0] == t ? sharing[1] : sharing[0];
                if (component[n] != unvisited)
                  continue;
                if (has_directed_edge(triangles[n], a, b))
                  std::swap(triangles[n][1], triangles[n][2]);
                component[n] = n_components;
                front.push(n);
              }
          }
        ++n_components;
      }
    return component;
  }

  // Turns every connected component outward: its enclosed volume, sum of centroid . (area normal)
  // (= 3 V by the divergence theorem), must be positive. Assumes the part has no inner voids.
  void orient_outward(DisplaySurface &surface)
  {
    const std::vector<unsigned int> component = orient_consistently(surface.triangles);
    const unsigned int n_components = component.empty() ? 0 : *std::max_element(component.begin(), component.end()) + 1;
    std::vector<double> signed_volume(n_components, 0.);
    for (std::size_t t = 0; t < surface.triangles.size(); ++t)
      {
        const Point3 &a = surface.vertices[surface.triangles[t][0]], &b = surface.vertices[surface.triangles[t][1]],
                     &c = surface.vertices[surface.triangles[t][2]];
        // a . (b x c) is 6 times the signed volume of the tet (origin, a, b, c).
        signed_volume[component[t]] += a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
                                       a[2] * (b[0] * c[1] - b[1] * c[0]);
      }
    for (std::size_t t = 0; t < surface.triangles.size(); ++t)
      if (signed_volume[component[t]] < 0.)
        std::swap(surface.triangles[t][1], surface.triangles[t][2]);
  }

  MeshStatistics triangle_statistics(const DisplaySurface &surface)
  {
    MeshStatistics s;
    s.n_nodes = surface.vertices.size();
    if (surface.triangles.empty())
      return s;
    s.min_quality = std::numeric_limits<double>::max();
    double sum    = 0.;
    for (const auto &t : surface.triangles)
      {
        const double q =
          triangle_shape_quality(surface.vertices[t[0]], surface.vertices[t[1]], surface.vertices[t[2]]);
        s.min_quality = std::min(s.min_quality, q);
        s.max_quality = std::max(s.max_quality, q);
        sum += q;
      }
    s.mean_quality = sum / double(surface.triangles.size());
    return s;
  }

  DisplaySurface display_surface_from(const PlainMesh &mesh)
  {
    DisplaySurface surface;
    surface.vertices  = mesh.nodes;
    surface.triangles = mesh.triangles;
    merge_duplicate_vertices(surface);
    orient_outward(surface);
    return surface;
  }

  // The faces of the tets that belong to one tet only, oriented outward (for a .msh input,
  // which may not hold boundary triangles at all).
  PlainMesh boundary_of_tets(const PlainMesh &mesh)
  {
    std::map<std::array<unsigned int, 3>, std::pair<int, std::array<unsigned int, 3>>> faces;
    static constexpr int local_faces[4][3] = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
    for (const auto &tet : mesh.tets)
      for (const auto &f : local_faces)
        {
          const std::array<unsigned int, 3> face{tet[f[0]], tet[f[1]], tet[f[2]]};
          auto                              sorted = face;
          std::sort(sorted.begin(), sorted.end());
          auto &entry = faces[sorted];
          entry.first += 1;
          entry.second = face;
        }
    PlainMesh boundary;
    boundary.nodes = mesh.nodes;
    for (const auto &entry : faces)
      if (entry.second.first == 1)
        boundary.triangles.push_back(entry.second.second);
    return boundary;
  }

  // Writes the display surface exactly as returned (same vertex order, same orientation), so
  // reading the file back gives the same arrays.
  void write_display_surface(const DisplaySurface &surface, const std::string &path)
  {
    gmsh::clear();
    gmsh::model::add("display_surface");
    const int                entity = gmsh::model::addDiscreteEntity(2);
    std::vector<std::size_t> node_tags(surface.vertices.size()), element_tags(surface.triangles.size()),
      element_nodes;
    std::vector<double> coordinates;
    for (std::size_t v = 0; v < surface.vertices.size(); ++v)
      {
        node_tags[v] = v + 1;
        coordinates.insert(coordinates.end(), surface.vertices[v].begin(), surface.vertices[v].end());
      }
    for (std::size_t t = 0; t < surface.triangles.size(); ++t)
      {
        element_tags[t] = t + 1;
        for (const unsigned int v : surface.triangles[t])
          element_nodes.push_back(v + 1);
      }
    gmsh::model::mesh::addNodes(2, entity, node_tags, coordinates);
    gmsh::model::mesh::addElementsByType(entity, 2, element_tags, element_nodes);
    add_named_group(2, {entity}, "display_surface", 1);
    write_mesh_atomically(path);
  }
} // namespace modal_haptics::meshing::detail
