// modal-rt: looks into a .mrt basis file, checks the kernel against it, and plays sessions.
//
//   modal-rt info   --basis FILE   header, spaces, modes, frequencies [Hz], candidate counts, the
//                                  felt-stiffness map per space (range, softest spots: stiffness_map.cc),
//                                  the validity map's lowest forces per space, section sizes;
//                                  --candidates adds, last, every space's candidate vertices
//   modal-rt info   --basis A --compare B [--largest N] [--noise PCT]
//                                  where design B's felt-stiffness map differs from design A's, at A's
//                                  display vertices (design_comparison.cc, mrt/map_comparison.h)
//   modal-rt info   --basis FILE --vertex N | --near X,Y,Z
//                                  one display vertex (by index, or the closest to a point [m]): its
//                                  position, normal, region, candidacy and felt stiffness (vertex_info.cc)
//   modal-rt verify --basis FILE   replays the stored full-FE validation cases through the kernel and
//                                  prints the max relative error; exit 1 above the tolerance
//                                  (1e-8 with float64 display modes, 1e-5 with float32)
//   modal-rt run --basis FILE --session SESSION.csv --output-dir DIR ...
//                                  a scripted session through the kernel in real time
//                                  (run_command.cc; realtime/README.md)
//   modal-rt serve --basis FILE --output-dir DIR ...
//                                  the same loop for a device that talks UDP (udp_device.cc)
//   and the commands of the app's extensions (the view: modal-rt view, view/README.md).
// Each command declares its options in one table (mrt/command_line.h); `modal-rt COMMAND --help`
// prints its usage and every option's help, `modal-rt --help` one line per command.
//
// Exit status: 0 success (or --help), 1 bad basis or failed check, 2 bad command line.
#include "design_comparison.h"
#include "stiffness_map.h"
#include "tool_main.h"
#include "vertex_info.h"

#include <modalrt/modalrt.h>
#include <mrt/command_line.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

namespace
{
  using modalrt_tool::ToolExtensions;

  const double two_pi = 6.283185307179586476925;

  struct Basis
  {
    modalrt_basis *handle = nullptr;
    ~Basis() { modalrt_basis_destroy(handle); }
  };

  const char *scalar_name(uint32_t type)
  {
    switch (type)
      {
        case 1: return "u32";
        case 2: return "f32";
        case 3: return "f64";
        case 4: return "u8";
        default: return "?";
      }
  }

  std::string space_text(uint32_t space) { return space == MODALRT_NONE ? std::string("-") : std::to_string(space); }

  void print_header(const modalrt_basis_info &info)
  {
    std::printf("format version  %u.%u\n", info.version_major, info.version_minor);
    std::printf("file size       %llu bytes, %u sections\n", (unsigned long long)info.file_bytes, info.section_count);
    std::printf("display surface %u vertices, %u triangles, bounds [%g %g %g] .. [%g %g %g] m\n",
                info.display_vertex_count, info.display_triangle_count, info.bounds_min[0], info.bounds_min[1],
                info.bounds_min[2], info.bounds_max[0], info.bounds_max[1], info.bounds_max[2]);
    std::printf("capacities      max_modes %u, max_patch_size %u\n", info.max_modes, info.max_patch_size);
    std::printf("display modes   float%u\n", 8 * info.mode_scalar_bytes);
    std::printf("scene           patch radius %g m, mass %g kg, centre of mass [%g %g %g] m\n", info.patch_radius,
                info.mass, info.centre_of_mass[0], info.centre_of_mass[1], info.centre_of_mass[2]);
  }

  void print_space(const modalrt_basis *basis, uint32_t s, uint32_t space_count)
  {
    modalrt_space_info info;
    modalrt_basis_get_space_info(basis, s, &info);
    const std::string far_field = info.far_rank ? "rank " + std::to_string(info.far_rank) : "none";
    std::printf("\nspace %u '%s': r = %u modes, %u candidates, %u validation cases, cross compliance %s, "
                "far field %s, participation %s\n",
                s, info.name, info.mode_count, info.candidate_count, info.validation_count,
                info.cross_count ? "yes" : "no", far_field.c_str(), info.has_participation ? "yes" : "no");
    const double *lambda = modalrt_basis_eigenvalues(basis, s);
    const double *zeta   = modalrt_basis_damping_ratios(basis, s);
    std::printf("  frequencies [Hz] (damping ratio):");
    for (uint32_t i = 0; i < info.mode_count; ++i)
      std::printf("%s%10.4g (%.3g)", i % 6 == 0 ? "\n   " : " ", std::sqrt(lambda[i]) / two_pi, zeta[i]);
    std::printf("\n");
    std::printf("  transfers into it from:");
    bool any = false;
    for (uint32_t j = 0; j < space_count; ++j)
      if (modalrt_basis_has_transfer(basis, s, j))
        {
          std::printf(" %u", j);
          any = true;
        }
    std::printf("%s\n", any ? "" : " none");
  }

