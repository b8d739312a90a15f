// Nothing already written is lost: every output is written to a temporary file beside its target
// and renamed over it only when complete (rename is atomic within a file system).
#pragma once

#include <deal.II/base/exceptions.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <unistd.h>

namespace modal_haptics
{
  inline std::string temporary_name_for(const std::string &target)
  {
    return target + ".tmp." + std::to_string(::getpid());
  }

  // Renames a finished temporary file over its target, or removes it and throws.
  inline void commit_temporary_file(const std::string &temporary, const std::string &target)
  {
    if (std::rename(temporary.c_str(), target.c_str()) != 0)
      {
        std::remove(temporary.c_str());
        AssertThrow(false, dealii::ExcMessage("Cannot rename '" + temporary + "' to '" + target + "'."));
      }
  }

  // Calls write(stream) on a temporary file and renames it to target; on any failure (a full disk,
  // an exception in write) the temporary file is removed and target is left as it was.
  inline void write_file_atomically(const std::string &target, const std::function<void(std::ostream &)> &write,
                                    const std::ios::openmode mode = std::ios::out)
  {
    const std::string temporary = temporary_name_for(target);
    {
      std::ofstream out(temporary, mode | std::ios::trunc);
      AssertThrow(out, dealii::ExcMessage("Cannot write '" + temporary + "' (is the output folder writable?)."));
      try
        {
          write(out);
          out.flush();
        }
      catch (...)
        {
          out.close();
          std::remove(temporary.c_str());
          throw;
        }
      if (!out)
        {
          out.close();
          std::remove(temporary.c_str());
          AssertThrow(false, dealii::ExcMessage("Writing '" + target + "' failed (disk full?); the previous file is kept."));
        }
    }
    commit_temporary_file(temporary, target);
  }
} // namespace modal_haptics
