// Reading what the precompute needs from a MSH file: its physical names, the quality of its tets,
// the mesh of a named curve or point.
#include "mesher_parts.h"

#include <gmsh.h>

#include <fstream>
#include <map>
#include <sstream>

namespace modal_haptics::meshing
{
  using namespace detail;

  std::map<int, std::map<std::string, int>> read_physical_names(const std::string &msh_file)
  {
    std::ifstream input(msh_file);
    if (!input)
      throw MeshingError("mesh file '" + msh_file + "' does not exist or cannot be read");
    std::map<int, std::map<std::string, int>> names;
    std::string                               line;
    while (std::getline(input, line) && line.rfind("$PhysicalNames", 0) != 0)
      ;
    if (!input)
      return names; // no names in this file
    std::size_t count = 0;
    input >> count;
    std::getline(input, line);
    for (std::size_t i = 0; i < count && std::getline(input, line); ++i)
      {
        std::istringstream entry(line);
        int                dim = -1, tag = 0;
        entry >> dim >> tag;
        const auto first = line.find('"'), last = line.rfind('"');
        if (!entry || first == std::string::npos || last <= first)
          throw MeshingError("mesh file '" + msh_file + "': malformed $PhysicalNames line '" + line + "'");
        names[dim][line.substr(first + 1, last - first - 1)] = tag;
      }
    return names;
  }

  MeshStatistics check_mesh_quality(const std::string &msh_file, const double min_quality)
  {
    require_readable(msh_file, "mesh file");
    GmshSession session(false);
    PlainMesh   mesh;
    call_gmsh("reading mesh file '" + msh_file + "'", [&] {
      gmsh::clear();
      gmsh::open(msh_file);
      mesh = read_current_mesh(true, false);
    });
    return tet_statistics(mesh, min_quality, "mesh file '" + msh_file + "'");
  }

  GroupMesh read_physical_group(const std::string &msh_file, const int dim, const std::string &name)
  {
    require_readable(msh_file, "mesh file");
    GmshSession session(false);
    GroupMesh   group;
    call_gmsh("reading group '" + name + "' of mesh file '" + msh_file + "'", [&] {
      gmsh::clear();
      gmsh::open(msh_file);
      std::string known;
      for (const auto &[tag, group_name] : physical_groups(dim))
        {
          known += (known.empty() ? "'" : ", '") + group_name + "'";
          if (group_name != name)
            continue;
          std::vector<std::size_t> node_tags;
          std::vector<double>      coordinates;
          gmsh::model::mesh::getNodesForPhysicalGroup(dim, tag, node_tags, coordinates);
          std::map<std::size_t, unsigned int> index_of_tag;
          for (std::size_t i = 0; i < node_tags.size(); ++i)
            {
              index_of_tag[node_tags[i]] = static_cast<unsigned int>(i);
              group.nodes.push_back({coordinates[3 * i], coordinates[3 * i + 1], coordinates[3 * i + 2]});
            }
          std::vector<int> entities;
          gmsh::model::getEntitiesForPhysicalGroup(dim, tag, entities);
          for (const int entity : entities)
            {
              std::vector<int>                      types;
              std::vector<std::vector<std::size_t>> element_tags, element_nodes;
              gmsh::model::mesh::getElements(types, element_tags, element_nodes, dim, entity);
              for (std::size_t t = 0; t < types.size(); ++t)
                if (types[t] == 1) // 2-node line
                  for (std::size_t e = 0; e + 1 < element_nodes[t].size(); e += 2)
                    group.segments.push_back({index_of_tag.at(element_nodes[t][e]), index_of_tag.at(element_nodes[t][e + 1])});
            }
          return;
        }
      throw MeshingError("mesh file '" + msh_file + "' has no physical " + (dim == 1 ? "curve" : "point") + " '" +
                         name + "' (its physical " + (dim == 1 ? "curves" : "points") + ": " +
                         (known.empty() ? "none" : known) + ")");
    });
    return group;
  }
} // namespace modal_haptics::meshing
