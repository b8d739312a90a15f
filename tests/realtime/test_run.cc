// modal-rt run end to end on a synthetic basis (the lattice cantilever, damped enough to settle in
// a fraction of a second): a two-HIP impedance session with switches and a carried part at 1 and
// 4 kHz, the static response of an admittance press, a clean stop on SIGINT, and one clear message
// and a non-zero exit for each bad command line and bad session file. Everything is asserted from
// the files the run writes; nothing is asserted on timing (the machine may be loaded).
#include "tool_runner.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <csignal>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fcntl.h>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>
#include <vector>

namespace
{
  const std::string basis_path = "run_lattice.mrt";

  using test::json_number;
  using test::read_text;

  void write_text(const std::string &path, const std::string &text) { std::ofstream(path) << text; }

  using test::column;
  using test::contains;
  using test::read_csv;

  // Runs `modal-rt run` with `arguments`.
  int run(const std::string &arguments, std::string &output) { return test::modal_rt("run " + arguments, output); }
  int tool(const std::string &arguments, std::string &output) { return test::modal_rt(arguments, output); }

  // The value of attribute `name` in `text` after `from` ("" where there is none before `to`).
  std::string attribute(const std::string &text, const std::string &name, std::size_t from, std::size_t to)
  {
    const std::size_t at = text.find(" " + name + "=\"", from);
    if (at == std::string::npos || at >= to)
      return "";
    const std::size_t start = at + name.size() + 3;
    return text.substr(start, text.find('"', start) - start);
  }

  // A VTU frame as ParaView reads its appended raw block (format="appended", encoding="raw",
  // header_type="UInt64"): after the '_', each DataArray's offset, in the XML's order, points at its
  // UInt64 byte count; each count is what the piece's sizes make of the array's type and components
  // (triangles: connectivity 3 per cell); the counts chain to the block's end, then the closing tags.
  bool appended_frame_is_whole(const std::string &vtu)
  {
    const std::size_t block = vtu.find("<AppendedData encoding=\"raw\">");
    const std::size_t data  = vtu.find('_', block) + 1;
    if (block == std::string::npos || !contains(vtu.substr(0, block), "header_type=\"UInt64\""))
      return false;
    const std::uint64_t points = std::stoull(attribute(vtu, "NumberOfPoints", 0, block));
    const std::uint64_t cells  = std::stoull(attribute(vtu, "NumberOfCells", 0, block));
    std::uint64_t       end    = 0;
    for (std::size_t at = vtu.find("<DataArray"); at < block; at = vtu.find("<DataArray", at + 1))
      {
        const std::size_t   tag_end    = vtu.find("/>", at);
        const std::string   type       = attribute(vtu, "type", at, tag_end);
        const std::string   name       = attribute(vtu, "Name", at, tag_end);
        const std::uint64_t components = std::stoull(attribute(vtu, "NumberOfComponents", at, tag_end));
        const std::uint64_t per_value  = type == "UInt8" ? 1 : 4;
        const std::uint64_t values     = name == "connectivity" ? 3 * cells : name == "offsets" || name == "types" ? cells : points;
        std::uint64_t       count      = 0;
        if (attribute(vtu, "format", at, tag_end) != "appended" ||
            std::stoull(attribute(vtu, "offset", at, tag_end)) != end || data + end + 8 > vtu.size())
          return false;
        std::memcpy(&count, vtu.data() + data + end, sizeof count);
        if (count != values * components * per_value)
          return false;
        end += 8 + count;
      }
    return vtu.compare(data + end, std::string::npos, "\n  </AppendedData>\n</VTKFile>\n") == 0;
  }

  // The 3-vector after "key": [ in the first entry of "final".
  void json_final_vector(const std::string &json, const std::string &key, double out[3])
  {
    std::size_t at = json.find("\"" + key + "\": [", json.find("\"final\""));
    const char *p  = json.c_str() + at + key.size() + 5;
    for (int d = 0; d < 3; ++d)
      {
        char *end = nullptr;
        out[d]    = std::strtod(p, &end);
        p         = end + 1; // the comma
      }
  }

  // Contact periods in a trace: per HIP, runs of rows in contact at the same vertex.
  std::size_t contact_periods(const std::vector<std::vector<std::string>> &trace, std::uint32_t hips)
  {
    std::size_t periods = 0;
    for (std::uint32_t h = 0; h < hips; ++h)
      {
        const std::string hip = "hip" + std::to_string(h) + "_";
        const std::size_t contact = column(trace[0], hip + "contact"), vertex = column(trace[0], hip + "vertex");
        std::string       previous = "-1";
        for (std::size_t r = 1; r < trace.size(); ++r)
          {
            const std::string now = trace[r][contact] == "1" ? trace[r][vertex] : "-1";
            periods += now != "-1" && now != previous;
            previous = now;
          }
      }
    return periods;
  }

  // presses.csv against the trace and the basis: one row per contact period; the compliance along the
  // normal is n^T G n of modalrt_basis_contact_compliance, finite and > 0, and full_fe is set exactly
  // for the candidates of the press's space. Returns the rows (header first).
  std::vector<std::vector<std::string>> check_presses(const std::string &dir, std::uint32_t hips)
  {
    const auto presses = read_csv(dir + "/presses.csv");
    ENSURE(!presses.empty() && presses[0][0] == "press");
    ENSURE(presses.size() - 1 == contact_periods(read_csv(dir + "/trace.csv"), hips));
    modalrt_basis *basis = nullptr;
    ENSURE(modalrt_basis_load(basis_path.c_str(), &basis) == MODALRT_OK);
    const std::vector<std::string> &h = presses[0];
    for (std::size_t r = 1; r < presses.size(); ++r)
      {
        const auto         &p          = presses[r];
        const std::uint32_t space      = std::stoul(p[column(h, "space")]);
        const std::uint32_t vertex     = std::stoul(p[column(h, "vertex")]);
        const double        compliance = std::strtod(p[column(h, "compliance_m_per_n")].c_str(), nullptr);
        const double        n[3]       = {std::stod(p[column(h, "nx")]), std::stod(p[column(h, "ny")]),
                                          std::stod(p[column(h, "nz")])};
        double              G[9];
        std::uint32_t       full_fe = 0;
        ENSURE(modalrt_basis_contact_compliance(basis, space, vertex, G, &full_fe) == MODALRT_OK);
        double expected = 0.0;
        for (int a = 0; a < 3; ++a)
          for (int b = 0; b < 3; ++b)
            expected += n[a] * G[3 * a + b] * n[b];
        ENSURE(std::isfinite(compliance) && compliance > 0.0);
        ENSURE_RELATIVE(compliance, expected, 1e-6);
        modalrt_space_info info;
        modalrt_basis_get_space_info(basis, space, &info);
        const std::uint32_t *candidates   = modalrt_basis_candidates(basis, space);
        const bool           is_candidate = std::binary_search(candidates, candidates + info.candidate_count, vertex);
        ENSURE(p[column(h, "full_fe")] == (is_candidate ? "1" : "0"));
      }
    modalrt_basis_destroy(basis);
    return presses;
  }