  // The corrected contacts' display vertices, 16 a line: hundreds of lines on a real scene, so only
  // with --candidates and after everything else.
  void print_candidates(const modalrt_basis *basis, uint32_t space_count)
  {
    for (uint32_t s = 0; s < space_count; ++s)
      {
        modalrt_space_info info;
        modalrt_basis_get_space_info(basis, s, &info);
        const uint32_t *candidates = modalrt_basis_candidates(basis, s);
        std::printf("\nspace %u '%s': %u candidates (display vertices):", s, info.name, info.candidate_count);
        for (uint32_t k = 0; k < info.candidate_count; ++k)
          std::printf("%s%u", k % 16 == 0 ? "\n   " : " ", candidates[k]);
        std::printf("\n");
      }
  }

  void print_sections(const modalrt_basis *basis, uint32_t count)
  {
    std::printf("\n%-22s %6s %6s %5s %12s %12s %14s\n", "section", "space", "from", "type", "offset", "count", "bytes");
    for (uint32_t k = 0; k < count; ++k)
      {
        modalrt_section_info s;
        modalrt_basis_get_section(basis, k, &s);
        std::printf("%-22s %6s %6s %5s %12llu %12llu %14llu\n", s.name, space_text(s.space).c_str(),
                    space_text(s.source_space).c_str(), scalar_name(s.scalar_type), (unsigned long long)s.offset,
                    (unsigned long long)s.count, (unsigned long long)s.bytes);
      }
  }

  int info(const modalrt_basis *basis, bool with_candidates)
  {
    modalrt_basis_info info;
    modalrt_basis_get_info(basis, &info);
    print_header(info);
    for (uint32_t s = 0; s < info.space_count; ++s)
      print_space(basis, s, info.space_count);
    modalrt_tool::print_felt_stiffness_map(basis);
    modalrt_tool::print_validity_map(basis);
    print_sections(basis, info.section_count);
    if (with_candidates)
      print_candidates(basis, info.space_count);
    return 0;
  }

  int verify(const modalrt_basis *basis, const char *path, bool quiet)
  {
    modalrt_verify_report report;
    const int             status = modalrt_basis_verify(basis, &report);
    if (status != MODALRT_OK && status != MODALRT_ERROR_VERIFY_FAILED)
      {
        std::fprintf(stderr, "modal-rt: %s\n", modalrt_last_error_message());
        return 1;
      }
    if (report.case_count == 0)
      {
        std::fprintf(stderr, "modal-rt: %s holds no validation case: nothing to verify\n", path);
        return 1;
      }
    if (!quiet)
      {
        std::printf("%5s %5s %8s %3s %5s %14s %14s %11s\n", "case", "space", "vertex", "dir", "cand", "|u_kernel|",
                    "|u_fe|", "rel error");
        for (uint32_t k = 0; k < report.case_count; ++k)
          {
            modalrt_verify_case c;
            modalrt_basis_verify_case(basis, k, &c);
            const double uk = std::sqrt(c.kernel[0] * c.kernel[0] + c.kernel[1] * c.kernel[1] + c.kernel[2] * c.kernel[2]);
            const double ur =
              std::sqrt(c.reference[0] * c.reference[0] + c.reference[1] * c.reference[1] + c.reference[2] * c.reference[2]);
            std::printf("%5u %5u %8u %3c %5s %14.6e %14.6e %11.3e\n", k, c.space, c.vertex, "xyz"[c.direction],
                        c.is_candidate ? "yes" : "no", uk, ur, c.relative_error);
          }
      }
    const bool pass = status == MODALRT_OK;
    std::printf("%s: %u validation cases, max relative error %.3e (case %u), tolerance %.0e: %s\n", path,
                report.case_count, report.max_relative_error, report.worst_case, report.tolerance,
                pass ? "PASS" : "FAIL");
    return pass ? 0 : 1;
  }

