// modal-rt serve, the UDP bridge, on loopback with a synthetic basis. A client (this test) presses
// the lattice's tip through the bridge; while pressing, its HIP teleports 1 m into the part (the
// force stays within the device's limit), packets arrive out of order, twice, or with an infinite
// position; then a second sender, an old sequence number and malformed packets arrive (all ignored
// and counted), then the client falls silent: from the first tick without a fresh state every
// command carries zero force and the SILENT flag, and the commands keep coming at the loop's rate.
// Packets are encoded here from the layout documented in realtime/README.md, not with the tool's
// code. The only timing asserted is that rate, within a factor of 2.
#include "test_support.h"

#include <algorithm>
#include <arpa/inet.h>
#include <chrono>
#include <csignal>
#include <cstring>
#include <fcntl.h>
#include <fstream>
#include <limits>
#include <netinet/in.h>
#include <sstream>
#include <sys/socket.h>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>

namespace
{
  struct Reply
  {
    std::uint32_t sequence, flags;
    std::uint64_t tick;
    double        force[3];
    std::uint32_t in_contact;
  };

  std::string read_text(const std::string &path)
  {
    std::ifstream     file(path);
    std::stringstream text;
    text << file.rdbuf();
    return text.str();
  }

  double json_number(const std::string &json, const std::string &key)
  {
    const std::size_t at = json.find("\"" + key + "\": ");
    return at == std::string::npos ? std::nan("") : std::strtod(json.c_str() + at + key.size() + 4, nullptr);
  }

  int udp_socket()
  {
    const int   s = socket(AF_INET, SOCK_DGRAM, 0);
    sockaddr_in any{};
    any.sin_family      = AF_INET;
    any.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    bind(s, reinterpret_cast<sockaddr *>(&any), sizeof any);
    fcntl(s, F_SETFL, O_NONBLOCK);
    return s;
  }

  // A state packet for one HIP: "MRTS", u16 version 1, u16 HIP count, u32 sequence, u32 0, then
  // position, velocity, force as f64 (little endian).
  std::vector<unsigned char> state_packet(std::uint32_t sequence, const double position[3])
  {
    std::vector<unsigned char> p(16 + 72, 0);
    std::memcpy(p.data(), "MRTS", 4);
    const std::uint16_t version = 1, hips = 1;
    std::memcpy(&p[4], &version, 2);
    std::memcpy(&p[6], &hips, 2);
    std::memcpy(&p[8], &sequence, 4);
    std::memcpy(&p[16], position, 24);
    return p;
  }

  // The packet with its k-th number (0..8: position, velocity, force) replaced by `value`.
  std::vector<unsigned char> with_number(std::vector<unsigned char> packet, int k, double value)
  {
    std::memcpy(&packet[16 + 8 * k], &value, 8);
    return packet;
  }

  double norm(const double f[3]) { return std::sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]); }

  void send_to(int s, const sockaddr_in &to, const std::vector<unsigned char> &packet)
  {
    sendto(s, packet.data(), packet.size(), 0, reinterpret_cast<const sockaddr *>(&to), sizeof to);
  }

  // Every command waiting on the socket: "MRTC", u16, u16, u32 sequence, u32 flags, u64 tick, then
  // per HIP force[3], position[3], velocity[3] f64, in_contact, vertex, space, 0 u32.
  void drain(int s, std::vector<Reply> &replies)
  {
    unsigned char buffer[512];
    for (;;)
      {
        const ssize_t size = recv(s, buffer, sizeof buffer, 0);
        if (size < 0)
          return;
        if (size != 24 + 88 || std::memcmp(buffer, "MRTC", 4) != 0)
          {
            test::report(false, __FILE__, __LINE__, "malformed command packet");
            continue;
          }
        Reply r;
        std::memcpy(&r.sequence, buffer + 8, 4);
        std::memcpy(&r.flags, buffer + 12, 4);
        std::memcpy(&r.tick, buffer + 16, 8);
        std::memcpy(r.force, buffer + 24, 24);
        std::memcpy(&r.in_contact, buffer + 24 + 72, 4);
        replies.push_back(r);
      }
  }

  pid_t start_bridge(int port)
  {
    const pid_t child = fork();
    if (child == 0)
      {
        const int out = open("serve_output.txt", O_WRONLY | O_CREAT | O_TRUNC, 0644);
        dup2(out, 1);
        dup2(out, 2);
        const std::string p = std::to_string(port);
        execl(MODAL_RT_PROGRAM, MODAL_RT_PROGRAM, "serve", "--basis", "serve_lattice.mrt", "--output-dir", "serve_out",
              "--port", p.c_str(), "--duration", "120", "--frame-rate", "2", static_cast<char *>(nullptr));
        _exit(127);
      }
    return child;
  }
} // namespace