  // The tool draws force_displacement.png when /usr/bin/python3 has matplotlib, else says it skipped.
  void check_plot(const std::string &dir, const std::string &output)
  {
    static const bool matplotlib = std::system("/usr/bin/python3 -c 'import matplotlib' > /dev/null 2>&1") == 0;
    if (!matplotlib)
      {
        ENSURE(contains(output, "force_displacement.png skipped"));
        return;
      }
    const std::string png = read_text(dir + "/force_displacement.png");
    ENSURE(png.size() > 1000 && png.compare(0, 8, "\x89PNG\r\n\x1a\n") == 0);
  }

  modalrt::LatticeOptions lattice()
  {
    modalrt::LatticeOptions o;
    o.patch_radius = 0.03;
    o.damping      = {0.7, 0.7}; // settles to 1e-9 relative in well under a second
    return o;
  }

  // Two HIPs on the lattice's top face (z = 0.01 m; the tip space owns x >= 0.12 m): HIP 0 presses
  // the tip (switch to space 1), lifts off; HIP 1 presses near the root (switch back to space 0);
  // both press while the part is carried up 5 cm; HIP 0 is released by an event and pressed again.
  const char *two_hip_session = R"(# test session
time,hip,event,x,y,z
0.0,0,target,0.125,0.025,0.02
0.0,1,target,0.025,0.025,0.03
0.2,0,target,0.125,0.025,0.005
0.4,0,target,0.125,0.025,0.02
0.5,1,target,0.025,0.025,0.005
0.6,0,target,0.05,0.025,0.005
0.8,-,frame,0,0,0
0.8,0,target,0.05,0.025,0.005
0.8,1,target,0.025,0.025,0.005
1.1,-,frame,0,0,0.05
1.1,0,target,0.05,0.025,0.055
1.1,1,target,0.025,0.025,0.055
1.2,0,release
1.3,0,press,0.05,0.025,0.01
1.5,-,end
)";

  // No scripted press pulls (a press that ends in -0.87 to -1.0 N before its release fails): on the
  // lattice's top face the outward normal is +z, so the force rendered on the device along it,
  // hiph_fz of trace.csv, is never attractive beyond 1e-9 N, in contact or ramping after a release.
  double most_pull(const std::string &dir, std::uint32_t hips)
  {
    const auto trace = read_csv(dir + "/trace.csv");
    double     pull  = 0.0;
    for (std::uint32_t h = 0; h < hips; ++h)
      {
        const std::size_t fz = column(trace[0], "hip" + std::to_string(h) + "_fz");
        for (std::size_t r = 1; r < trace.size(); ++r)
          pull = std::max(pull, -std::stod(trace[r][fz]));
      }
    return pull;
  }

  void impedance_session()
  {
    write_text("run_two_hips.csv", two_hip_session);
    for (const double rate : {1000.0, 4000.0})
      {
        const std::string dir = rate == 1000.0 ? "run_out_1k" : "run_out_4k";
        std::string       out;
        // The plot once (Python takes a second); --no-plot leaves none, not even a stale one.
        const std::string plot = rate == 1000.0 ? "" : " --no-plot";
        ENSURE(run("--basis " + basis_path + " --session run_two_hips.csv --output-dir " + dir + " --rate " +
                     std::to_string(int(rate)) + plot,
                   out) == 0);
        std::printf("%s", out.c_str());
        const std::string stats = read_text(dir + "/stats.json");
        ENSURE(json_number(stats, "ticks") == 1.5 * rate);
        ENSURE(json_number(stats, "allocations_after_start") == 0);
        ENSURE(json_number(stats, "non_finite_outputs") == 0);
        ENSURE(json_number(stats, "rejected_inputs") == 0);
        ENSURE(json_number(stats, "switches") >= 2);
        ENSURE(json_number(stats, "events_applied") == 2 && json_number(stats, "failed_events") == 0);
        ENSURE(contains(stats, "\"stopped_by\": \"end of session\""));
        ENSURE(json_number(stats, "in_contact") == 1); // HIP 0, pressed by the last event
        ENSURE(contains(read_text(dir + "/trace.csv"), "time,hip0_x"));
        ENSURE(contains(read_text(dir + "/frames.pvd"), "frames/frame_000000.vtu"));
        ENSURE(contains(read_text(dir + "/frames/frame_000000.vtu"), "Name=\"displacement\""));
        ENSURE(appended_frame_is_whole(read_text(dir + "/frames/frame_000000.vtu")));
        // At least HIP 0 on the tip, HIP 1 near the root, HIP 0 again after the release event.
        ENSURE(check_presses(dir, 2).size() >= 1 + 3);
        const double pull = most_pull(dir, 2);
        ENSURE(pull <= 1e-9);
        std::printf("  most attractive force on the device over the session: %.3g N\n", pull);
        // The schedule's verdict, against the documented threshold of 0.1 % late ticks.
        ENSURE(contains(out, "  timing        fine: ") || contains(out, "  timing        warning: "));
        ENSURE(contains(out, "the 0.1 % a hand cannot feel"));
        if (plot.empty())
          check_plot(dir, out);
        else
          ENSURE(!std::filesystem::exists(dir + "/force_displacement.png"));
      }
  }

  // A constant force on a validation vertex of the tip space, admittance, rigid probe: the settled
  // felt displacement is F times the stored full static response (B Lambda^-1 B^T + C) e_z.
  void admittance_static_response(const modalrt::BasisContent &c)
  {
    const modalrt::BasisSpaceContent &tip = c.spaces[1];
    std::size_t                       k   = 0;
    while (tip.validation_cases[2 * k + 1] != 2 || c.region[tip.validation_cases[2 * k]] != 1)
      ++k;
    const std::uint32_t vertex = tip.validation_cases[2 * k];
    const double       *x      = &c.vertices[3 * vertex];
    const double        force  = -2.0; // [N] along z, into the part
    char                text[512];
    std::snprintf(text, sizeof text,
                  "time,hip,event,x,y,z\n0,0,target,%.17g,%.17g,%.17g\n0,0,force,0,0,0\n0.2,0,force,0,0,%g\n"
                  "1.0,-,end\n",
                  x[0], x[1], x[2], force);
    write_text("run_static.csv", text);
    std::string out;
    ENSURE(run("--basis " + basis_path + " --session run_static.csv --output-dir run_out_static --mode admittance "
                 "--device probe --quiet",
               out) == 0);
    const std::string stats = read_text("run_out_static/stats.json");
    ENSURE(json_number(stats, "active_vertex") == vertex);
    double position[3];
    json_final_vector(stats, "position", position);
    double error = 0.0, size = 0.0;
    for (int d = 0; d < 3; ++d)
      {
        const double expected = force * tip.validation_response[3 * k + d];
        error += (position[d] - x[d] - expected) * (position[d] - x[d] - expected);
        size += expected * expected;
      }
    std::printf("  static response at vertex %u: relative error %.3e\n", vertex, std::sqrt(error / size));
    ENSURE(std::sqrt(error / size) <= 1e-6);
    // One press at a candidate, settled under a constant force along the normal (the lattice's top
    // face is flat): the felt stiffness is the full-FE static stiffness.
    const auto presses = check_presses("run_out_static", 1);
    ENSURE(presses.size() == 2);
    if (presses.size() == 2)
      {
        ENSURE(presses[1][column(presses[0], "full_fe")] == "1");
        ENSURE_NEAR(std::stod(presses[1][column(presses[0], "ratio")]), 1.0, 1e-6);
        ENSURE_NEAR(std::stod(presses[1][column(presses[0], "felt_force_n")]), -force, 1e-9);
      }
    ENSURE(json_number(stats, "allocations_after_start") == 0 && json_number(stats, "non_finite_outputs") == 0);
  }

  // SIGINT once a one-minute session runs (its first frame is written): exit 0, every output written.
  void stop_on_sigint()
  {
    std::filesystem::remove_all("run_out_sigint");
    const pid_t child = fork();
    if (child == 0)
      {
        const int null = open("/dev/null", O_WRONLY);
        dup2(null, 1);
        execl(MODAL_RT_PROGRAM, MODAL_RT_PROGRAM, "run", "--basis", basis_path.c_str(), "--session", "run_two_hips.csv",
              "--output-dir", "run_out_sigint", "--duration", "60", static_cast<char *>(nullptr));
        _exit(127);
      }
    for (int k = 0; k < 600 && !std::filesystem::exists("run_out_sigint/frames/frame_000000.vtu"); ++k)
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    kill(child, SIGINT);
    int status = 0;
    waitpid(child, &status, 0);
    ENSURE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
    const std::string stats = read_text("run_out_sigint/stats.json");
    ENSURE(contains(stats, "\"stopped_by\": \"signal\""));
    ENSURE(json_number(stats, "ticks") > 0 && json_number(stats, "ticks") < 60000);
    ENSURE(contains(read_text("run_out_sigint/frames.pvd"), "</VTKFile>"));
  }

  // Exit `code` and every `culprit` named in the message.
  void expect_failure(const std::string &arguments, int code, std::initializer_list<const char *> culprits)
  {
    std::string out;
    const int   status = run(arguments, out);
    ENSURE(status == code);
    for (const char *culprit : culprits)
      if (!contains(out, culprit))
        test::report(false, __FILE__, __LINE__, "'" + std::string(culprit) + "' not named in: " + out);
    std::printf("  exit %d: %s", status, out.substr(0, out.find('\n') + 1).c_str());
  }

  // The multi-contact presses of a run of the two-HIP session on `content` (admittance, rigid probe):
  // each press's multi-contact static stiffness is the static answer computed here from the basis
  // content written to the file,
  //   u_a = sum_b (B_a Lambda^-1 B_b^T + C_ab) F_b,  multi_static_stiffness = felt_force / (-n . u_a),
  // C_ab as the specification gives it (modalrt::content_static_compliance), within 1e-9 relative.
  void check_multi_presses(const modalrt::BasisContent &content, const std::vector<std::vector<std::string>> &presses,
                           const std::vector<std::vector<std::string>> &trace, const std::uint32_t vertices[2])
  {
    ENSURE(presses.size() == 3 && trace.size() > 1);
    if (presses.size() != 3)
      return;
    const auto &h = presses[0];
    for (std::size_t k = 1; k < presses.size(); ++k)
      {
        const auto         &p     = presses[k];
        const std::uint32_t hip   = std::stoul(p[column(h, "hip")]);
        const std::uint32_t space = std::stoul(p[column(h, "space")]);
        ENSURE(hip < 2 && std::stoul(p[column(h, "vertex")]) == vertices[hip] && space == 1);
        ENSURE(p[column(h, "felt_contacts")] == "2");
        // The forces on the part at the felt time (admittance: the trace's force is the one applied).
        const double felt_time = std::stod(p[column(h, "felt_time_s")]);
        std::size_t  r         = 1;
        while (r + 1 < trace.size() && std::stod(trace[r][0]) < felt_time - 1e-12)
          ++r;
        double F[2][3];
        for (std::uint32_t b = 0; b < 2; ++b)
          for (int d = 0; d < 3; ++d)
            F[b][d] = std::stod(trace[r][column(trace[0], "hip" + std::to_string(b) + "_f" + "xyz"[d])]);
        // The static answer from the content of the file.
        const modalrt::BasisSpaceContent &s  = content.spaces[space];
        const std::size_t                 nc = s.candidates.size();
        const auto index = [&](std::uint32_t v) {
          return std::size_t(std::lower_bound(s.candidates.begin(), s.candidates.end(), v) - s.candidates.begin());
        };
        const std::size_t a = index(vertices[hip]);
        double            u[3] = {0.0, 0.0, 0.0};
        for (std::uint32_t b = 0; b < 2; ++b)
          {
            const std::size_t kb = index(vertices[b]);
            ENSURE(kb < nc && s.candidates[kb] == vertices[b]);
            const std::array<double, 9> G = modalrt::content_static_compliance(s, a, kb);
            for (int c = 0; c < 3; ++c)
              for (int d = 0; d < 3; ++d)
                u[c] += G[3 * c + d] * F[b][d];
          }
        const double n[3] = {std::stod(p[column(h, "nx")]), std::stod(p[column(h, "ny")]), std::stod(p[column(h, "nz")])};
        const double felt_force = -(n[0] * F[hip][0] + n[1] * F[hip][1] + n[2] * F[hip][2]);
        const double exact      = felt_force / -(n[0] * u[0] + n[1] * u[1] + n[2] * u[2]);
        const double multi      = std::stod(p[column(h, "multi_static_stiffness_n_per_m")]);
        const double single     = std::stod(p[column(h, "static_stiffness_n_per_m")]);
        std::printf("  HIP %u at vertex %u: multi-contact static stiffness %.12g N/m, from the file's content "
                    "%.12g N/m (relative difference %.2e); alone %.6g N/m\n",
                    hip, vertices[hip], multi, exact, std::abs(multi - exact) / exact, single);
        ENSURE(std::abs(multi - exact) <= 1e-9 * std::abs(exact) && exact > 0.0);
        ENSURE(std::abs(single - exact) > 1e-3 * exact); // the other load matters
        ENSURE_NEAR(std::stod(p[column(h, "felt_force_n")]), felt_force, 1e-9);
      }
  }

  // Two HIPs pressing two candidates of the tip space at once, through modal-rt run: with the dense
  // cross compliance every pair is stored and the presses are the full-FE answer (multi_full_fe 1);
  // without CROSS_COMPLIANCE the same presses say there is no full-FE answer; with the cross
  // compliance between triangle neighbours only and a far field (.mrt 1.3), the far pair's presses
  // are the static answer with C_ab = Z_a Z_b^T and say so (multi_full_fe 0, multi_note, the summary).
  void multi_contact_full_fe()
  {
    modalrt::LatticeOptions o = lattice();
    o.patch_radius            = 0.0; // B_v = the modes at the vertex: the file's CANDIDATE_MODES
    const auto content        = modalrt::make_lattice_cantilever(o);
    ENSURE(modalrt::write_basis_file("run_multi.mrt", content));
    modalrt::LatticeOptions far = o;
    far.far_rank                = 3;
    const auto far_content      = modalrt::make_lattice_cantilever(far);
    ENSURE(modalrt::write_basis_file("run_multi_far.mrt", far_content));
    o.cross = false;
    ENSURE(modalrt::write_basis_file("run_multi_no_cross.mrt", modalrt::make_lattice_cantilever(o)));
    const std::uint32_t vertices[2] = {modalrt::lattice_display_vertex(o, 6, 1), modalrt::lattice_display_vertex(o, 8, 2)};
    std::string         text        = "time,hip,event,x,y,z\n";
    char                row[256];
    for (std::uint32_t h = 0; h < 2; ++h)
      {
        const double *x = &content.vertices[3 * vertices[h]];
        std::snprintf(row, sizeof row, "0,%u,target,%.17g,%.17g,%.17g\n0,%u,force,0,0,0\n", h, x[0], x[1], x[2], h);
        text += row;
      }
    text += "0.2,0,force,0,0,-2\n0.2,1,force,0,0,-1\n1.0,-,end\n";
    write_text("run_multi.csv", text);

    std::string out;
    ENSURE(run("--basis run_multi.mrt --session run_multi.csv --output-dir run_out_multi --mode admittance --device probe "
               "--trace-rate 1000 --no-plot",
               out) == 0);
    std::printf("%s", out.c_str());
    const auto presses = read_csv("run_out_multi/presses.csv");
    ENSURE(contains(out, "  validity      no validity map in the basis")); // said once, for the presses
    check_multi_presses(content, presses, read_csv("run_out_multi/trace.csv"), vertices);
    for (std::size_t k = 1; k < presses.size(); ++k)
      {
        ENSURE(presses[k][column(presses[0], "multi_full_fe")] == "1");
        ENSURE(presses[k][column(presses[0], "multi_note")].empty());
      }

    ENSURE(run("--basis run_multi_far.mrt --session run_multi.csv --output-dir run_out_multi_far --mode admittance "
               "--device probe --trace-rate 1000 --no-plot",
               out) == 0);
    const auto far_presses = read_csv("run_out_multi_far/presses.csv");
    check_multi_presses(far_content, far_presses, read_csv("run_out_multi_far/trace.csv"), vertices);
    const std::string far_note = "far-field coupling (rank 3) between vertices " + std::to_string(vertices[0]) +
                                 " and " + std::to_string(vertices[1]) +
                                 ": the precompute's report.json states its measured error (spaces[].far_field)";
    for (std::size_t k = 1; k < far_presses.size(); ++k)
      {
        ENSURE(far_presses[k][column(far_presses[0], "multi_full_fe")] == "0");
        ENSURE(far_presses[k][column(far_presses[0], "multi_note")] == far_note);
      }
    ENSURE(contains(out, "static (" + far_note + ")"));
    ENSURE(!contains(out, "no full-FE reference (far-field"));

    ENSURE(run("--basis run_multi_no_cross.mrt --session run_multi.csv --output-dir run_out_multi_no_cross "
               "--mode admittance --device probe --no-plot --quiet",
               out) == 0);
    const auto no_cross = read_csv("run_out_multi_no_cross/presses.csv");
    ENSURE(no_cross.size() == 3);
    for (std::size_t k = 1; k < no_cross.size(); ++k)
      {
        ENSURE(no_cross[k][column(no_cross[0], "multi_full_fe")] == "0");
        ENSURE(contains(no_cross[k][column(no_cross[0], "multi_note")], "stores no cross compliance"));
      }
  }

  // Slides through modal-rt run (the session's `proxy` row): HIP 0 pressed 2 mm below the lattice's
  // top face slides along it from x = 0.06 m across the tip VOI's boundary (x = 0.12 m) to 0.17 m;
  // in a second scripted session two HIPs slide past each other. Asserted from slides.csv, trace.csv and
  // presses.csv: the slide is found (its length, the switch into the tip space), the largest force
  // change per tick while sliding is bounded and far below the snap contact's on the same session,
  // the passivity observer is not below -1e-4 J, the trace's static stiffness is the basis's at the
  // proxy's point, and no press is made of a slide's rows.
  const char *slide_session = R"(time,hip,event,x,y,z