  // What info and verify were asked.
  struct BasisOptions
  {
    std::string path;
    bool        quiet      = false;
    bool        candidates = false; // info: also list every space's candidate vertices
    std::string vertex;             // --vertex's value as given (checked once the basis is loaded)
    bool        near     = false;
    double      point[3] = {0, 0, 0}; // [m] --near
    std::string compare;              // --compare: design B's basis
    bool        comparison_option = false; // --largest or --noise given
    modalrt_tool::DesignComparisonOptions comparison;
  };

  // --vertex: a display vertex index, checked against the basis. Exit status 2 with a message
  // naming the option and the value when it is not one.
  bool parse_vertex(const std::string &text, const modalrt_basis *basis, uint32_t &vertex)
  {
    modalrt_basis_info info;
    modalrt_basis_get_info(basis, &info);
    char                    *end   = nullptr;
    const unsigned long long value = std::strtoull(text.c_str(), &end, 10);
    if (text.empty() || text[0] < '0' || text[0] > '9' || *end != '\0' || value >= info.display_vertex_count)
      {
        std::fprintf(stderr, "modal-rt info: --vertex '%s': not a display vertex (the basis has %u, 0 .. %u)\n",
                     text.c_str(), info.display_vertex_count, info.display_vertex_count - 1);
        return false;
      }
    vertex = uint32_t(value);
    return true;
  }

  // --near X,Y,Z: three finite numbers [m] separated by commas.
  void parse_point(const std::string &text, double point[3])
  {
    const char *p = text.c_str();
    for (int c = 0; c < 3; ++c)
      {
        char *end = nullptr;
        point[c]  = std::strtod(p, &end);
        if (end == p || !std::isfinite(point[c]) || *end != (c < 2 ? ',' : '\0'))
          throw mrt::cli::UsageError("--near '" + text + "': expected X,Y,Z in metres (three finite numbers)");
        p = end + 1;
      }
  }

  const char *const basis_help = "the basis file (.mrt)";

  mrt::cli::OptionTable info_table(BasisOptions &o)
  {
    mrt::cli::OptionTable t("modal-rt info", "A basis file's header, spaces, modes, frequencies, candidate counts, "
                                             "felt-stiffness and validity maps and sections; one display vertex; "
                                             "or where a second design's felt stiffness differs.");
    t.text("--basis", "FILE.mrt", basis_help, [&o](const std::string &v) { o.path = v; }).required();
    t.flag("--candidates", "also list every space's candidate vertices, last", [&o] { o.candidates = true; });
    t.text("--vertex", "N", "one display vertex by index: position, normal, region, candidacy, felt stiffness",
           [&o](const std::string &v) { o.vertex = v; });
    t.text("--near", "X,Y,Z", "the same for the display vertex closest to a point [m]", [&o](const std::string &v) {
      parse_point(v, o.point);
      o.near = true;
    });
    t.text("--compare", "B.mrt", "where design B's felt-stiffness map differs from this basis's, at its vertices",
           [&o](const std::string &v) { o.compare = v; });
    t.number("--largest", "N", "how many of the largest differences --compare lists", {0, 1000000, "", true},
             [&o](double v) {
               o.comparison.largest = std::size_t(v);
               o.comparison_option  = true;
             })
      .shown_default("10");
    t.number("--noise", "PCT", "--compare's noise floor [%]: a smaller relative difference is none", {0, 1e6, "%"},
             [&o](double v) {
               o.comparison.noise_percent = v;
               o.comparison_option        = true;
             })
      .shown_default("1");
    t.notes("--candidates, --vertex, --near and --compare exclude each other; --largest and --noise go with "
            "--compare\n(design_comparison.cc, mrt/map_comparison.h).");
    return t;
  }

  mrt::cli::OptionTable verify_table(BasisOptions &o)
  {
    mrt::cli::OptionTable t("modal-rt verify",
                            "Replays the stored full-FE validation cases through the kernel and prints the max "
                            "relative error; exit status 1 above the tolerance (1e-8 with float64 display modes, "
                            "1e-5 with float32).");
    t.text("--basis", "FILE.mrt", basis_help, [&o](const std::string &v) { o.path = v; }).required();
    t.flag("--quiet", "only the closing line (PASS or FAIL), no table of cases", [&o] { o.quiet = true; });
    return t;
  }