int main()
{
  modalrt::LatticeOptions o;
  o.patch_radius = 0.03;
  o.damping      = {0.7, 0.7};
  ENSURE(modalrt::write_basis_file("serve_lattice.mrt", modalrt::make_lattice_cantilever(o)));
  const int   port   = 20000 + int(getpid() % 20000);
  const pid_t bridge = start_bridge(port);

  sockaddr_in server{};
  server.sin_family      = AF_INET;
  server.sin_port        = htons(std::uint16_t(port));
  server.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  const int          client = udp_socket(), stranger = udp_socket();
  std::vector<Reply> replies;

  // Hover above the tip until the bridge answers, then press 2 mm into the top face (z = 0.01 m).
  std::uint32_t sequence = 0;
  double        x[3]     = {0.125, 0.025, 0.015};
  for (int k = 0; k < 20000 && replies.empty(); ++k)
    {
      send_to(client, server, state_packet(++sequence, x));
      std::this_thread::sleep_for(std::chrono::microseconds(500));
      drain(client, replies);
    }
  ENSURE(!replies.empty());
  for (int k = 0; k <= 800; ++k)
    {
      x[2] = 0.015 - 0.007 * std::min(1.0, k / 400.0);
      send_to(client, server, state_packet(++sequence, x));
      std::this_thread::sleep_for(std::chrono::microseconds(500));
      drain(client, replies);
    }
  auto hold = [&](const double *at, int packets) {
    for (int k = 0; k < packets; ++k)
      {
        send_to(client, server, state_packet(++sequence, at));
        std::this_thread::sleep_for(std::chrono::microseconds(500));
        drain(client, replies);
      }
  };

  // Faults while pressing. The HIP teleports 1 m into the part: the force felt must stay within the
  // device's limit from the first tick that sees it. Then, back on the surface, packets arrive out
  // of order and twice (both stale: ignored and counted), and one with an infinite position (bad).
  const double        deep[3] = {x[0], x[1], x[2] - 1.0};
  const std::uint32_t teleport_first = sequence + 1;
  hold(deep, 40);
  const std::uint32_t teleport_last = sequence;
  hold(x, 100);
  send_to(client, server, state_packet(sequence + 2, x));
  send_to(client, server, state_packet(sequence + 1, deep)); // older than the packet before it
  send_to(client, server, state_packet(sequence + 2, deep)); // the same number again
  sequence += 2;
  send_to(client, server, with_number(state_packet(++sequence, x), 0, std::numeric_limits<double>::infinity()));
  hold(x, 100);
  const std::uint32_t last = sequence;

  // Ignored and counted: another sender, an old sequence number, a short and a non-finite packet.
  send_to(stranger, server, state_packet(last + 100, x));
  send_to(client, server, state_packet(last - 5, x));
  send_to(client, server, std::vector<unsigned char>(10, 0));
  send_to(client, server, with_number(state_packet(last + 1, x), 8, std::nan("")));
  // The client falls silent (a device unplugged mid-press): the loop must keep its rate.
  const auto silence_start = std::chrono::steady_clock::now();
  for (int k = 0; k < 400; ++k)
    {
      std::this_thread::sleep_for(std::chrono::microseconds(500));
      drain(client, replies);
    }
  const double silence_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - silence_start).count();
  kill(bridge, SIGINT);
  int status = 0;
  waitpid(bridge, &status, 0);
  std::printf("%s", read_text("serve_output.txt").c_str());
  ENSURE(WIFEXITED(status) && WEXITSTATUS(status) == 0);

  // The tick that took the last state pressed; every later tick is silent with zero force, from the
  // very next tick on.
  const Reply *fresh = nullptr, *first_silent = nullptr;
  bool         all_zero = true;
  for (const Reply &r : replies)
    if (r.sequence == last && !(r.flags & 1u) && !fresh)
      fresh = &r;
    else if (fresh && r.tick > fresh->tick)
      {
        all_zero = all_zero && (r.flags & 1u) && r.force[0] == 0.0 && r.force[1] == 0.0 && r.force[2] == 0.0;
        if (!first_silent)
          first_silent = &r;
      }
  ENSURE(fresh && fresh->in_contact == 1 && fresh->force[2] > 0.0);
  ENSURE(first_silent && fresh && first_silent->tick == fresh->tick + 1);
  ENSURE(all_zero);
  // Silent commands kept coming at the loop's rate (1 kHz; half of it allows for a loaded machine).
  const std::size_t silent = std::size_t(std::count_if(replies.begin(), replies.end(), [](const Reply &r) { return r.flags & 1u; }));
  ENSURE(double(silent) >= 0.5 * 1000.0 * silence_seconds);

  // Teleported 1 m deep: every force finite and within the device's limit, the limit reached.
  const double max_force = modalrt_device_default_def().max_force;
  double       teleport_force = 0.0;
  bool         teleport_seen = false, within_limit = true;
  for (const Reply &r : replies)
    {
      within_limit = within_limit && std::isfinite(norm(r.force)) && norm(r.force) <= max_force * (1.0 + 1e-12);
      if (r.sequence >= teleport_first && r.sequence <= teleport_last)
        teleport_seen = true, teleport_force = std::max(teleport_force, norm(r.force));
    }
  ENSURE(teleport_seen && within_limit);
  ENSURE_RELATIVE(teleport_force, max_force, 1e-12);

  const std::string stats = read_text("serve_out/stats.json");
  ENSURE(json_number(stats, "foreign_packets") == 1);
  ENSURE(json_number(stats, "stale_packets") == 3);
  ENSURE(json_number(stats, "bad_packets") == 3);
  ENSURE(json_number(stats, "clamped_forces") > 0);
  ENSURE(json_number(stats, "states_accepted") >= 800);
  ENSURE(json_number(stats, "silent_ticks") > 0);
  ENSURE(json_number(stats, "allocations_after_start") == 0);
  ENSURE(json_number(stats, "non_finite_outputs") == 0);
  ENSURE(read_text("serve_out/stats.json").find("\"stopped_by\": \"signal\"") != std::string::npos);
  close(client);
  close(stranger);
  return test::finish("test_serve");
}
