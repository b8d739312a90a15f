// The meshing stage's cache: the key of a mesh (a hash of every input it depends on) and the key file
// beside it (the key and the mesh's statistics), and the descriptions of inputs the keys are made of.
#include "mesher_parts.h"

#include <mrt/atomic_file.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <vector>

namespace modal_haptics::meshing::detail
{
  namespace fs = std::filesystem;

  // ---------------------------------------------------------------------------------------------
  // Hashing and the cache key files
  // ---------------------------------------------------------------------------------------------

  // FNV-1a, 64 bit: enough to tell whether the inputs of a mesh changed (not a security hash).
  std::uint64_t fnv1a(const char *data, const std::size_t size, std::uint64_t hash)
  {
    for (std::size_t i = 0; i < size; ++i)
      {
        hash ^= static_cast<unsigned char>(data[i]);
        hash *= 1099511628211ull;
      }
    return hash;
  }

  std::string hex(const std::uint64_t value)
  {
    std::ostringstream out;
    out << std::hex << std::setw(16) << std::setfill('0') << value;
    return out.str();
  }

  void require_readable(const std::string &file, const std::string &what)
  {
    std::ifstream input(file, std::ios::binary);
    if (file.empty() || !input || fs::is_directory(file))
      throw MeshingError(what + " '" + file + "' does not exist or cannot be read");
  }

  std::string file_content_hash(const std::string &file)
  {
    std::ifstream input(file, std::ios::binary);
    if (!input)
      throw MeshingError("geometry file '" + file + "' does not exist or cannot be read");
    std::uint64_t     hash = 14695981039346656037ull;
    std::vector<char> buffer(1 << 16);
    while (input.read(buffer.data(), static_cast<std::streamsize>(buffer.size())) || input.gcount() > 0)
      hash = fnv1a(buffer.data(), static_cast<std::size_t>(input.gcount()), hash);
    return hex(hash);
  }

  std::string describe_point(const Point3 &p)
  {
    std::ostringstream out;
    out << std::setprecision(17) << '[' << p[0] << ',' << p[1] << ',' << p[2] << ']';
    return out.str();
  }

  // For messages: short numbers.
  std::string readable_point(const Point3 &p)
  {
    std::ostringstream out;
    out << std::setprecision(6) << '[' << p[0] << ", " << p[1] << ", " << p[2] << ']';
    return out.str();
  }

  std::string describe_voi(const VolumeOfInterest &voi)
  {
    std::ostringstream out;
    out << std::setprecision(17) << "voi " << voi.name;
    if (voi.shape == VolumeOfInterest::Shape::box)
      out << " box " << describe_point(voi.box_lower) << describe_point(voi.box_upper);
    else
      out << " ball " << describe_point(voi.ball_centre) << ' ' << voi.ball_radius;
    out << " fine " << voi.fine_size << " transition " << voi.transition;
    return out.str();
  }

  // A short, readable region for error messages.
  std::string describe_region(const VolumeOfInterest &voi)
  {
    std::ostringstream out;
    if (voi.shape == VolumeOfInterest::Shape::box)
      out << "box " << readable_point(voi.box_lower) << '-' << readable_point(voi.box_upper);
    else
      out << "ball centre " << readable_point(voi.ball_centre) << " radius " << std::setprecision(6)
          << voi.ball_radius;
    return out.str();
  }


  bool read_key_file(const std::string &path, KeyFile &content)
  {
    std::ifstream input(path);
    std::string   word;
    if (!input)
      return false;
    MeshStatistics &s = content.statistics;
    while (input >> word)
      {
        if (word == "key") input >> content.key;
        else if (word == "n_nodes") input >> s.n_nodes;
        else if (word == "n_tets") input >> s.n_tets;
        else if (word == "min_quality") input >> s.min_quality;
        else if (word == "mean_quality") input >> s.mean_quality;
        else if (word == "max_quality") input >> s.max_quality;
        else std::getline(input, word); // comments and unknown lines
      }
    return !content.key.empty();
  }

  void write_text_atomically(const std::string &path, const std::string &text)
  {
    std::string error;
    if (!mrt::write_text_atomically(path, text, error))
      throw MeshingError(error);
  }


  void write_key_file(const std::string &path, const std::string &inputs, const std::string &key,
                      const MeshStatistics &s)
  {
    std::ostringstream out;
    out << std::setprecision(17) << "# inputs: " << inputs << "\nkey " << key << "\nn_nodes " << s.n_nodes
        << "\nn_tets " << s.n_tets << "\nmin_quality " << s.min_quality << "\nmean_quality " << s.mean_quality
        << "\nmax_quality " << s.max_quality << '\n';
    write_text_atomically(path, out.str());
  }

  std::string key_of(const std::string &inputs) { return hex(fnv1a(inputs.data(), inputs.size())); }
} // namespace modal_haptics::meshing::detail
