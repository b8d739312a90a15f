// Nothing already written is lost: a file is written complete beside its target and renamed over it
// (rename is atomic within a file system), so a reader sees the old file or the new one, never half
// of one. Every stage writes its outputs this way: the precompute (output/atomic_file.h adds its
// exceptions and the staged sets), the meshing stage's meshes and keys, the real-time tools' files.
// Header-only, C++17 and POSIX (getpid), so that a stage that links no mrt object may include it.
#pragma once

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>
#include <system_error>
#include <unistd.h>

namespace mrt
{
  // The temporary file beside `target`, unique to this process (two runs into one folder do not
  // share it); `extension` ends the name, for a writer that picks its format from it (gmsh).
  inline std::string temporary_name(const std::string &target, const std::string &extension = "")
  {
    return target + ".tmp." + std::to_string(::getpid()) + extension;
  }

  // Renames a complete `temporary` over `target`. false and `error` naming both if it cannot (the
  // temporary is then removed; the target is as it was).
  inline bool commit_temporary(const std::string &temporary, const std::string &target, std::string &error)
  {
    if (std::rename(temporary.c_str(), target.c_str()) == 0)
      return true;
    error = "cannot rename '" + temporary + "' to '" + target + "': " + std::strerror(errno);
    std::remove(temporary.c_str());
    return false;
  }

  // Writes `text` to `path` through a temporary file. false and `error` naming the file on failure.
  inline bool write_text_atomically(const std::string &path, const std::string &text, std::string &error)
  {
    const std::string temporary = temporary_name(path);
    std::FILE        *file      = std::fopen(temporary.c_str(), "wb");
    if (!file)
      {
        error = "cannot write '" + temporary + "': " + std::strerror(errno);
        return false;
      }
    const bool written = std::fwrite(text.data(), 1, text.size(), file) == text.size();
    const int  cause   = errno;
    if (std::fclose(file) != 0 || !written)
      {
        error = "cannot write '" + path + "': " + std::strerror(written ? errno : cause) + " (disk full?)";
        std::remove(temporary.c_str());
        return false;
      }
    return commit_temporary(temporary, path, error);
  }

  // Copies `from` to `to` through a temporary file. false and `error` naming both on failure.
  inline bool copy_file_atomically(const std::string &from, const std::string &to, std::string &error)
  {
    const std::string temporary = temporary_name(to);
    std::error_code   code;
    std::filesystem::copy_file(from, temporary, std::filesystem::copy_options::overwrite_existing, code);
    if (code)
      {
        error = "cannot copy '" + from + "' to '" + to + "': " + code.message();
        std::remove(temporary.c_str());
        return false;
      }
    return commit_temporary(temporary, to, error);
  }
} // namespace mrt
