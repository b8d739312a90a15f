// Nothing already written is lost: every output is written to a temporary file beside its target
// and renamed over it only when complete (rename is atomic within a file system); the main results
// of a run are renamed together at its end (StagedFiles).
#pragma once

#include <deal.II/base/exceptions.h>

#include <mrt/atomic_file.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <future>
#include <string>
#include <unistd.h>
#include <utility>
#include <vector>

namespace modal_haptics
{
  inline std::string temporary_name_for(const std::string &target) { return mrt::temporary_name(target); }

  // Renames a finished temporary file over its target, or removes it and throws.
  inline void commit_temporary_file(const std::string &temporary, const std::string &target)
  {
    std::string error;
    AssertThrow(mrt::commit_temporary(temporary, target, error), dealii::ExcMessage(error + "."));
  }

  // Calls write(stream) on `temporary`; on any failure (a full disk, an exception in write) the file
  // is removed and an exception names `target`.
  inline void write_temporary_file(const std::string &temporary, const std::string &target,
                                   const std::function<void(std::ostream &)> &write, const std::ios::openmode mode)
  {
    std::ofstream out(temporary, mode | std::ios::trunc);
    AssertThrow(out, dealii::ExcMessage("Cannot write '" + temporary + "': " + std::strerror(errno) +
                                        " (is the output folder writable?)."));
    int cause = 0;
    try
      {
        write(out);
        out.flush();
        cause = errno;
      }
    catch (...)
      {
        if (out) // the writer's own error
          {
            out.close();
            std::remove(temporary.c_str());
            throw;
          }
        // The stream failed and the writer said so in its own words (deal.II's writers throw a
        // generic ExcIO): the message below says which file and why.
        cause = errno;
      }
    if (!out)
      {
        out.close();
        std::remove(temporary.c_str());
        AssertThrow(false, dealii::ExcMessage("Writing '" + target + "' failed: " + std::strerror(cause) +
                                              " (disk full?); the previous file is kept."));
      }
  }

  // Calls write(stream) on a temporary file and renames it to target; on any failure the temporary
  // file is removed and target is left as it was.
  inline void write_file_atomically(const std::string &target, const std::function<void(std::ostream &)> &write,
                                    const std::ios::openmode mode = std::ios::out)
  {
    const std::string temporary = temporary_name_for(target);
    write_temporary_file(temporary, target, write, mode);
    commit_temporary_file(temporary, target);
  }

  // Files written atomically (as above) on threads of their own while the run goes on: a space's
  // VTU, one core's work for one to two seconds, while the next space's serial steps leave the
  // other core idle (docs/performance.md). One list per process, used from the main thread only.
  class BackgroundWrites
  {
  public:
    static BackgroundWrites &of_this_process()
    {
      static BackgroundWrites writes;
      return writes;
    }

    void write_file_atomically(const std::string &target, std::function<void(std::ostream &)> write)
    {
      pending_.push_back(std::async(std::launch::async, [target, write = std::move(write)] {
        modal_haptics::write_file_atomically(target, write);
      }));
    }

    // Returns when every file is written; rethrows the first failure (its message names the file).
    void wait()
    {
      auto pending = std::move(pending_);
      pending_.clear();
      for (auto &write : pending)
        write.wait();
      for (auto &write : pending)
        write.get();
    }

    // A run that fails still lets the files already begun finish (std::async's futures wait).
    ~BackgroundWrites() = default;

  private:
    BackgroundWrites() = default;
    std::vector<std::future<void>> pending_;
  };

  // The main results of a run (.h5, .mrt, used_parameters.prm, .pvd, report.json) are one set: each
  // is written complete into its temporary file, and they are renamed over their targets only when
  // every one is written. A run that fails or is killed before that leaves the previous run's set as
  // it was, never a new .h5 beside an old .mrt (a kill during the renames, microseconds, is the only
  // window for a mixed set). Temporaries never committed are removed with the object.
  class StagedFiles
  {
  public:
    StagedFiles() = default;
    StagedFiles(const StagedFiles &) = delete;
    StagedFiles &operator=(const StagedFiles &) = delete;
    ~StagedFiles()
    {
      for (const auto &[temporary, target] : files_)
        std::remove(temporary.c_str());
    }

    // The temporary file `target` is to be written into, by a writer that opens it itself.
    std::string stage(const std::string &target)
    {
      files_.emplace_back(temporary_name_for(target), target);
      return files_.back().first;
    }

    void write(const std::string &target, const std::function<void(std::ostream &)> &write,
               const std::ios::openmode mode = std::ios::out)
    {
      write_temporary_file(stage(target), target, write, mode);
    }

    // Where `target`'s content is now: its temporary while staged, else target itself.
    std::string current_path(const std::string &target) const
    {
      for (const auto &[temporary, staged_target] : files_)
        if (staged_target == target)
          return temporary;
      return target;
    }

    // Renames every staged file over its target, in staging order.
    void commit()
    {
      for (const auto &[temporary, target] : files_)
        commit_temporary_file(temporary, target);
      files_.clear();
    }

  private:
    std::vector<std::pair<std::string, std::string>> files_; // (temporary, target)
  };
} // namespace modal_haptics