  // The combinations info refuses; the first one found, "" when they go together.
  std::string conflict(const BasisOptions &o)
  {
    const bool vertex = !o.vertex.empty(), compare = !o.compare.empty();
    if (vertex && o.near)
      return "--vertex and --near pick the same thing: give one";
    if (o.candidates && (vertex || o.near))
      return "--candidates lists the whole basis, --vertex one vertex: give one";
    if (compare && (o.candidates || vertex || o.near))
      return "--compare prints the comparison alone: without --candidates, --vertex or --near";
    if (o.comparison_option && !compare)
      return "--largest and --noise are options of --compare B.mrt";
    return "";
  }

  // info --vertex N / --near X,Y,Z: one display vertex.
  int vertex_info(const modalrt_basis *basis, const BasisOptions &o)
  {
    uint32_t vertex = 0;
    if (o.near)
      {
        double distance = 0.0;
        vertex          = modalrt_tool::nearest_vertex(basis, o.point, distance);
        std::printf("nearest display vertex to [%.9g %.9g %.9g] m: %u, at %.6g m (%.6g mm)\n", o.point[0],
                    o.point[1], o.point[2], vertex, distance, 1e3 * distance);
      }
    else if (!parse_vertex(o.vertex, basis, vertex))
      return 2;
    modalrt_tool::print_vertex(basis, vertex);
    return 0;
  }

  // info or verify.
  int basis_command(const std::string &command, int argc, char **argv)
  {
    BasisOptions                o;
    const mrt::cli::OptionTable table = command == "info" ? info_table(o) : verify_table(o);
    if (const int status = mrt::cli::parse_command_line(table, argc, argv); status >= 0)
      return status;
    if (const std::string problem = conflict(o); !problem.empty())
      return mrt::cli::report_usage_error(table, problem);
    Basis basis;
    if (modalrt_basis_load(o.path.c_str(), &basis.handle) != MODALRT_OK)
      {
        std::fprintf(stderr, "modal-rt: bad basis file '%s': %s\n", o.path.c_str(), modalrt_last_error_message());
        return 1;
      }
    if (!o.vertex.empty() || o.near)
      return vertex_info(basis.handle, o);
    if (!o.compare.empty())
      return modalrt_tool::compare_designs(basis.handle, o.path.c_str(), o.compare.c_str(), o.comparison);
    return command == "info" ? info(basis.handle, o.candidates) : verify(basis.handle, o.path.c_str(), o.quiet);
  }

  // modal-rt --help: every command with its one line.
  int overview(const ToolExtensions &extensions, bool help)
  {
    BasisOptions unused;
    std::vector<std::pair<std::string, std::string>> commands = {
      {"info", info_table(unused).summary()},   {"verify", verify_table(unused).summary()},
      {"run", modalrt_tool::run_summary(false)}, {"serve", modalrt_tool::run_summary(true)}};
    for (const modalrt_tool::Command &command : extensions.commands)
      commands.emplace_back(command.name, command.summary);
    if (extensions.commands.empty())
      commands.emplace_back("view", "not in this build (view/README.md)");
    std::string text = "usage: modal-rt COMMAND [OPTIONS]\n\ncommands:\n";
    for (const auto &[name, summary] : commands)
      text += "  " + name + std::string(8 - name.size(), ' ') + summary.substr(0, summary.find(". ")) + "\n";
    text += "\nmodal-rt COMMAND --help: that command's usage and what each option does.\n"
            "Exit status: 0 success (or --help), 1 bad basis or failed check, 2 bad command line.\n";
    std::fputs(text.c_str(), help ? stdout : stderr);
    return help ? 0 : 2;
  }
} // namespace

int modalrt_tool::tool_main(int argc, char **argv, const ToolExtensions &extensions)
{
  if (argc < 2)
    return overview(extensions, false);
  const std::string command = argv[1];
  if (command == "--help" || command == "-h" || command == "help")
    return overview(extensions, true);
  if (command == "info" || command == "verify")
    return basis_command(command, argc - 2, argv + 2);
  if (command == "run" || command == "serve")
    return run_command(argc - 2, argv + 2, command == "serve", extensions.watch);
  for (const Command &extension : extensions.commands)
    if (command == extension.name)
      return extension.run(argc - 2, argv + 2);
  if (command == "view")
    {
      std::fprintf(stderr, "modal-rt view: %s\n", built_without_view);
      return 1;
    }
  std::fprintf(stderr, "modal-rt: unknown command '%s'\n", command.c_str());
  return overview(extensions, false);
}
