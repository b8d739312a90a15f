// modal-rt info --basis A --compare B on synthetic lattice bases with felt-stiffness maps:
//   - a basis against itself: the identity rule, every ratio 1, nothing beyond the noise floor;
//   - B's maps 1.3 times A's: +30.000 % in every listed line, A and B there as the files hold them;
//     --largest N lists N; a 0.5 % difference is within the default floor (1 %), beyond --noise 0.1;
//   - a lattice with another vertex count (another triangulation of the same top face) and a map
//     linear in position, 1.3 times A's: the closest-point rule reproduces +30.000 % everywhere;
//   - the same surface moved 0.5 mm along its normal: matched at 0.5 mm, every ratio 1;
//   - refused with exit status 1 and the file's name: a file without a map (as A or as B), a file
//     that does not exist or is corrupt; bad option values and combinations exit 2.
#include "tool_runner.h"

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>

namespace
{
  int run(const std::string &arguments, std::string &output) { return test::modal_rt(arguments, output); }

  using test::contains;

  // The number right after the first `label` in `text` (from `from`); NaN if absent.
  double number_after(const std::string &text, const std::string &label, std::size_t from = 0)
  {
    const std::size_t at = text.find(label, from);
    return at == std::string::npos ? std::nan("") : std::atof(text.c_str() + at + label.size());
  }

  modalrt::LatticeOptions lattice(std::uint32_t nx = 9)
  {
    modalrt::LatticeOptions o;
    o.nx             = nx;
    o.patch_radius   = 0.03;
    o.felt_stiffness = true;
    return o;
  }

  // The scene's map of the content: each vertex from its region's space [N/m].
  double scene_value(const modalrt::BasisContent &c, std::uint32_t v) { return c.spaces[c.region[v]].felt_stiffness[v]; }

  std::size_t vertices_with_value(const modalrt::BasisContent &c)
  {
    std::size_t n = 0;
    for (std::uint32_t v = 0; v < c.vertex_count(); ++v)
      n += scene_value(c, v) > 0.0;
    return n;
  }

  modalrt::BasisContent scaled(modalrt::BasisContent c, double factor)
  {
    for (auto &space : c.spaces)
      for (double &k : space.felt_stiffness)
        k *= factor;
    return c;
  }

  // The lines of the largest differences: "      k   vertex  (x, y, z) ..." after the header.
  std::vector<std::string> largest_lines(const std::string &out)
  {
    std::vector<std::string> lines;
    std::istringstream       in(out.substr(out.find("match [mm]") + 1));
    std::string              line;
    std::getline(in, line);
    while (std::getline(in, line))
      lines.push_back(line);
    return lines;
  }

  void every_ratio(const std::string &out, const std::string &ratio)
  {
    ENSURE(contains(out, "ratio B/A       min " + ratio + " / median " + ratio + " / max " + ratio));
  }

  void same_basis()
  {
    const modalrt::BasisContent a = modalrt::make_lattice_cantilever(lattice());
    ENSURE(modalrt::write_basis_file("compare_a.mrt", a));
    std::string out;
    ENSURE(run("info --basis compare_a.mrt --compare compare_a.mrt", out) == 0);
    std::printf("%s", out.c_str());
    const std::size_t n = vertices_with_value(a);
    ENSURE(n > 10 && n < a.vertex_count()); // the clamped column has none
    ENSURE(contains(out, "rule            identity"));
    ENSURE(contains(out, "match distance  max 0 mm, 95th percentile 0 mm"));
    ENSURE(contains(out, "compared        " + std::to_string(n) + " of A's " + std::to_string(a.vertex_count())));
    every_ratio(out, "1.000000");
    ENSURE(contains(out, "beyond noise    0 of " + std::to_string(n)));
    for (const std::string &line : largest_lines(out))
      ENSURE(contains(line, " +0.000 "));
  }

