// A scenario computed as a job of its own (`modal-precompute SCENE.prm --scenario NAME`): its modal
// space, and what the merge (`--merge`) checks it against before writing the scene's files.
// docs/cluster.md describes the workflow.
//
// The file is a private intermediate of one build of modal-precompute (a Boost.Serialization binary
// archive, as deal.II uses for its checkpoints): exact to the bit, not an exchange format. Its first
// line names the format, so that anything else is refused with a message.
#pragma once

#include "scene_mesher.h"
#include "results/space_result.h"

#include "scene_mesher.h" // meshing/: the display surface

#include <cstdint>
#include <string>

namespace modal_haptics
{
  struct PartialResult
  {
    std::string   scene_name;
    std::string   parameters;            // every scene parameter as ParameterHandler prints it (ShortText)
    std::uint32_t display_checksum = 0;  // CRC-32 of the display surface (display_surface_checksum)
    std::uint32_t mesh_checksum    = 0;  // CRC-32 of the scenario's .msh file (file_checksum)
    unsigned int  n_processes      = 1;  // MPI processes of the job
    double        peak_memory_mb   = 0.; // the largest peak resident memory of one of them
    double        seconds          = 0.; // the job's wall time
    ModalSpaceResult space;
  };

  // DIRECTORY/NAME.partial: where the job of scenario NAME writes its partial result.
  std::string partial_result_file(const std::string &directory, const std::string &scenario);

  // Written to a temporary file, then renamed (atomic_file.h).
  void write_partial_result(const std::string &filename, const PartialResult &partial);

  // Throws, naming the file, when it is not a partial result of this format.
  PartialResult read_partial_result(const std::string &filename);

  // CRC-32 of the display surface's vertex coordinates and triangles, as the run read them.
  std::uint32_t display_surface_checksum(const meshing::DisplaySurface &surface);

  // CRC-32 of a file's bytes; throws naming the file when it cannot be read.
  std::uint32_t file_checksum(const std::string &filename);
} // namespace modal_haptics
