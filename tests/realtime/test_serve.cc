// modal-rt serve, the UDP bridge, on loopback with a synthetic basis. A client (this test) presses
// the lattice's tip through the bridge, then a second sender, an old sequence number and malformed
// packets arrive (ignored and counted), then the client falls silent: from the first tick without a
// fresh state every command carries zero force and the SILENT flag. Packets are encoded here from
// the layout documented in realtime/README.md, not with the tool's code. Nothing is asserted on timing.
#include "test_support.h"

#include <arpa/inet.h>
#include <chrono>
#include <csignal>
#include <cstring>
#include <fcntl.h>
#include <fstream>
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
  std::vector<unsigned char> state_packet(std::uint32_t sequence, const double position[3], double nan_at = 0)
  {
    std::vector<unsigned char> p(16 + 72, 0);
    std::memcpy(p.data(), "MRTS", 4);
    const std::uint16_t version = 1, hips = 1;
    std::memcpy(&p[4], &version, 2);
    std::memcpy(&p[6], &hips, 2);
    std::memcpy(&p[8], &sequence, 4);
    std::memcpy(&p[16], position, 24);
    if (nan_at != 0)
      {
        const double nan = std::nan("");
        std::memcpy(&p[16 + 48], &nan, 8);
      }
    return p;
  }

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
  const std::uint32_t last = sequence;

  // Ignored and counted: another sender, an old sequence number, a short and a non-finite packet.
  send_to(stranger, server, state_packet(last + 100, x));
  send_to(client, server, state_packet(last - 5, x));
  send_to(client, server, std::vector<unsigned char>(10, 0));
  send_to(client, server, state_packet(last + 1, x, 1.0));
  for (int k = 0; k < 400; ++k)
    {
      std::this_thread::sleep_for(std::chrono::microseconds(500));
      drain(client, replies);
    }
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

  const std::string stats = read_text("serve_out/stats.json");
  ENSURE(json_number(stats, "foreign_packets") == 1);
  ENSURE(json_number(stats, "stale_packets") == 1);
  ENSURE(json_number(stats, "bad_packets") == 2);
  ENSURE(json_number(stats, "states_accepted") >= 800);
  ENSURE(json_number(stats, "silent_ticks") > 0);
  ENSURE(json_number(stats, "allocations_after_start") == 0);
  ENSURE(json_number(stats, "non_finite_outputs") == 0);
  ENSURE(read_text("serve_out/stats.json").find("\"stopped_by\": \"signal\"") != std::string::npos);
  close(client);
  close(stranger);
  return test::finish("test_serve");
}