  void scaled_basis()
  {
    const modalrt::BasisContent a = modalrt::make_lattice_cantilever(lattice());
    ENSURE(modalrt::write_basis_file("compare_b.mrt", scaled(a, 1.3)));
    std::string out;
    ENSURE(run("info --basis compare_a.mrt --compare compare_b.mrt", out) == 0);
    std::printf("%s", out.c_str());
    const std::size_t n = vertices_with_value(a);
    ENSURE(contains(out, "rule            identity"));
    every_ratio(out, "1.300000");
    ENSURE(contains(out, "beyond noise    " + std::to_string(n) + " of " + std::to_string(n)));
    const std::vector<std::string> lines = largest_lines(out);
    ENSURE(lines.size() == 10);
    for (const std::string &line : lines)
      {
        ENSURE(contains(line, " +30.000 "));
        // "  k  vertex  (x, y, z)  'region'  A  B  B-A  %  match": A and B as the files hold them [N/mm].
        std::istringstream words(line);
        std::size_t        k;
        std::uint32_t      v;
        words >> k >> v;
        const std::string rest = line.substr(line.find("' ") + 2);
        std::istringstream values(rest);
        double             ka, kb;
        values >> ka >> kb;
        ENSURE(v < a.vertex_count());
        ENSURE_RELATIVE(ka, 1e-3 * scene_value(a, v), 1e-5);
        ENSURE_RELATIVE(kb, 1.3e-3 * scene_value(a, v), 1e-5);
        const double *x = &a.vertices[3 * v];
        char          position[80];
        std::snprintf(position, sizeof position, "(%.3f, %.3f, %.3f)", 1e3 * x[0], 1e3 * x[1], 1e3 * x[2]);
        ENSURE(contains(line, position));
      }
    ENSURE(run("info --basis compare_a.mrt --compare compare_b.mrt --largest 3", out) == 0);
    ENSURE(largest_lines(out).size() == 3);
    ENSURE(run("info --basis compare_a.mrt --compare compare_b.mrt --largest 0", out) == 0);
    ENSURE(!contains(out, "largest differences"));

    // 0.5 %: no difference under the default floor of 1 %, a difference beyond a floor of 0.1 %.
    ENSURE(modalrt::write_basis_file("compare_b.mrt", scaled(a, 1.005)));
    ENSURE(run("info --basis compare_a.mrt --compare compare_b.mrt", out) == 0);
    ENSURE(contains(out, "beyond noise    0 of " + std::to_string(n) + " vertices differ by more than 1 %"));
    ENSURE(run("info --basis compare_a.mrt --compare compare_b.mrt --noise 0.1", out) == 0);
    ENSURE(contains(out, "beyond noise    " + std::to_string(n) + " of " + std::to_string(n) +
                           " vertices differ by more than 0.1 %"));
  }

  // k = 1e3 (20 + 100 x + 60 y) N/m in every space, 0 in A's clamped column (x = 0): linear in
  // position, so barycentric blending on the shared planar top face reproduces it.
  modalrt::BasisContent with_linear_map(modalrt::BasisContent c, double factor, bool clamped_without_value)
  {
    for (auto &space : c.spaces)
      for (std::uint32_t v = 0; v < c.vertex_count(); ++v)
        {
          const double *x           = &c.vertices[3 * v];
          space.felt_stiffness[v] = clamped_without_value && x[0] == 0.0 ? 0.0 : factor * 1e3 * (20 + 100 * x[0] + 60 * x[1]);
        }
    return c;
  }

  void retriangulated_basis()
  {
    const modalrt::BasisContent a = with_linear_map(modalrt::make_lattice_cantilever(lattice(9)), 1.0, true);
    const modalrt::BasisContent b = with_linear_map(modalrt::make_lattice_cantilever(lattice(13)), 1.3, false);
    ENSURE(a.vertex_count() == 27 && b.vertex_count() == 39);
    ENSURE(modalrt::write_basis_file("compare_a_linear.mrt", a));
    ENSURE(modalrt::write_basis_file("compare_b.mrt", b));
    std::string out;
    ENSURE(run("info --basis compare_a_linear.mrt --compare compare_b.mrt --largest 30", out) == 0);
    std::printf("%s", out.c_str());
    ENSURE(contains(out, "rule            closest point: the surfaces differ (27 and 39 vertices)"));
    ENSURE(number_after(out, "match distance  max ") < 1e-9); // [mm]: the same plane
    ENSURE(contains(out, "compared        24 of A's 27 vertices (3 without a value in A, 0 without one in B"));
    every_ratio(out, "1.300000");
    const std::vector<std::string> lines = largest_lines(out);
    ENSURE(lines.size() == 24);
    for (const std::string &line : lines)
      ENSURE(contains(line, " +30.000 "));
  }

