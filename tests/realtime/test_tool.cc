// modal-rt on synthetic basis files: info prints the spaces, verify passes on consistent bases
// (float64 and float32 display modes), fails on a basis whose validation responses are off, and a
// corrupt file is reported with its name and a non-zero exit status.
#include "test_support.h"

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <sys/wait.h>

namespace
{
  // Runs modal-rt with `arguments`; returns its exit status and its output (stdout and stderr).
  int run(const std::string &arguments, std::string &output)
  {
    const std::string command = std::string(MODAL_RT_PROGRAM) + " " + arguments + " > modal_rt_output.txt 2>&1";
    const int         status  = std::system(command.c_str());
    std::ifstream     file("modal_rt_output.txt");
    std::stringstream text;
    text << file.rdbuf();
    output = text.str();
    std::remove("modal_rt_output.txt");
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }

  bool contains(const std::string &text, const std::string &part) { return text.find(part) != std::string::npos; }

  void consistent_bases()
  {
    for (bool float64 : {true, false})
      {
        modalrt::LatticeOptions o;
        o.float64_modes = float64;
        o.patch_radius  = 0.03;
        const std::string path = float64 ? "tool_f64.mrt" : "tool_f32.mrt";
        ENSURE(modalrt::write_basis_file(path, modalrt::make_lattice_cantilever(o)));
        std::string out;
        ENSURE(run("info --basis " + path, out) == 0);
        ENSURE(contains(out, "space 1 'tip': r = 16 modes") && contains(out, "frequencies [Hz]"));
        ENSURE(contains(out, "DISPLAY_MODES") && contains(out, float64 ? "float64" : "float32"));
        ENSURE(run("verify --basis " + path, out) == 0);
        ENSURE(contains(out, "PASS"));
        std::printf("%s", out.substr(out.rfind('\n', out.size() - 2) + 1).c_str());
        std::remove(path.c_str());
      }
  }

  void inconsistent_basis()
  {
    modalrt::BasisContent c = modalrt::make_lattice_cantilever();
    c.spaces[1].validation_response[4] *= 1.0 + 1e-6;
    ENSURE(modalrt::write_basis_file("tool_bad_validation.mrt", c));
    std::string out;
    ENSURE(run("verify --basis tool_bad_validation.mrt --quiet", out) == 1);
    ENSURE(contains(out, "FAIL"));
    std::remove("tool_bad_validation.mrt");
  }

  void corrupt_file()
  {
    std::vector<unsigned char> bytes = modalrt::write_basis(modalrt::make_lattice_cantilever());
    bytes[bytes.size() - 1] ^= 0x5A;
    std::FILE *f = std::fopen("tool_corrupt.mrt", "wb");
    std::fwrite(bytes.data(), 1, bytes.size(), f);
    std::fclose(f);
    std::string out;
    ENSURE(run("verify --basis tool_corrupt.mrt", out) == 1);
    ENSURE(contains(out, "tool_corrupt.mrt") && contains(out, "checksum mismatch"));
    std::printf("  %s", out.c_str());
    ENSURE(run("info --basis no_such_file.mrt", out) == 1 && contains(out, "no_such_file.mrt"));
    ENSURE(run("frobnicate", out) == 2);
    std::remove("tool_corrupt.mrt");
  }
} // namespace

int main()
{
  consistent_bases();
  inconsistent_basis();
  corrupt_file();
  return test::finish("test_tool");
}