0.0,-,proxy,0.3,0.2
0.0,0,target,0.06,0.025,0.02
0.3,0,target,0.06,0.025,0.008
0.6,0,target,0.06,0.025,0.008
1.8,0,target,0.17,0.025,0.008
2.1,0,target,0.17,0.025,0.008
2.4,0,target,0.17,0.025,0.02
2.5,-,end
)";

  const char *two_slides_session = R"(time,hip,event,x,y,z
0.0,-,proxy,0.3,0.2
0.0,0,target,0.05,0.015,0.02
0.0,1,target,0.15,0.035,0.02
0.3,0,target,0.05,0.015,0.008
0.3,1,target,0.15,0.035,0.008
0.6,0,target,0.05,0.015,0.008
0.6,1,target,0.15,0.035,0.008
1.6,0,target,0.15,0.015,0.008
1.6,1,target,0.05,0.035,0.008
1.9,0,target,0.15,0.015,0.02
1.9,1,target,0.05,0.035,0.02
2.0,-,end
)";

  // The largest |F_n - F_(n-1)| of HIP `hip` between consecutive trace rows in contact (a trace at
  // --trace-rate = --rate has every tick), and the rows of the run (header first).
  double largest_contact_step(const std::vector<std::vector<std::string>> &trace, std::uint32_t hip)
  {
    const std::string h = "hip" + std::to_string(hip) + "_";
    const std::size_t contact = column(trace[0], h + "contact"), fx = column(trace[0], h + "fx");
    double            largest = 0.0;
    for (std::size_t r = 2; r < trace.size(); ++r)
      {
        if (trace[r][contact] != "1" && trace[r - 1][contact] != "1")
          continue;
        double step = 0.0;
        for (std::size_t d = 0; d < 3; ++d)
          step += std::pow(std::stod(trace[r][fx + d]) - std::stod(trace[r - 1][fx + d]), 2);
        largest = std::max(largest, std::sqrt(step));
      }
    return largest;
  }

  void slides()
  {
    const double bound = -1e-4; // [J] the passivity observer's documented floor
    write_text("run_slide.csv", slide_session);
    std::string out;
    ENSURE(run("--basis " + basis_path + " --session run_slide.csv --output-dir run_out_slide --trace-rate 1000", out) == 0);
    std::printf("%s", out.c_str());
    ENSURE(contains(out, "  slide 0       HIP 0, global -> tip"));
    const auto slides = read_csv("run_out_slide/slides.csv");
    ENSURE(slides.size() == 2);
    if (slides.size() != 2)
      return;
    const auto  &h          = slides[0];
    const double length     = std::stod(slides[1][column(h, "length_m")]);
    const double step       = std::stod(slides[1][column(h, "max_force_step_n")]);
    const double energy     = std::stod(slides[1][column(h, "passivity_energy_j")]);
    const double start      = std::stod(slides[1][column(h, "start_s")]), end = std::stod(slides[1][column(h, "end_s")]);
    ENSURE(slides[1][column(h, "space_start")] == "0" && slides[1][column(h, "space_end")] == "1");
    ENSURE(length > 0.08 && length < 0.13);
    ENSURE(energy >= bound);
    const std::string stats = read_text("run_out_slide/stats.json");
    ENSURE(json_number(stats, "switches") >= 1 && json_number(stats, "allocations_after_start") == 0);
    ENSURE(contains(stats, "\"passivity_energy_j\": "));
    // Without a validity map: no tick beyond, no margin, and the summary says so.
    ENSURE(slides[1][column(h, "beyond_ticks")] == "0" && slides[1][column(h, "lowest_margin")] == "nan");
    ENSURE(slides[1][column(h, "lowest_margin_vertex")] == "-1");
    ENSURE(contains(stats, "\"lowest_margin\": null") && contains(stats, "\"slides_beyond\": 0"));
    ENSURE(contains(out, "passivity") && contains(out.substr(out.find("  slide 0 ")), "no validity map"));

    // The trace's static stiffness is 1 / (n^T G n) of modalrt_basis_point_compliance at the proxy's
    // point, n the corners' blended normal.
    const auto     trace = read_csv("run_out_slide/trace.csv");
    modalrt_basis *basis = nullptr;
    ENSURE(modalrt_basis_load(basis_path.c_str(), &basis) == MODALRT_OK);
    const auto  &t        = trace[0];
    std::size_t  checked  = 0;
    double       worst    = 0.0;
    for (std::size_t r = 1; r < trace.size(); r += 37)
      {
        if (trace[r][column(t, "hip0_contact")] != "1")
          continue;
        const std::uint32_t triangle = std::stoul(trace[r][column(t, "hip0_triangle")]);
        const double w[3] = {std::stod(trace[r][column(t, "hip0_w0")]), std::stod(trace[r][column(t, "hip0_w1")]),
                             std::stod(trace[r][column(t, "hip0_w2")])};
        double G[9], n[3] = {0, 0, 0};
        ENSURE(modalrt_basis_point_compliance(basis, std::stoul(trace[r][column(t, "hip0_space")]), triangle, w, G,
                                              nullptr) == MODALRT_OK);
        for (int k = 0; k < 3; ++k)
          for (int d = 0; d < 3; ++d)
            n[d] += w[k] * modalrt_basis_display_normals(basis)[3 * modalrt_basis_display_triangles(basis)[3 * triangle + k] + d];
        double nGn = 0.0, length_n = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        for (int a = 0; a < 3; ++a)
          for (int b = 0; b < 3; ++b)
            nGn += n[a] * G[3 * a + b] * n[b] / (length_n * length_n);
        const double k = std::stod(trace[r][column(t, "hip0_static_stiffness")]);
        worst          = std::max(worst, std::fabs(k * nGn - 1.0));
        ++checked;
      }
    modalrt_basis_destroy(basis);
    ENSURE(checked >= 20 && worst < 1e-6);
    // No press is made of the slide's rows.
    const auto presses = read_csv("run_out_slide/presses.csv");
    for (std::size_t k = 1; k < presses.size(); ++k)
      {
        const double s = std::stod(presses[k][column(presses[0], "start_s")]), e = std::stod(presses[k][column(presses[0], "end_s")]);
        ENSURE(e < start || s > end);
      }

    // The same session with the snap contact: dragged along, it is released and snaps again.
    std::string snap_session = slide_session;
    snap_session.erase(snap_session.find("0.0,-,proxy"), std::string("0.0,-,proxy,0.3,0.2\n").size());
    write_text("run_slide_snap.csv", snap_session);
    ENSURE(run("--basis " + basis_path + " --session run_slide_snap.csv --output-dir run_out_slide_snap --trace-rate "
                 "1000 --no-plot --quiet",
               out) == 0);
    const double snap = largest_contact_step(read_csv("run_out_slide_snap/trace.csv"), 0);
    std::printf("  slide across the VOI boundary through modal-rt run: %.1f mm, largest force change per tick %.3e N "
                "(the snap contact on the same session: %.3e N), passivity %+.3e J; static stiffness in the trace "
                "within %.1e of the basis's at %zu points\n",
                1e3 * length, step, snap, energy, worst, checked);
    // [N] per tick: a tenth of the ~0.46 N normal force; the snap contact steps by force_rate_limit (0.2 N)
    // at each release, 9 times the proxy's measured 0.023 N.
    ENSURE(step > 0.0 && step < 0.05 && snap > 4.0 * step);
    ENSURE(read_csv("run_out_slide_snap/slides.csv").size() == 1); // the snap contact never slides

    write_text("run_two_slides.csv", two_slides_session);
    ENSURE(run("--basis " + basis_path + " --session run_two_slides.csv --output-dir run_out_two_slides --no-plot",
               out) == 0);
    std::printf("%s", out.c_str());
    const auto two = read_csv("run_out_two_slides/slides.csv");
    ENSURE(two.size() == 3);
    if (two.size() != 3)
      return;
    ENSURE(two[1][column(h, "hip")] != two[2][column(h, "hip")]);
    ENSURE(std::stod(two[2][column(h, "start_s")]) < std::stod(two[1][column(h, "end_s")])); // at the same time
    for (std::size_t k = 1; k < 3; ++k)
      {
        ENSURE(std::stod(two[k][column(h, "length_m")]) > 0.06);
        ENSURE(std::stod(two[k][column(h, "max_force_step_n")]) < 0.05);
        ENSURE(std::stod(two[k][column(h, "passivity_energy_j")]) >= bound);
      }
  }

  // run_validity.mrt: the lattice with the made-up validity map (LatticeOptions::validity_force).
  void write_validity_basis()
  {
    modalrt::LatticeOptions o = lattice();
    o.validity_force          = true;
    ENSURE(modalrt::write_basis_file("run_validity.mrt", modalrt::make_lattice_cantilever(o)));
  }

  // A slide against the validity map: the slide session on the lattice with the made-up map (F_p =
  // p x 0.2 N x (1 + x / 0.2 m) at the candidates), at the 1 % level (F1 about 0.26-0.37 N, below the
  // slide's 0.47 N: beyond) and at 5 % (F5 five times that: within). Every tick traced: slides.csv's
  // beyond_ticks equals the slide's trace rows flagged beyond, and its lowest margin equals
  // min(validity_force / |F|) recomputed from the slide's trace rows in contact, at the row it names.
  void slides_against_validity()
  {
    write_validity_basis();
    write_text("run_slide.csv", slide_session);
    for (const int level : {1, 5})
      {
        const std::string dir = "run_out_slide_validity_" + std::to_string(level);
        std::string       out;
        ENSURE(run("--basis run_validity.mrt --session run_slide.csv --no-plot --trace-rate 1000 --output-dir " +
                     dir + " --validity-level " + std::to_string(level),
                   out) == 0);
        const auto slides = read_csv(dir + "/slides.csv");
        const auto trace  = read_csv(dir + "/trace.csv");
        ENSURE(slides.size() == 2 && trace.size() > 1);
        if (slides.size() != 2 || trace.size() < 2)
          continue;
        const auto   &h = slides[0], &t = trace[0];
        const auto   &slide = slides[1];
        const double  start = std::stod(slide[column(h, "start_s")]), end = std::stod(slide[column(h, "end_s")]);
        const std::size_t beyond = column(t, "hip0_beyond"), force = column(t, "hip0_validity_force");
        const std::size_t fx = column(t, "hip0_fx"), contact = column(t, "hip0_contact");
        std::size_t       flagged = 0, rows = 0, lowest_row = 0;
        double            lowest  = INFINITY;
        for (std::size_t r = 1; r < trace.size(); ++r)
          {
            const double time = std::stod(trace[r][0]);
            if (time < start || time > end)
              continue;
            ++rows;
            flagged += trace[r][beyond] == "1";
            const double F = std::hypot(std::stod(trace[r][fx]), std::stod(trace[r][fx + 1]), std::stod(trace[r][fx + 2]));
            const double Fv = std::stod(trace[r][force]);
            if (trace[r][contact] == "1" && std::isfinite(Fv) && F > 0.0 && Fv / F < lowest)
              lowest = Fv / F, lowest_row = r;
          }
        const double margin = std::stod(slide[column(h, "lowest_margin")]);
        const double at     = std::stod(slide[column(h, "lowest_margin_s")]);
        const auto   ticks  = std::stoull(slide[column(h, "beyond_ticks")]);
        std::printf("  slide at the %d %% level: %llu of %zu ticks beyond, lowest margin %.9g at %.3f s (from the "
                    "trace: %zu flagged, lowest %.9g)\n",
                    level, (unsigned long long)ticks, rows, margin, at, flagged, lowest);
        ENSURE(slide[column(h, "validity_level_pct")] == std::to_string(level));
        ENSURE(rows == std::stoull(slide[column(h, "ticks")])); // every tick traced
        ENSURE(ticks == flagged);
        ENSURE(std::isfinite(lowest) && lowest_row > 0);
        if (lowest_row == 0)
          continue;
        ENSURE_RELATIVE(margin, lowest, 1e-7); // the trace's 9 digits
        // The row it names is one with that margin, and its columns are that row's.
        std::size_t named = 0;
        for (std::size_t r = 1; r < trace.size() && named == 0; ++r)
          named = trace[r][0] == slide[column(h, "lowest_margin_s")] ? r : 0;
        ENSURE(named > 0);
        if (named == 0)
          continue;
        const auto &row = trace[named];
        ENSURE(row[contact] == "1");
        ENSURE(row[column(t, "hip0_vertex")] == slide[column(h, "lowest_margin_vertex")]);
        ENSURE(row[column(t, "hip0_triangle")] == slide[column(h, "lowest_margin_triangle")]);
        ENSURE_RELATIVE(std::stod(row[force]), std::stod(slide[column(h, "lowest_margin_validity_force_n")]), 1e-8);
        ENSURE_RELATIVE(std::stod(row[force]) / std::stod(slide[column(h, "lowest_margin_force_n")]), lowest, 1e-7);
        const std::string stats = read_text(dir + "/stats.json");
        const std::size_t entry = stats.find("\"slides\": [");
        ENSURE(json_number(stats, "beyond_ticks", entry) == double(ticks)); // the slide's, before the run's
        ENSURE_RELATIVE(json_number(stats, "lowest_margin", entry), margin, 1e-8);
        ENSURE(json_number(stats, "slides_beyond") == (level == 1 ? 1 : 0));
        ENSURE(json_number(stats, "allocations_after_start") == 0); // the tracker's count in the haptic thread
        if (level == 1)
          {
            ENSURE(ticks > 100 && margin < 1.0);
            ENSURE(contains(out, "beyond its validity force on " + std::to_string(ticks) + " of " +
                                   slide[column(h, "ticks")] + " ticks: lowest F1 / |F| = "));
          }
        else
          {
            ENSURE(ticks == 0 && margin > 1.0);
            ENSURE(contains(out, "within its validity force: lowest F5 / |F| = "));
          }
      }
  }

  // The validity map (.mrt 1.2): HIP 0 presses vertex 15 of the tip space (F1, F5, F10 = 0.35, 1.75,
  // 3.5 N) with the hand about 2.9 N: beyond F5 (the default level), within F10; --validity-clamp holds
  // the rendered force at F5. trace.csv's beyond and validity_force, presses.csv's columns, stats.json's
  // counts and the summary's line per press.
  const char *validity_session = R"(time,hip,event,x,y,z