  void shifted_basis()
  {
    const modalrt::BasisContent a = modalrt::make_lattice_cantilever(lattice());
    modalrt::BasisContent       b = a;
    for (std::uint32_t v = 0; v < b.vertex_count(); ++v)
      b.vertices[3 * v + 2] += 0.0005;
    ENSURE(modalrt::write_basis_file("compare_b.mrt", b));
    std::string out;
    ENSURE(run("info --basis compare_a.mrt --compare compare_b.mrt", out) == 0);
    ENSURE(contains(out, "rule            closest point: the surfaces differ (27 and 27 vertices)"));
    ENSURE_NEAR(number_after(out, "match distance  max "), 0.5, 1e-9);
    ENSURE_NEAR(number_after(out, "95th percentile "), 0.5, 1e-9);
    every_ratio(out, "1.000000");
    ENSURE(contains(out, "beyond noise    0 of"));
  }

  void refused_files()
  {
    modalrt::LatticeOptions o = lattice();
    o.felt_stiffness          = false;
    ENSURE(modalrt::write_basis_file("compare_no_map.mrt", modalrt::make_lattice_cantilever(o)));
    std::string out;
    ENSURE(run("info --basis compare_a.mrt --compare compare_no_map.mrt", out) == 1);
    ENSURE(contains(out, "'compare_no_map.mrt' has no felt-stiffness map"));
    std::printf("  %s", out.c_str());
    ENSURE(run("info --basis compare_no_map.mrt --compare compare_a.mrt", out) == 1);
    ENSURE(contains(out, "'compare_no_map.mrt' has no felt-stiffness map"));
    ENSURE(run("info --basis compare_a.mrt --compare no_such_design.mrt", out) == 1);
    ENSURE(contains(out, "bad basis file 'no_such_design.mrt'"));
    std::printf("  %s", out.c_str());

    std::vector<unsigned char> bytes = modalrt::write_basis(modalrt::make_lattice_cantilever(lattice()));
    bytes[bytes.size() - 1] ^= 0x5A;
    std::FILE *f = std::fopen("compare_corrupt.mrt", "wb");
    std::fwrite(bytes.data(), 1, bytes.size(), f);
    std::fclose(f);
    ENSURE(run("info --basis compare_a.mrt --compare compare_corrupt.mrt", out) == 1);
    ENSURE(contains(out, "bad basis file 'compare_corrupt.mrt'") && contains(out, "checksum mismatch"));

    // The command line.
    ENSURE(run("info --basis compare_a.mrt --compare compare_a.mrt --largest x", out) == 2 && contains(out, "--largest 'x'"));
    ENSURE(run("info --basis compare_a.mrt --compare compare_a.mrt --noise -1", out) == 2 && contains(out, "--noise '-1'"));
    ENSURE(run("info --basis compare_a.mrt --compare compare_a.mrt --noise nan", out) == 2);
    ENSURE(run("info --basis compare_a.mrt --largest 3", out) == 2 && contains(out, "options of --compare"));
    ENSURE(run("info --basis compare_a.mrt --compare compare_a.mrt --vertex 3", out) == 2);
    ENSURE(run("verify --basis compare_a.mrt --compare compare_a.mrt", out) == 2);
    ENSURE(run("info --help", out) == 0 && contains(out, "--compare B.mrt"));
    for (const char *path : {"compare_no_map.mrt", "compare_corrupt.mrt", "compare_a.mrt", "compare_a_linear.mrt",
                             "compare_b.mrt"})
      std::remove(path);
  }
} // namespace

int main()
{
  same_basis();
  scaled_basis();
  retriangulated_basis();
  shifted_basis();
  refused_files();
  return test::finish("test_design_compare");
}
