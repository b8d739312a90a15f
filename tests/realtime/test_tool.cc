// modal-rt on synthetic basis files: info prints the spaces, verify passes on consistent bases
// (float64 and float32 display modes), fails on a basis whose validation responses are off, and a
// corrupt file is reported with its name and a non-zero exit status. info --vertex / --near: a
// vertex's felt stiffness equals 1 / (n^T (B Lambda^-1 B^T + C) n) from the basis content at a
// candidate and says "modal only" elsewhere; --near finds the vertex at a point; bad values are named.
#include "test_support.h"

#include <algorithm>
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
  // The number after "felt in <label>: " in info --vertex's output (N/mm); NaN if absent.
  double felt_n_per_mm(const std::string &out, const std::string &label)
  {
    const std::size_t at = out.find("felt in " + label + ": ");
    return at == std::string::npos ? std::nan("") : std::atof(out.c_str() + at + label.size() + 10);
  }

  // 1e-3 / (n^T (B Lambda^-1 B^T + C) n) of candidate k of space s, from the content written.
  double expected_n_per_mm(const modalrt::BasisContent &c, std::uint32_t s, std::size_t k, const double *n)
  {
    const auto         &space = c.spaces[s];
    const std::size_t   r     = space.eigenvalues.size();
    const double       *B     = &space.candidate_modes[3 * r * k];
    double              compliance = 0.0;
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b)
        {
          double g = space.candidate_compliance[9 * k + 3 * a + b];
          for (std::size_t i = 0; i < r; ++i)
            g += B[a * r + i] * B[b * r + i] / space.eigenvalues[i];
          compliance += n[a] * g * n[b];
        }
    return 1e-3 / compliance;
  }

  void vertex_info()
  {
    modalrt::LatticeOptions o;
    o.patch_radius                = 0.03;
    const modalrt::BasisContent c = modalrt::make_lattice_cantilever(o);
    ENSURE(modalrt::write_basis_file("tool_vertex.mrt", c));
    const std::vector<unsigned char> bytes = modalrt::write_basis(c);
    modalrt_basis                   *basis = nullptr;
    ENSURE(modalrt_basis_load_memory(bytes.data(), bytes.size(), &basis) == MODALRT_OK);
    // A tip vertex: in the tip VOI, a candidate of space 1, not of space 0.
    const std::uint32_t v  = modalrt::lattice_display_vertex(o, 8, 1);
    const auto         &c1 = c.spaces[1].candidates;
    const std::size_t   k  = std::find(c1.begin(), c1.end(), v) - c1.begin();
    ENSURE(c.region[v] == 1 && k < c1.size());
    ENSURE(std::count(c.spaces[0].candidates.begin(), c.spaces[0].candidates.end(), v) == 0);
    std::string out;
    ENSURE(run("info --basis tool_vertex.mrt --vertex " + std::to_string(v), out) == 0);
    std::printf("%s", out.c_str());
    const double expected = expected_n_per_mm(c, 1, k, modalrt_basis_display_normals(basis) + 3 * v);
    ENSURE_NEAR(felt_n_per_mm(out, "space 1 'tip'") / expected, 1.0, 1e-9);
    std::printf("felt at candidate %u: printed %.12g N/mm, from the file's B, Lambda, C %.12g N/mm (%.1e relative)\n",
                v, felt_n_per_mm(out, "space 1 'tip'"), expected, felt_n_per_mm(out, "space 1 'tip'") / expected - 1.0);
    ENSURE(contains(out, "(corrected: equals full FE)  <- its region"));
    ENSURE(contains(out, "region    space 1 'tip'") && contains(out, "candidate) of: space 1 'tip'\n"));
    ENSURE(felt_n_per_mm(out, "space 0 'global'") > 0.0 && contains(out, "(modal only: not a corrected contact)"));
    // --near: 0.2 mm off another vertex finds it.
    const std::uint32_t w = modalrt::lattice_display_vertex(o, 3, 2);
    const double       *x = &c.vertices[3 * w];
    char                point[128];
    std::snprintf(point, sizeof point, "%.17g,%.17g,%.17g", x[0], x[1], x[2] + 2e-4);
    ENSURE(run(std::string("info --basis tool_vertex.mrt --near ") + point, out) == 0);
    ENSURE(contains(out, ": " + std::to_string(w) + ", at 0.0002 m (0.2 mm)"));
    ENSURE(contains(out, "vertex " + std::to_string(w) + " of "));
    // Bad values: named, exit status 2.
    ENSURE(run("info --basis tool_vertex.mrt --vertex 99999", out) == 2 && contains(out, "--vertex '99999'"));
    std::printf("  %s", out.c_str());
    ENSURE(run("info --basis tool_vertex.mrt --vertex 3x", out) == 2 && contains(out, "--vertex '3x'"));
    ENSURE(run("info --basis tool_vertex.mrt --near 0.1,0.2", out) == 2 && contains(out, "--near '0.1,0.2'"));
    std::printf("  %s", out.c_str());
    ENSURE(run("info --basis tool_vertex.mrt --near 0.1,nan,0", out) == 2 && contains(out, "--near '0.1,nan,0'"));
    ENSURE(run("info --basis tool_vertex.mrt --vertex 1 --near 0,0,0", out) == 2 && contains(out, "give one"));
    ENSURE(run("verify --basis tool_vertex.mrt --vertex 1", out) == 2);
    modalrt_basis_destroy(basis);
    std::remove("tool_vertex.mrt");
  }
} // namespace

int main()
{
  consistent_bases();
  inconsistent_basis();
  corrupt_file();
  vertex_info();
  return test::finish("test_tool");
}
