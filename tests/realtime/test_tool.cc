// modal-rt on synthetic basis files: info prints the spaces (the candidate vertices only with
// --candidates, last), verify passes on consistent bases
// (float64 and float32 display modes), fails on a basis whose validation responses are off, and a
// corrupt file is reported with its name and a non-zero exit status. info --vertex / --near: a
// vertex's felt stiffness equals 1 / (n^T (B Lambda^-1 B^T + C) n) from the basis content at a
// candidate and says "modal only" elsewhere; --near finds the vertex at a point; bad values are named.
// The far field (FAR_COMPLIANCE): info prints its rank per space.
// The validity map (VALIDITY_FORCE): info lists its lowest forces per space, --vertex the three forces.
// The felt-stiffness map (FELT_STIFFNESS): info prints per space its range over the space's region and
// its 5 softest spots, the numbers of the map written; --vertex prints the scene's map at the vertex,
// which at a candidate equals the full-FE felt stiffness from B, Lambda and C.
#include "tool_runner.h"

#include <mrt/surface_normals.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>

namespace
{
  int run(const std::string &arguments, std::string &output) { return test::modal_rt(arguments, output); }

  using test::contains;

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
        // The candidate vertices (hundreds of lines on a real scene) only with --candidates, after the
        // section table; the summary keeps their count.
        ENSURE(contains(out, " candidates, ") && !contains(out, "candidates (display vertices):"));
        ENSURE(run("info --basis " + path + " --candidates", out) == 0);
        ENSURE(out.find("candidates (display vertices):") > out.find("DISPLAY_MODES"));
        ENSURE(run("info --basis " + path + " --candidates --vertex 3", out) == 2 && contains(out, "give one"));
        ENSURE(run("verify --basis " + path, out) == 0);
        ENSURE(contains(out, "PASS"));
        std::printf("%s", out.substr(out.rfind('\n', out.size() - 2) + 1).c_str());
        std::remove(path.c_str());
      }
  }

  // info prints each space's far-field rank (.mrt 1.3), "none" without one; verify passes on it.
  void far_field_info()
  {
    modalrt::LatticeOptions o;
    o.far_rank = 4;
    ENSURE(modalrt::write_basis_file("tool_far.mrt", modalrt::make_lattice_cantilever(o)));
    ENSURE(modalrt::write_basis_file("tool_no_far.mrt", modalrt::make_lattice_cantilever()));
    std::string out;
    ENSURE(run("info --basis tool_far.mrt", out) == 0);
    ENSURE(contains(out, "space 0 'global': r = 8 modes") && contains(out, "far field rank 4, "));
    ENSURE(contains(out, "format version  1.3"));
    ENSURE(run("verify --basis tool_far.mrt", out) == 0 && contains(out, "PASS"));
    ENSURE(run("info --basis tool_no_far.mrt", out) == 0 && contains(out, "far field none, "));
    ENSURE(!contains(out, "far field rank"));
    std::remove("tool_far.mrt");
    std::remove("tool_no_far.mrt");
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
  // The number after "at the contact in <label>: " in info --vertex's output (N/mm); NaN if absent.
  double felt_n_per_mm(const std::string &out, const std::string &label)
  {
    const std::string key = "at the contact in " + label + ": ";
    const std::size_t at  = out.find(key);
    return at == std::string::npos ? std::nan("") : std::atof(out.c_str() + at + key.size());
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

  // The lattice's tip vertex (8, 1): in the tip VOI, a candidate of space 1 (its index there in `k`).
  std::uint32_t tip_candidate(const modalrt::LatticeOptions &o, const modalrt::BasisContent &c, std::size_t &k)
  {
    const std::uint32_t v  = modalrt::lattice_display_vertex(o, 8, 1);
    const auto         &c1 = c.spaces[1].candidates;
    k                      = std::find(c1.begin(), c1.end(), v) - c1.begin();
    ENSURE(c.region[v] == 1 && k < c1.size());
    return v;
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
    std::size_t         k = 0;
    const std::uint32_t v = tip_candidate(o, c, k);
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

  // The number after `key` in `out` (NaN if absent), from position `from` on.
  double number_after(const std::string &out, const std::string &key, std::size_t from = 0)
  {
    const std::size_t at = out.find(key, from);
    return at == std::string::npos ? std::nan("") : std::atof(out.c_str() + at + key.size());
  }

  void felt_stiffness_map()
  {
    modalrt::LatticeOptions o;
    o.patch_radius                = 0.03;
    o.felt_stiffness              = true;
    const modalrt::BasisContent c = modalrt::make_lattice_cantilever(o);
    ENSURE(modalrt::write_basis_file("tool_map.mrt", c));
    std::string out;
    ENSURE(run("info --basis tool_map.mrt", out) == 0);
    std::printf("%s", out.substr(out.find("felt-stiffness map"), out.find("\nsection") - out.find("felt-stiffness map")).c_str());
    for (std::uint32_t s = 0; s < c.spaces.size(); ++s)
      {
        // What the file holds over the space's region: the computed values, softest first.
        std::vector<std::pair<double, std::uint32_t>> values;
        std::uint32_t                                 region_size = 0;
        for (std::uint32_t v = 0; v < c.vertex_count(); ++v)
          if (c.region[v] == s)
            {
              ++region_size;
              if (c.spaces[s].felt_stiffness[v] > 0.0)
                values.emplace_back(1e-3 * c.spaces[s].felt_stiffness[v], v);
            }
        std::sort(values.begin(), values.end());
        const std::size_t n = values.size();
        ENSURE(n >= 5 && (s == 0 ? n < region_size : n == region_size)); // the clamped vertices (x = 0): none
        const std::string line = "space " + std::to_string(s) + " '" + c.spaces[s].name + "': " + std::to_string(n) +
                                 " of its region's " + std::to_string(region_size) + " vertices: ";
        const std::size_t at = out.find(line);
        ENSURE(at != std::string::npos);
        const double median = n % 2 ? values[n / 2].first : 0.5 * (values[n / 2 - 1].first + values[n / 2].first);
        ENSURE_NEAR(number_after(out, "min ", at) / values.front().first, 1.0, 1e-5);
        ENSURE_NEAR(number_after(out, "median ", at) / median, 1.0, 1e-5);
        ENSURE_NEAR(number_after(out, "max ", at) / values.back().first, 1.0, 1e-5);
        for (std::size_t k = 0; k < 5; ++k)
          {
            const std::uint32_t v    = values[k].second;
            const std::string   spot = "softest " + std::to_string(k + 1) + ": vertex " + std::to_string(v) + " at (";
            const std::size_t   p    = out.find(spot, at);
            ENSURE(p != std::string::npos);
            ENSURE_NEAR(std::atof(out.c_str() + p + spot.size()), 1e3 * c.vertices[3 * v], 1e-3);
            ENSURE_NEAR(number_after(out, "mm: ", p) / values[k].first, 1.0, 1e-5);
          }
      }

    ENSURE(!contains(out, "softest 6:"));

    // --vertex: the scene's map at a tip candidate is its full-FE felt stiffness (along the contract's
    // normal); a clamped vertex has none.
    std::size_t         k = 0;
    const std::uint32_t v = tip_candidate(o, c, k);
    std::vector<double> normals(c.vertices.size());
    mrt::area_weighted_normals(c.vertices.data(), c.vertex_count(), c.triangles.data(), c.triangles.size() / 3,
                               normals.data());
    ENSURE(run("info --basis tool_map.mrt --vertex " + std::to_string(v), out) == 0);
    const double expected = expected_n_per_mm(c, 1, k, normals.data() + 3 * v);
    const double printed  = number_after(out, "felt-stiffness map: ");
    ENSURE_NEAR(printed / expected, 1.0, 1e-9);
    ENSURE(contains(out, "N/mm (its region's space 1, full FE)"));
    std::printf("map at vertex %u: printed %.12g N/mm, full FE from the file's B, Lambda, C %.12g N/mm\n", v, printed,
                expected);
    ENSURE(run("info --basis tool_map.mrt --vertex " + std::to_string(modalrt::lattice_display_vertex(o, 0, 1)), out) == 0);
    ENSURE(contains(out, "felt-stiffness map: not computed here (0 in its region's space 0)"));

    // A file without a map says so.
    o.felt_stiffness = false;
    ENSURE(modalrt::write_basis_file("tool_map.mrt", modalrt::make_lattice_cantilever(o)));
    ENSURE(run("info --basis tool_map.mrt", out) == 0 && contains(out, "felt-stiffness map: none in this file"));
    ENSURE(run("info --basis tool_map.mrt --vertex 3", out) == 0 && contains(out, "felt-stiffness map: none in this file"));
    std::remove("tool_map.mrt");
  }

  // The validity map (VALIDITY_FORCE): info lists per space how many vertices of its region have an F5
  // and the 5 lowest with F1, F5, F10 ("not reached" for 1e30); --vertex the three at a vertex.
  void validity_map()
  {
    modalrt::LatticeOptions o;
    o.validity_force              = true;
    const modalrt::BasisContent c = modalrt::make_lattice_cantilever(o);
    ENSURE(modalrt::write_basis_file("tool_validity.mrt", c));
    std::string out;
    ENSURE(run("info --basis tool_validity.mrt", out) == 0);
    const std::size_t at = out.find("validity map (VALIDITY_FORCE");
    ENSURE(at != std::string::npos);
    if (at == std::string::npos)
      return;
    std::printf("%s", out.substr(at, out.find("\nsection") - at).c_str());
    // Space 1 'tip' (x >= 0.12 m): its lowest F5 at x = 0.125 m, F_p = p 0.2 N (1 + x / 0.2 m).
    ENSURE(contains(out, "space 1 'tip': F5 at 12 of its region's 12 vertices"));
    ENSURE(contains(out, "lowest 1: vertex 5 at (125.000, 0.000, 10.000) mm: F1 0.325 N, F5 1.625 N, F10 3.25 N"));
    ENSURE(contains(out, "space 0 'global': F5 at 12 of its region's 15 vertices")); // none on the clamped column
    ENSURE(!contains(out, "lowest 6:"));
    ENSURE(run("info --basis tool_validity.mrt --vertex 17", out) == 0);
    ENSURE(contains(out, "validity map: F1 0.4 N, F5 2 N, F10 not reached (its region's space 1"));
    ENSURE(run("info --basis tool_validity.mrt --vertex 0", out) == 0);
    ENSURE(contains(out, "validity map: F1 -, F5 -, F10 - (its region's space 0"));
    o.validity_force = false;
    ENSURE(modalrt::write_basis_file("tool_validity.mrt", modalrt::make_lattice_cantilever(o)));
    ENSURE(run("info --basis tool_validity.mrt", out) == 0 && contains(out, "validity map: none in this file"));
    ENSURE(run("info --basis tool_validity.mrt --vertex 3", out) == 0 && contains(out, "validity map: none in its region's space 0"));
    std::remove("tool_validity.mrt");
  }

  // Every command's --help lists every option of its table with a line of help; an unknown option
  // and a bad number are refused with exit status 2, the option and the value named.
  void command_lines()
  {
    const struct
    {
      const char                         *command;
      std::initializer_list<const char *> options;
      const char                         *number_option;
    } commands[] = {
      {"info", {"--basis", "--candidates", "--vertex", "--near", "--compare", "--largest", "--noise"}, "--largest"},
      {"verify", {"--basis", "--quiet"}, nullptr},
      {"run", {"--basis", "--session", "--output-dir", "--rate", "--duration", "--mode", "--device", "--profile",
               "--haptic-scale", "--hold", "--ramp", "--snap-distance", "--spin-us", "--validity-level",
               "--validity-clamp", "--design-b", "--fade", "--blind", "--frame-rate", "--trace-rate", "--view",
               "--no-plot", "--quiet"}, "--rate"},
      {"serve", {"--basis", "--output-dir", "--bind", "--port", "--hips", "--peer-timeout", "--token", "--token-file",
                 "--contact", "--friction", "--rate", "--duration", "--mode", "--profile", "--hold", "--ramp",
                 "--validity-level", "--validity-clamp", "--design-b", "--fade", "--frame-rate", "--view"}, "--port"},
    };
    std::string out;
    for (const auto &c : commands)
      {
        ENSURE(run(std::string(c.command) + " --help", out) == 0 && contains(out, "usage: modal-rt " + std::string(c.command)));
        for (const char *option : c.options)
          ENSURE(contains(out, std::string("\n  ") + option + " "));
        ENSURE(run(std::string(c.command) + " --basis x.mrt --frobnicate", out) == 2 &&
               contains(out, "unknown option '--frobnicate'"));
        if (c.number_option)
          ENSURE(run(std::string(c.command) + " --basis x.mrt " + c.number_option + " 1x", out) == 2 &&
                 contains(out, std::string(c.number_option) + " '1x' is not a number"));
      }
    ENSURE(run("--help", out) == 0 && contains(out, "info") && contains(out, "serve") && contains(out, "view"));
  }
} // namespace

int main()
{
  command_lines();
  consistent_bases();
  far_field_info();
  inconsistent_basis();
  corrupt_file();
  vertex_info();
  felt_stiffness_map();
  validity_map();
  return test::finish("test_tool");
}