0.0,0,target,0.15,0.025,0.02
0.3,0,target,0.15,0.025,-0.005
1.0,0,target,0.15,0.025,-0.005
1.3,0,target,0.15,0.025,0.02
1.5,-,end
)";

  void validity()
  {
    write_validity_basis();
    write_text("run_validity.csv", validity_session);
    const std::string files = "--basis run_validity.mrt --session run_validity.csv --no-plot --trace-rate 1000";
    const char *dirs[] = {"run_out_validity", "run_out_validity_clamp", "run_out_validity_10"};
    int         which  = 0;
    for (const char *variant : {"", " --validity-clamp", " --validity-level 10"})
      {
        const std::string dir = dirs[which++];
        std::string       out;
        ENSURE(run(files + " --output-dir " + dir + variant, out) == 0);
        const std::string stats   = read_text(dir + "/stats.json");
        const auto        trace   = read_csv(dir + "/trace.csv");
        const auto        presses = read_csv(dir + "/presses.csv");
        ENSURE(trace.size() > 1);
        if (trace.size() < 2)
          continue;
        const bool        clamp = std::string(variant) == " --validity-clamp", ten = !clamp && variant[0];
        const double      Fv    = ten ? 3.5 : 1.75;
        std::size_t       flagged = 0, mismatches = 0;
        double            largest = 0.0;
        const std::size_t beyond = column(trace[0], "hip0_beyond"), force = column(trace[0], "hip0_validity_force");
        const std::size_t fx = column(trace[0], "hip0_fx"), contact = column(trace[0], "hip0_contact");
        for (std::size_t r = 1; r < trace.size(); ++r)
          {
            const double F = std::hypot(std::stod(trace[r][fx]), std::stod(trace[r][fx + 1]), std::stod(trace[r][fx + 2]));
            flagged += trace[r][beyond] == "1";
            if (trace[r][contact] == "1")
              {
                largest = std::max(largest, F);
                mismatches += std::fabs(std::stod(trace[r][force]) - Fv) > 1e-9;
                if (!clamp)
                  mismatches += (trace[r][beyond] == "1") != (F > Fv);
              }
          }
        std::printf("validity%s: %zu of %zu ticks beyond F%d = %.2f N, largest force %.17g N, stats.json "
                    "beyond_ticks %g\n",
                    variant, flagged, trace.size() - 1, ten ? 10 : 5, Fv, largest, json_number(stats, "beyond_ticks"));

        ENSURE(mismatches == 0);
        ENSURE(json_number(stats, "beyond_ticks") == double(flagged)); // every tick traced: the counts agree
        ENSURE(json_number(stats, "level_percent") == (ten ? 10 : 5));
        ENSURE(contains(stats, clamp ? "\"clamp\": true" : "\"clamp\": false") && contains(stats, "\"map\": true"));
        ENSURE(presses.size() == 2);
        if (presses.size() == 2)
          ENSURE(presses[1][column(presses[0], "beyond_validity")] == (ten ? "0" : "1"));
        if (ten)
          {
            ENSURE(flagged == 0 && largest > 2.5 && largest < 3.5);
            ENSURE(contains(out, "within its validity force: up to ") && contains(out, "F10 = 3.5 N"));
          }
        else
          {
            ENSURE(flagged > 300);
            ENSURE(contains(out, "beyond its validity force: F5 = 1.75 N, from "));
            ENSURE(clamp ? largest <= 1.75 + 1e-8 : largest > 2.5); // the trace's 9 digits
            ENSURE(!clamp || contains(out, "held at it (--validity-clamp)"));
            ENSURE(!contains(out, "no validity map in the basis"));
          }
      }
    expect_failure(files + " --output-dir x --validity-level 7", 2, {"--validity-level", "'7'", "1, 5 or 10"});
  }

  void bad_command_lines()
  {
    const std::string files = "--basis " + basis_path + " --session run_two_hips.csv";
    expect_failure(files, 2, {"missing --output-dir"});
    expect_failure(files + " --output-dir x --rate abc", 2, {"--rate", "'abc'"});
    expect_failure(files + " --output-dir x --rate 50", 2, {"--rate '50'", "out of range"});
    expect_failure(files + " --output-dir x --mode rigid", 2, {"--mode", "'rigid'"});
    expect_failure(files + " --output-dir x --frobnicate 1", 2, {"--frobnicate"});
    expect_failure(files + " --output-dir x --duration", 2, {"--duration needs a value"});
    expect_failure("--basis no_such.mrt --session run_two_hips.csv --output-dir x", 1, {"no_such.mrt"});
    expect_failure(files + " --output-dir x --port 47000", 2, {"unknown option '--port'"}); // serve only

    // serve: its own rules, each with the status the README documents.
    const std::string serve = "serve --basis " + basis_path + " --output-dir x";
    const struct
    {
      std::string                         arguments;
      std::initializer_list<const char *> culprits;
    } serve_cases[] = {
      {serve + " --bind not-an-ip", {"--bind", "'not-an-ip'", "IPv4"}},
      {serve + " --port 70000", {"--port '70000'", "out of range"}},
      {serve + " --hips 17", {"--hips '17'", "out of range"}},
      {serve + " --session s.csv", {"unknown option '--session'"}},
      {serve + " --silence-ticks 1", {"unknown option '--silence-ticks'"}},
      {serve + " --hold -1", {"--hold '-1'", "out of range"}},
      {serve + " --ramp 0", {"--ramp '0'", "out of range"}},
      {serve + " --peer-timeout x", {"--peer-timeout", "'x'"}},
      {serve + " --contact glide", {"--contact", "'glide'", "snap or proxy"}},
      {serve + " --friction 0.2,0.3", {"--friction", "'0.2,0.3'", "0 <= MU_D <= MU_S <= 10"}},
      {serve + " --friction 0.3", {"--friction", "MU_S,MU_D"}},
      {"run --basis x.mrt --session s.csv --output-dir x --contact proxy", {"unknown option '--contact'"}},
      {"serve --output-dir x", {"missing --basis"}},
      {"frobnicate", {"usage"}},
    };
    for (const auto &c : serve_cases)
      {
        std::string out;
        const int   status = tool(c.arguments, out);
        ENSURE(status == 2);
        for (const char *culprit : c.culprits)
          ENSURE(contains(out, culprit));
        std::printf("  exit %d: %s", status, out.substr(0, out.find('\n') + 1).c_str());
      }

    // --help on every command: the usage on stdout, exit 0.
    for (const char *command : {"--help", "info --help", "verify --help", "run --help", "serve --help"})
      {
        std::string out;
        ENSURE(tool(command, out) == 0 && contains(out, "usage"));
      }
    std::string out;
    ENSURE(tool("--help", out) == 0 && contains(out, "modal-rt COMMAND --help"));
    // view too (not "unknown option '--help'", exit 2). A modal-rt built without
    // the view says so, exit 1, with --help as without.
#if MODAL_RT_HAS_VIEW
    ENSURE(tool("view --help", out) == 0 && contains(out, "usage") && contains(out, "--frame-rate HZ (60)"));
    ENSURE(tool("view --basis x.mrt --frobnicate", out) == 2 && contains(out, "unknown option '--frobnicate'"));
    ENSURE(tool("view --basis x.mrt --contact glide", out) == 2 && contains(out, "'glide' is not snap or proxy"));
    ENSURE(tool("view --basis x.mrt --friction 0.1,0.2", out) == 2 && contains(out, "0 <= MU_D <= MU_S <= 10"));
    ENSURE(tool("view --basis x.mrt --device phantom", out) == 2 && contains(out, "--device 'phantom' is not a device profile"));
    // An impedance profile on the mouse's admittance contact: refused once the basis is known, not a crash.
    ENSURE(tool("view --basis " + basis_path + " --device touch --port 0 --duration 1", out) == 1 &&
           contains(out, "device profile 'touch' is an impedance device"));
    ENSURE(tool("run --basis " + basis_path + " --session run_two_hips.csv --output-dir run_bad --profile bogus", out) == 1 &&
           contains(out, "no device profile 'bogus'"));
#else
    ENSURE(tool("view --help", out) == 1 && contains(out, "built without the view"));
#endif
    ENSURE(tool("run --help", out) == 0 && contains(out, "--session") && contains(out, "--hold S (0.5)"));
    ENSURE(tool("serve --help", out) == 0 && contains(out, "--peer-timeout S (1)") && !contains(out, "--session") &&
           contains(out, "--frame-rate HZ (0)"));
  }

  // serve's defaults cannot fill a disk: without --frame-rate it writes no frame.
  void serve_writes_no_frames_by_default()
  {
    std::string out;
    const int   port   = 20000 + int(getpid() % 20000) + 1;
    const int   status = tool("serve --basis " + basis_path + " --output-dir serve_default --duration 0.3 --quiet --no-plot "
                              "--port " + std::to_string(port), out);
    ENSURE(status == 0);
    const std::string stats = read_text("serve_default/stats.json");
    ENSURE(json_number(stats, "ticks") == 300);
    std::size_t frames = 0;
    for (const auto &entry : std::filesystem::directory_iterator("serve_default/frames"))
      frames += entry.path().extension() == ".vtu" ? 1 : 0;
    ENSURE(frames == 0);
  }

  void bad_session_files()
  {
    const std::string head = "time,hip,event,x,y,z\n0,0,target,0.1,0.02,0.02\n";
    const struct
    {
      const char *name, *text;
      std::initializer_list<const char *> culprits;
    } cases[] = {
      {"run_bad_row.csv", "0.5,0,target,0.1,0.02\n", {"run_bad_row.csv:3", "'z'"}},
      {"run_bad_fields.csv", "0.5,0,target,1,2,3,4\n", {"run_bad_fields.csv:3", "found 7"}},
      {"run_bad_nan.csv", "0.5,0,force,0,nan,0\n", {"run_bad_nan.csv:3", "'nan'", "not a finite number"}},
      {"run_bad_inf.csv", "0.5,0,target,0,0,1e999\n", {"run_bad_inf.csv:3", "'1e999'"}},
      {"run_bad_number.csv", "0.5,0,target,0,0.0.1,0\n", {"run_bad_number.csv:3", "'0.0.1'", "not a number"}},
      {"run_bad_event.csv", "# comment\n0.5,0,jump,0,0,0\n", {"run_bad_event.csv:4", "unknown event 'jump'"}},
      {"run_bad_time.csv", "0.5,0,target,0,0,0\n0.2,0,target,0,0,0\n", {"run_bad_time.csv:4", "time 0.2"}},
      {"run_bad_hip.csv", "0.5,x,target,0,0,0\n", {"run_bad_hip.csv:3", "hip 'x'"}},
      {"run_bad_target.csv", "0.5,1,force,0,0,-1\n", {"run_bad_target.csv", "HIP 1 has no 'target' row"}},
      {"run_bad_proxy_time.csv", "0.5,-,proxy,0.3,0.2\n", {"run_bad_proxy_time.csv:3", "its time must be 0"}},
      {"run_bad_proxy_twice.csv", "0,-,proxy\n0,-,proxy\n", {"run_bad_proxy_twice.csv:4", "a second 'proxy' row"}},
      {"run_bad_proxy_mu.csv", "0,-,proxy,0.2,0.3\n", {"run_bad_proxy_mu.csv:3", "mu_s 0.2, mu_d 0.3"}},
      {"run_bad_proxy_hip.csv", "0,1,proxy,0.3,0.2\n", {"run_bad_proxy_hip.csv:3", "belongs to no HIP"}},
    };
    for (const auto &c : cases)
      {
        write_text(c.name, head + c.text);
        expect_failure("--basis " + basis_path + " --session " + c.name + " --output-dir x", 1, c.culprits);
        std::remove(c.name);
      }
    write_text("run_bad_header.csv", "t,hip,event\n");
    expect_failure("--basis " + basis_path + " --session run_bad_header.csv --output-dir x", 1,
                   {"run_bad_header.csv:1", "header"});
    expect_failure("--basis " + basis_path + " --session no_such_session.csv --output-dir x", 1,
                   {"no_such_session.csv", "cannot open"});
  }
} // namespace

int main()
{
  const modalrt::BasisContent content = modalrt::make_lattice_cantilever(lattice());
  ENSURE(modalrt::write_basis_file(basis_path, content));
  impedance_session();
  admittance_static_response(content);
  stop_on_sigint();
  multi_contact_full_fe();
  slides();
  slides_against_validity();
  validity();
  bad_command_lines();
  serve_writes_no_frames_by_default();
  bad_session_files();
  return test::finish("test_run");
}
