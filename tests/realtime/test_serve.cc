// modal-rt serve, the UDP bridge, on loopback with a synthetic basis. Packets are encoded here from
// the layout documented in realtime/README.md (protocol version 3), not with the tool's code. The
// bridge writes its token to serve_token.txt (mode 0600, removed at exit); the client reads it there.
//   1. A client says HELLO and presses the lattice's tip; while pressing, its HIP teleports 1 m into
//      the part (the force stays within the device's limit), packets arrive out of order, twice,
//      with an infinite position or with an unknown flag bit (ignored and counted).
//   2. Lock-outs that must not happen: a packet 2^31 - 1 ahead is stale, not adopted (the next
//      ordinary packet is accepted); a counter restarted at 0 with HELLO is accepted at once.
//      Restarts: the counter restarted mid-press on the same port without HELLO is
//      recognized after 3 packets; a driver restarted on a new port 20 ms after its last state,
//      HELLO once then one state per tick (the README's minimal client), is served within 0.1 s.
//      Each is a new session: the contact is released, its force ramps to zero at the kernel's rate
//      limit (no step), no command has zero force in contact.
//   3. A sender without the token (HELLO and states, while the device presses) gets BAD_TOKEN
//      refusals and is never served; the device's contact goes on untouched. A second device with
//      the token gets REFUSED echoing its sequence number; an old client (a version 2 HELLO, no
//      token) gets BAD_VERSION.
//   4. The client falls silent mid-press: every command from the next tick on carries the FAIL_SAFE
//      flag; the force is held, then ramps down to zero without a step; commands keep coming at the
//      loop's rate until the peer timeout (1 s) frees the slot. A sender without the token says HELLO
//      during the silence and after it (the slot free): refused each time, never served.
//   5. The second device (a restart on another port) then takes the slot (no contact carried over
//      from the client's press), leaves with BYE, and the first client comes back with a counter
//      restarted at 0 without HELLO: accepted (slot free), its first command not in contact.
//   6. A bridge with sliding contacts (--contact proxy): the command's position is the proxy's, its
//      HIP flags say SLIDING while it slides, the friction force is mu_d times the normal one.
//   7. A bridge on a basis with a validity map: the HIP flags say BEYOND_VALIDITY (256) exactly while
//      the commanded force exceeds the contact's validity force.
// The only timing asserted is the command rate, within a factor of 2, and the takeover's promptness.
#include "test_support.h"

#include <algorithm>
#include <array>
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
#include <sys/stat.h>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>

namespace
{
  using test::json_number;
  using test::read_text;

  constexpr std::uint32_t fail_safe_flag = 1u, refused_flag = 2u, bad_version_flag = 4u, bad_token_flag = 8u;
  constexpr std::uint32_t hello = 1u, bye = 2u;
  constexpr std::uint32_t ramping_flag = 64u, released_flag = 2u, contact_started_flag = 1u;

  struct Reply
  {
    std::size_t   size;
    std::uint16_t version, hips;
    std::uint32_t sequence, flags;
    std::uint64_t tick;
    double        force[3], position[3];
    std::uint32_t in_contact, hip_flags;
    std::uint32_t client; // which socket received it (0 the client, 1 its restart on a new port)
  };

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

  using Token = std::array<unsigned char, 16>;
  Token bridge_token{}; // the token of the bridge being driven: read from its token file or given by --token

  // A state packet for one HIP: "MRTS", u16 version 3, u16 HIP count, u32 sequence, u32 flags, the
  // 16-byte token, then position, velocity, force as f64 (little endian).
  std::vector<unsigned char> state_packet(std::uint32_t sequence, const double position[3], std::uint32_t flags = 0,
                                          const Token &token = bridge_token)
  {
    std::vector<unsigned char> p(32 + 72, 0);
    std::memcpy(p.data(), "MRTS", 4);
    const std::uint16_t version = 3, hips = 1;
    std::memcpy(&p[4], &version, 2);
    std::memcpy(&p[6], &hips, 2);
    std::memcpy(&p[8], &sequence, 4);
    std::memcpy(&p[12], &flags, 4);
    std::memcpy(&p[16], token.data(), 16);
    std::memcpy(&p[32], position, 24);
    return p;
  }

  // A client of protocol version 2 (no token): "MRTS", u16 2, u16 HIP count, u32 sequence, u32 flags,
  // then the HIP's numbers.
  std::vector<unsigned char> old_state_packet(std::uint32_t sequence, const double position[3], std::uint32_t flags)
  {
    std::vector<unsigned char> p(16 + 72, 0);
    std::memcpy(p.data(), "MRTS", 4);
    const std::uint16_t version = 2, hips = 1;
    std::memcpy(&p[4], &version, 2);
    std::memcpy(&p[6], &hips, 2);
    std::memcpy(&p[8], &sequence, 4);
    std::memcpy(&p[12], &flags, 4);
    std::memcpy(&p[16], position, 24);
    return p;
  }

  // The packet with its k-th number (0..8: position, velocity, force) replaced by `value`.
  std::vector<unsigned char> with_number(std::vector<unsigned char> packet, int k, double value)
  {
    std::memcpy(&packet[32 + 8 * k], &value, 8);
    return packet;
  }

  // 32 hexadecimal digits as the token's bytes (false: not a token).
  bool parse_hex(const std::string &hex, Token &token)
  {
    if (hex.size() < 32)
      return false;
    for (std::size_t k = 0; k < 16; ++k)
      {
        unsigned value = 0;
        if (std::sscanf(hex.c_str() + 2 * k, "%2x", &value) != 1)
          return false;
        token[k] = static_cast<unsigned char>(value);
      }
    return true;
  }

  // The token the bridge wrote to `path` when it started: the file must appear (mode 0600, only
  // its user may read it) holding 32 hexadecimal digits.
  Token read_token_file(const std::string &path)
  {
    Token       token{};
    struct stat status{};
    for (int k = 0; k < 4000 && stat(path.c_str(), &status) != 0; ++k)
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    ENSURE((status.st_mode & 0777) == 0600);
    ENSURE(parse_hex(read_text(path), token));
    return token;
  }

  double norm(const double f[3]) { return std::sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]); }

  void send_to(int s, const sockaddr_in &to, const std::vector<unsigned char> &packet)
  {
    sendto(s, packet.data(), packet.size(), 0, reinterpret_cast<const sockaddr *>(&to), sizeof to);
  }

  // Every packet waiting on the socket: "MRTC", u16 version, u16 n, u32 sequence, u32 flags, u64
  // tick, then per HIP force[3], position[3], velocity[3] f64, in_contact, vertex, space, flags u32.
  // A refusal has n = 0 (24 bytes).
  void drain(int s, std::vector<Reply> &replies, std::uint32_t client = 0)
  {
    unsigned char buffer[512];
    for (;;)
      {
        const ssize_t size = recv(s, buffer, sizeof buffer, 0);
        if (size < 0)
          return;
        Reply r{};
        r.size   = std::size_t(size);
        r.client = client;
        if (size < 24 || std::memcmp(buffer, "MRTC", 4) != 0)
          {
            test::report(false, __FILE__, __LINE__, "malformed command packet");
            continue;
          }
        std::memcpy(&r.version, buffer + 4, 2);
        std::memcpy(&r.hips, buffer + 6, 2);
        std::memcpy(&r.sequence, buffer + 8, 4);
        std::memcpy(&r.flags, buffer + 12, 4);
        std::memcpy(&r.tick, buffer + 16, 8);
        if (r.size != 24 + 88 * std::size_t(r.hips) || r.version != 3)
          {
            test::report(false, __FILE__, __LINE__, "command packet of the wrong size or version");
            continue;
          }
        if (r.hips == 1)
          {
            std::memcpy(r.force, buffer + 24, 24);
            std::memcpy(r.position, buffer + 24 + 24, 24);
            std::memcpy(&r.in_contact, buffer + 24 + 72, 4);
            std::memcpy(&r.hip_flags, buffer + 24 + 84, 4);
          }
        replies.push_back(r);
      }
  }

  // The bridge on `port` serving `basis`, its outputs in serve_out<suffix> and its log in
  // serve_output<suffix>.txt, with the `extra` options.
  pid_t start_bridge(int port, const std::string &suffix = "", const std::vector<std::string> &extra = {"--frame-rate", "2"},
                     const std::string &basis = "serve_lattice.mrt")
  {
    std::vector<std::string> arguments = {MODAL_RT_PROGRAM, "serve", "--basis", basis, "--output-dir",
                                          "serve_out" + suffix, "--port", std::to_string(port), "--duration", "120"};
    arguments.insert(arguments.end(), extra.begin(), extra.end());
    const pid_t child = fork();
    if (child == 0)
      {
        const int out = open(("serve_output" + suffix + ".txt").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
        dup2(out, 1);
        dup2(out, 2);
        std::vector<char *> argv;
        for (std::string &a : arguments)
          argv.push_back(a.data());
        argv.push_back(nullptr);
        execv(MODAL_RT_PROGRAM, argv.data());
        _exit(127);
      }
    return child;
  }

  void pause_and_drain(int s, std::vector<Reply> &replies, int microseconds, std::uint32_t client = 0)
  {
    std::this_thread::sleep_for(std::chrono::microseconds(microseconds));
    drain(s, replies, client);
  }

  // The scenarios after the main one do not test the peer timeout: a longer one keeps a client that a
  // loaded machine (the sanitizer builds beside other tests) stalls for a second in the same session.
  const char *const scenario_peer_timeout = "5";

  // A client of the bridge on loopback `port`: HELLO at x (sequence numbers from `sequence` on) every
  // 0.5 ms until the first command comes.
  struct Greeted
  {
    sockaddr_in        server{};
    int                socket = -1;
    std::vector<Reply> replies;
    std::uint32_t      sequence = 0;
  };
  Greeted greet(int port, std::uint32_t sequence, const double x[3])
  {
    Greeted g;
    g.server.sin_family      = AF_INET;
    g.server.sin_port        = htons(std::uint16_t(port));
    g.server.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    g.socket                 = udp_socket();
    g.sequence               = sequence;
    for (int k = 0; k < 20000 && g.replies.empty(); ++k)
      {
        send_to(g.socket, g.server, state_packet(++g.sequence, x, hello));
        pause_and_drain(g.socket, g.replies, 500);
      }
    ENSURE(!g.replies.empty());
    return g;
  }

  // The client says BYE at x; the bridge is stopped with SIGINT and must exit 0.
  void leave_and_stop(Greeted &g, const double x[3], pid_t bridge)
  {
    send_to(g.socket, g.server, state_packet(++g.sequence, x, bye));
    kill(bridge, SIGINT);
    int status = 0;
    waitpid(bridge, &status, 0);
    ENSURE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  }

  // The largest change of force between consecutive commands of replies[from, to) (both in the
  // same session's ticks), and how many were in contact with zero force.
  struct Steps
  {
    double      largest = 0.0;
    std::size_t zero_in_contact = 0;
  };
  Steps force_steps(const std::vector<Reply> &replies, std::size_t from, std::size_t to)
  {
    Steps s;
    for (std::size_t k = from; k < to; ++k)
      {
        const Reply &r = replies[k];
        if (r.hips != 1)
          continue;
        if (r.in_contact && r.force[0] == 0.0 && r.force[1] == 0.0 && r.force[2] == 0.0)
          ++s.zero_in_contact;
        if (k > from && replies[k - 1].hips == 1 && r.tick == replies[k - 1].tick + 1)
          {
            const double d[3] = {r.force[0] - replies[k - 1].force[0], r.force[1] - replies[k - 1].force[1],
                                 r.force[2] - replies[k - 1].force[2]};
            s.largest = std::max(s.largest, std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]));
          }
      }
    return s;
  }
  // The client side of the test: the client's socket (and the socket of its restart on a new port),
  // a second device, every command received, the client's sequence counter and HIP position.
  struct Clients
  {
    sockaddr_in        server{};
    int                client = udp_socket(), restarted = udp_socket(), stranger = udp_socket();
    std::vector<Reply> replies, stranger_replies;
    std::uint32_t      sequence = 1000;
    double             x[3]     = {0.125, 0.025, 0.015};

    // `packets` states at `at`, one every 0.5 ms, reading the commands in between.
    void hold(const double *at, int packets)
    {
      for (int k = 0; k < packets; ++k)
        {
          send_to(client, server, state_packet(++sequence, at));
          pause_and_drain(client, replies, 500);
        }
    }
    // Out of the surface and in again (a released HIP snaps only once it has left the surface).
    void press_again()
    {
      for (int k = 0; k <= 500; ++k)
        {
          const double depth = k < 100 ? 0.0 : 0.007 * std::min(1.0, (k - 100) / 300.0);
          const double at[3] = {x[0], x[1], 0.015 - depth};
          send_to(client, server, state_packet(++sequence, at));
          pause_and_drain(client, replies, 500);
        }
      ENSURE(!replies.empty() && replies.back().in_contact == 1);
    }
  };

  struct Teleport
  {
    std::uint32_t first, last; // sequence numbers of the states 1 m deep
  };

  // 1. HELLO, hover above the tip until the bridge answers, press 7 mm down onto the top face, then
  // faults while pressing. The HIP teleports 1 m into the part: the force felt must stay within the
  // device's limit from the first tick that sees it. Then, back on the surface, packets arrive out
  // of order and twice (both stale), one with an infinite position and one with an unknown flag bit
  // (both bad).
  Teleport press_with_faults(Clients &c)
  {
    for (int k = 0; k < 20000 && c.replies.empty(); ++k) // HELLO until the bridge, starting, answers
      {
        send_to(c.client, c.server, state_packet(++c.sequence, c.x, hello));
        pause_and_drain(c.client, c.replies, 500);
      }
    ENSURE(!c.replies.empty());
    for (int k = 0; k <= 800; ++k)
      {
        c.x[2] = 0.015 - 0.007 * std::min(1.0, k / 400.0);
        send_to(c.client, c.server, state_packet(++c.sequence, c.x));
        pause_and_drain(c.client, c.replies, 500);
      }
    const double deep[3] = {c.x[0], c.x[1], c.x[2] - 1.0};
    Teleport     t{c.sequence + 1, 0};
    c.hold(deep, 120); // long enough for the limit to be reached even after a late packet (the force
                       // then comes back at the kernel's rate limit, 0.2 N per tick)
    t.last = c.sequence;
    c.hold(c.x, 100);
    send_to(c.client, c.server, state_packet(c.sequence + 2, c.x));
    send_to(c.client, c.server, state_packet(c.sequence + 1, deep)); // older than the packet before it
    send_to(c.client, c.server, state_packet(c.sequence + 2, deep)); // the same number again
    c.sequence += 2;
    send_to(c.client, c.server,
            with_number(state_packet(++c.sequence, c.x), 0, std::numeric_limits<double>::infinity()));
    send_to(c.client, c.server, state_packet(++c.sequence, c.x, 1u << 7)); // a reserved flag bit
    c.hold(c.x, 50);
    // 2. No lock-out: a packet 2^31 - 1 ahead is stale (a "newer than the last" rule would have
    // adopted it and ignored the device for 24.8 days); the next ordinary packet is accepted.
    send_to(c.client, c.server, state_packet(c.sequence + 0x7FFFFFFFu, deep));
    c.hold(c.x, 50);
    return t;
  }

  // A device that restarts its counter at 0 says HELLO: accepted at once, a new session (released).
  // Then it restarts its counter mid-press on the same port, without HELLO: 3 consecutive numbers
  // outside the window are a restart (a new session), not 450 zero-force commands in contact.
  void restart_counter(Clients &c)
  {
    const std::size_t before_hello = c.replies.size();
    c.sequence                     = 0;
    send_to(c.client, c.server, state_packet(c.sequence, c.x, hello));
    c.hold(c.x, 100);
    bool hello_released = false;
    for (std::size_t k = before_hello; k < c.replies.size(); ++k)
      hello_released = hello_released || (c.replies[k].sequence <= 100 && c.replies[k].in_contact == 0 && c.replies[k].hips == 1);
    ENSURE(hello_released);
    c.press_again();

    const std::size_t before_restart = c.replies.size();
    c.sequence                       = 5;
    c.hold(c.x, 100);
    const Steps same_port    = force_steps(c.replies, before_restart, c.replies.size());
    bool        restart_seen = false, restart_released = false;
    for (std::size_t k = before_restart; k < c.replies.size(); ++k)
      if (c.replies[k].hips == 1 && c.replies[k].sequence <= 106 && c.replies[k].sequence >= 6)
        restart_seen = true, restart_released = restart_released || (c.replies[k].in_contact == 0);
    ENSURE(restart_seen && restart_released);
    ENSURE(same_port.zero_in_contact == 0);
    std::printf("counter restart on the same port: largest force step %.4f N, %zu zero-force commands in contact\n",
                same_port.largest, same_port.zero_in_contact);
    c.press_again();
  }

  // The driver restarts on a new port (a new socket) 20 ms after its last state and says HELLO once,
  // then one state per 0.5 ms (the README's minimal client): served at once (it used to be refused
  // for 0.98 s, until the peer timeout), released, the force ramping down without a step, never
  // zero in contact. The restarted driver is the client from here on.
  void restart_on_new_port(Clients &c)
  {
    drain(c.client, c.replies);
    const std::size_t before = c.replies.size();
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    drain(c.client, c.replies);
    const auto start = std::chrono::steady_clock::now();
    c.sequence       = 1;
    send_to(c.restarted, c.server, state_packet(c.sequence, c.x, hello));
    double served_after = -1.0;
    for (int k = 0; k < 200; ++k)
      {
        send_to(c.restarted, c.server, state_packet(++c.sequence, c.x));
        pause_and_drain(c.restarted, c.replies, 500, 1);
        for (std::size_t j = before; j < c.replies.size() && served_after < 0.0; ++j)
          if (c.replies[j].client == 1 && c.replies[j].hips == 1)
            served_after = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      }
    std::size_t refusals = 0, first_new = c.replies.size();
    for (std::size_t j = before; j < c.replies.size(); ++j)
      {
        refusals += c.replies[j].client == 1 && c.replies[j].hips == 0 ? 1 : 0;
        if (c.replies[j].client == 1 && c.replies[j].hips == 1 && first_new == c.replies.size())
          first_new = j;
      }
    ENSURE(served_after >= 0.0 && served_after < 0.1);
    ENSURE(refusals == 0);
    ENSURE(first_new < c.replies.size() && c.replies[first_new].in_contact == 0 &&
           !(c.replies[first_new].hip_flags & contact_started_flag));
    const Steps steps = force_steps(c.replies, first_new, c.replies.size());
    ENSURE(steps.zero_in_contact == 0);
    std::printf("restart on a new port 20 ms later, HELLO once: served after %.1f ms, %zu refusals, largest force "
                "step %.4f N, %zu zero-force commands in contact\n",
                1e3 * served_after, refusals, steps.largest, steps.zero_in_contact);
    std::swap(c.client, c.restarted);
    c.press_again();
  }

  // Another token than the bridge's: what a local process of another user (or one on the network)
  // sends without having read the token file.
  Token guessed_token()
  {
    Token t = bridge_token;
    t[15] ^= 1u; // one bit off: a byte-by-byte comparison would reach the last byte
    return t;
  }

  // Every reply to a sender without the token is a BAD_TOKEN refusal echoing its sequence number;
  // returns how many there were.
  std::size_t check_intruder_refused(const std::vector<Reply> &replies, std::uint32_t first, std::uint32_t last)
  {
    for (const Reply &r : replies)
      ENSURE(r.hips == 0 && r.flags == bad_token_flag && r.sequence >= first && r.sequence <= last);
    return replies.size();
  }

  // 3. A sender without the token, while the device presses: HELLO (which, with the token, would
  // take the slot over) and ordinary states, interleaved with the device's. Each is refused with
  // BAD_TOKEN; the device goes on pressing, every command to it in contact, none released.
  std::size_t intruder_while_pressing(Clients &c)
  {
    const int         intruder = udp_socket();
    std::vector<Reply> intruder_replies;
    const std::size_t before = c.replies.size();
    for (std::uint32_t k = 0; k < 200; ++k)
      {
        send_to(c.client, c.server, state_packet(++c.sequence, c.x));
        send_to(intruder, c.server, state_packet(500 + k, c.x, k % 10 == 0 ? hello : 0u, guessed_token()));
        pause_and_drain(c.client, c.replies, 500);
        drain(intruder, intruder_replies);
      }
    c.hold(c.x, 20);
    drain(intruder, intruder_replies);
    close(intruder);
    const std::size_t refused = check_intruder_refused(intruder_replies, 500, 699);
    std::size_t       served  = 0, released = 0;
    for (std::size_t k = before; k < c.replies.size(); ++k)
      if (c.replies[k].hips == 1)
        ++served, released += c.replies[k].in_contact == 1 && !(c.replies[k].hip_flags & released_flag) ? 0 : 1;
    std::printf("a sender without the token while the device presses: %zu of 200 packets answered BAD_TOKEN; the "
                "device got %zu commands, %zu of them out of contact or released\n",
                refused, served, released);
    ENSURE(refused >= 150); // loopback may drop a few under load, never serve one
    ENSURE(served >= 100 && released == 0);
    return refused;
  }

  // 3. A second device (with the token) is refused with a packet saying so; an old client (a version
  // 2 HELLO, no token) gets BAD_VERSION. A refusal echoes the refused packet's sequence number and
  // carries the bridge's tick count and version (3), whatever the refused packet's version.
  void refusals(Clients &c)
  {
    send_to(c.stranger, c.server, state_packet(7, c.x));
    send_to(c.stranger, c.server, old_state_packet(8, c.x, hello));
    for (int k = 0; k < 20; ++k)
      pause_and_drain(c.stranger, c.stranger_replies, 500);
    const std::vector<Reply> &r = c.stranger_replies;
    ENSURE(r.size() == 2);
    if (r.size() != 2)
      return;
    ENSURE(r[0].hips == 0 && r[0].flags == refused_flag);
    ENSURE(r[1].hips == 0 && r[1].flags == bad_version_flag);
    ENSURE(r[0].sequence == 7 && r[1].sequence == 8);
    ENSURE(r[0].tick > 1000 && r[1].tick >= r[0].tick);
  }

  // A sender without the token says HELLO `count` times, one every 0.5 ms: each refused with
  // BAD_TOKEN, none served (while the device is silent, and once the slot is free).
  std::size_t intruder_hellos(const sockaddr_in &server, const double x[3], std::uint32_t first, int count)
  {
    const int          intruder = udp_socket();
    std::vector<Reply> replies;
    for (int k = 0; k < count; ++k)
      {
        send_to(intruder, server, state_packet(first + std::uint32_t(k), x, hello, guessed_token()));
        pause_and_drain(intruder, replies, 500);
      }
    pause_and_drain(intruder, replies, 5000);
    close(intruder);
    const std::size_t refused = check_intruder_refused(replies, first, first + std::uint32_t(count) - 1);
    ENSURE(refused >= std::size_t(count) * 3 / 4);
    return refused;
  }

  // 5. The second device takes the free slot (a device restarted on another port), not in contact at
  // the client's pressed position, then leaves with BYE; the first comes back with its counter
  // restarted at 0 and no HELLO: accepted, the slot being free, its first command without contact
  // (not still in contact at the first device's vertex).
  void second_device_then_return(Clients &c)
  {
    c.stranger_replies.clear();
    for (int k = 0; k < 100; ++k)
      {
        send_to(c.stranger, c.server, state_packet(100 + k, c.x));
        pause_and_drain(c.stranger, c.stranger_replies, 500);
      }
    send_to(c.stranger, c.server, state_packet(200, c.x, bye));
    for (int k = 0; k < 20; ++k)
      pause_and_drain(c.stranger, c.stranger_replies, 500);
    ENSURE(!c.stranger_replies.empty() && c.stranger_replies.back().hips == 1);
    for (const Reply &r : c.stranger_replies)
      ENSURE(r.in_contact == 0);
    const std::size_t before_return = c.replies.size();
    for (std::uint32_t k = 0; k < 100; ++k)
      {
        send_to(c.client, c.server, state_packet(k, c.x));
        pause_and_drain(c.client, c.replies, 500);
      }
    // Served again: commands whose tick had one of these states (not fail-safe), whatever the timing.
    std::size_t served_again = 0;
    for (std::size_t k = before_return; k < c.replies.size(); ++k)
      served_again += c.replies[k].hips == 1 && !(c.replies[k].flags & fail_safe_flag) && c.replies[k].sequence < 100 ? 1 : 0;
    ENSURE(served_again >= 20);
    for (std::size_t k = before_return; k < c.replies.size(); ++k)
      if (c.replies[k].hips == 1)
        {
          ENSURE(c.replies[k].in_contact == 0);
          break;
        }
  }

  // The tick that took the last state pressed; every later tick of the silence carries FAIL_SAFE,
  // from the very next tick on; the force is held, then ramps down without a step, and reaches 0.
  // Commands kept coming at the loop's rate until the peer timeout (1 kHz for 1 s; half of it
  // allows for a loaded machine).
  void check_silence(const std::vector<Reply> &replies, std::size_t end, std::uint32_t last, double seconds)
  {
    const Reply        *fresh = nullptr;
    std::vector<double> silent_forces;
    bool                all_flagged = true;
    for (std::size_t k = 0; k < end; ++k)
      {
        const Reply &r = replies[k];
        if (r.sequence == last && !(r.flags & fail_safe_flag) && !fresh)
          fresh = &r;
        else if (fresh && r.tick > fresh->tick)
          {
            all_flagged = all_flagged && (r.flags & fail_safe_flag) && (r.hip_flags & 32u);
            silent_forces.push_back(norm(r.force));
          }
      }
    ENSURE(fresh && fresh->in_contact == 1 && fresh->force[2] > 0.0);
    ENSURE(all_flagged && !silent_forces.empty());
    if (fresh && !silent_forces.empty())
      {
        const double held = norm(fresh->force);
        ENSURE_NEAR(silent_forces.front(), held, 1e-12 * held); // held, not dropped
        double largest_step = 0.0, previous = held;
        for (double f : silent_forces)
          largest_step = std::max(largest_step, previous - f), previous = f;
        ENSURE(silent_forces.back() == 0.0);
        // A ramp of 50 ms: at most held / 50 per tick, twice that if the loop missed a period.
        ENSURE(largest_step <= 2.0 * held / 50.0);
        std::printf("silence: %.3f N held, then ramped to 0 (largest step %.4f N, %zu fail-safe commands)\n", held,
                    largest_step, silent_forces.size());
      }
    ENSURE(double(silent_forces.size()) >= 0.5 * 1000.0 * std::min(1.0, seconds));
  }

  // Teleported 1 m deep: every force finite and within the device's limit, the limit reached.
  void check_teleport(const std::vector<Reply> &replies, const Teleport &t)
  {
    const double max_force      = modalrt_device_default_def().max_force;
    double       teleport_force = 0.0;
    bool         teleport_seen = false, within_limit = true;
    for (const Reply &r : replies)
      {
        within_limit = within_limit && std::isfinite(norm(r.force)) && norm(r.force) <= max_force * (1.0 + 1e-12);
        if (r.sequence >= t.first && r.sequence <= t.last && r.sequence > 1000)
          teleport_seen = true, teleport_force = std::max(teleport_force, norm(r.force));
      }
    ENSURE(teleport_seen && within_limit);
    ENSURE_RELATIVE(teleport_force, max_force, 1e-12);
  }

  void check_stats(std::size_t intruder_refusals)
  {
    const std::string stats = read_text("serve_out/stats.json");
    ENSURE(json_number(stats, "foreign_packets") == 1);
    ENSURE(json_number(stats, "bad_version_packets") == 1);
    // The bridge counts every packet without the token; loopback may have dropped a refusal.
    ENSURE(json_number(stats, "token_refusals") >= double(intruder_refusals));
    ENSURE(json_number(stats, "refusals_sent") == 2 + json_number(stats, "token_refusals"));
    ENSURE(json_number(stats, "stale_packets") == 5); // 3, and the first 2 numbers of the restarted counter
    ENSURE(json_number(stats, "bad_packets") == 2);
    ENSURE(json_number(stats, "hellos") >= 2); // until the bridge answered, and the counter restart
    ENSURE(json_number(stats, "byes") == 1);
    ENSURE(json_number(stats, "peer_timeouts") == 1);
    // The client (HELLO until answered: each a session start), its HELLO at 0, its restart on a new
    // port, the second device, the client again; the counter restart without HELLO and the takeover.
    ENSURE(json_number(stats, "sessions") >= 5);
    ENSURE(json_number(stats, "restarts") == 1);
    ENSURE(json_number(stats, "takeovers") == 1);
    ENSURE(json_number(stats, "clamped_forces") > 0);
    ENSURE(json_number(stats, "states_accepted") >= 800);
    ENSURE(json_number(stats, "missing_ticks") > 0);
    ENSURE(json_number(stats, "allocations_after_start") == 0);
    ENSURE(json_number(stats, "non_finite_outputs") == 0);
    ENSURE(stats.find("\"stopped_by\": \"signal\"") != std::string::npos);
  }

  // The token the later bridges are given with --token (no token file written).
  constexpr char given_token_hex[] = "0123456789ABCDEFfedcba9876543210";

  // 6. Sliding through the bridge (--contact proxy, mu_s 0.3, mu_d 0.2): a client presses 2 mm into
  // the lattice's top face near the root and drags its HIP 40 mm along x at 0.04 m/s. The command
  // carries the proxy: its HIP flags have SLIDING (128) while it slides, its position is the proxy's
  // on the surface (above the pressing HIP and behind it, by the coupling force over K), and the
  // force's tangential part is mu_d times the normal one. The snap bridge above never sets SLIDING.
  void slide_through_the_bridge(int port, const std::vector<Reply> &snap_replies)
  {
    constexpr std::uint32_t sliding_flag = 128u;
    const pid_t bridge = start_bridge(port, "_proxy", {"--peer-timeout", scenario_peer_timeout, "--contact", "proxy", "--friction", "0.3,0.2", "--no-plot", "--token", given_token_hex});
    ENSURE(parse_hex(given_token_hex, bridge_token));
    double      x[3]   = {0.05, 0.025, 0.015};
    Greeted     g      = greet(port, 7, x);
    const int   client = g.socket;
    const sockaddr_in   server   = g.server;
    std::vector<Reply> &replies  = g.replies;
    std::uint32_t      &sequence = g.sequence;
    std::vector<std::array<double, 3>> sent; // the HIP position of each sequence number from the first
    const std::uint32_t                first = sequence + 1;
    const int                          press = 800, drag = 2000; // 0.5 ms each
    for (int k = 0; k < press + drag; ++k)
      {
        x[2] = 0.015 - 0.007 * std::min(1.0, k / 400.0); // 2 mm below the top face at z = 0.01
        x[0] = 0.05 + (k < press ? 0.0 : 0.04 * (k - press) * 0.0005);
        auto packet = state_packet(++sequence, x);
        const double velocity = k < press ? 0.0 : 0.04;
        std::memcpy(&packet[32 + 24], &velocity, 8);
        send_to(client, server, packet);
        sent.push_back({x[0], x[1], x[2]});
        pause_and_drain(client, replies, 500);
      }
    leave_and_stop(g, x, bridge);
    const double K = 1000.0, mu_d = 0.2; // [N/m] the default coupling, the bridge's --friction
    std::size_t  sliding = 0;
    double       worst_ratio = 0.0, worst_gap = 0.0, lag = 0.0;
    for (const Reply &r : replies)
      {
        if (r.hips != 1 || !(r.hip_flags & sliding_flag) || r.sequence < first || r.sequence - first >= sent.size())
          continue;
        const auto  &hip = sent[r.sequence - first];
        const double tangential = std::hypot(r.force[0], r.force[1]), normal = r.force[2];
        ENSURE(r.in_contact == 1 && normal > 0.2);
        worst_ratio = std::max(worst_ratio, std::fabs(tangential / normal - mu_d) / mu_d);
        // The proxy is on the surface above the HIP, by the normal force over K (the lattice's top face
        // moves less than that between two states).
        worst_gap = std::max(worst_gap, std::fabs((r.position[2] - hip[2]) - normal / K) / (normal / K));
        lag       = std::max(lag, hip[0] - r.position[0]);
        ++sliding;
      }
    std::size_t snap_sliding = 0;
    for (const Reply &r : snap_replies)
      snap_sliding += (r.hip_flags & sliding_flag) != 0;
    std::printf("  slide through the bridge: %zu commands flagged SLIDING, F_t/F_n within %.2e of mu_d, proxy above "
                "the HIP by F_n/K within %.1e, behind it by up to %.2f mm; the snap bridge: %zu flagged\n",
                sliding, worst_ratio, worst_gap, 1e3 * lag, snap_sliding);
    ENSURE(sliding > 500 && worst_ratio < 0.05 && worst_gap < 0.3 && lag > 0.0001);
    ENSURE(snap_sliding == 0);
    const std::string stats = read_text("serve_out_proxy/stats.json");
    ENSURE(json_number(stats, "length_m") > 0.03); // its slide, found by the loop as run's
    close(client);
  }
  // 7. The validity map through the bridge: on a basis with one (vertex 15 of the tip space: F5 =
  // 1.75 N, the default level), a client presses 8 mm into it and lifts off; every command in contact
  // carries BEYOND_VALIDITY (256) in its HIP flags exactly when its force exceeds 1.75 N; stats.json
  // counts them. The first bridge's basis has no map: never flagged.
  void validity_through_the_bridge(int port, const std::vector<Reply> &plain_replies)
  {
    constexpr std::uint32_t beyond_flag = 256u;
    modalrt::LatticeOptions o;
    o.patch_radius   = 0.03;
    o.damping        = {0.7, 0.7};
    o.validity_force = true;
    ENSURE(modalrt::write_basis_file("serve_validity.mrt", modalrt::make_lattice_cantilever(o)));
    const pid_t bridge = start_bridge(port, "_validity", {"--peer-timeout", scenario_peer_timeout, "--no-plot", "--token", given_token_hex}, "serve_validity.mrt");
    ENSURE(parse_hex(given_token_hex, bridge_token));
    double      x[3]   = {0.15, 0.025, 0.015};
    Greeted     g      = greet(port, 3, x);
    for (int k = 0; k < 3000; ++k) // 0.5 ms each: down 13 mm (8 mm below the top face) and back up
      {
        const double s = k < 1500 ? k / 1500.0 : (3000 - k) / 1500.0;
        x[2]           = 0.015 - 0.013 * s * s * (3 - 2 * s);
        send_to(g.socket, g.server, state_packet(++g.sequence, x));
        pause_and_drain(g.socket, g.replies, 500);
      }
    leave_and_stop(g, x, bridge);
    std::size_t flagged = 0, contact = 0, mismatches = 0, plain_flagged = 0;
    double      largest = 0.0;
    for (const Reply &r : g.replies)
      {
        if (r.hips != 1)
          continue;
        const bool beyond = (r.hip_flags & beyond_flag) != 0;
        flagged += beyond;
        if (r.in_contact)
          {
            ++contact;
            largest = std::max(largest, norm(r.force));
            mismatches += beyond != (norm(r.force) > 1.75);
          }
        else
          mismatches += beyond;
      }
    for (const Reply &r : plain_replies)
      plain_flagged += (r.hip_flags & beyond_flag) != 0;
    const std::string stats = read_text("serve_out_validity/stats.json");
    std::printf("  validity through the bridge: %zu of %zu commands in contact flagged BEYOND_VALIDITY (|F| > F5 = "
                "1.75 N, up to %.3f N), %zu mismatches; stats.json beyond_ticks %g; the bridge without a map: %zu "
                "flagged\n",
                flagged, contact, largest, mismatches, json_number(stats, "beyond_ticks"), plain_flagged);
    ENSURE(flagged > 100 && contact > flagged && mismatches == 0 && plain_flagged == 0);
    ENSURE(json_number(stats, "beyond_ticks") >= double(flagged)); // every tick counted, commands sent or not
    close(g.socket);
  }


  // 8. serve with the Touch profile: a press in to 4 mm, 20 mm deep at once (a teleport) and out; every
  // force commanded is within the Touch's 3.3 N and the stiffness it renders (F_n over the HIP's travel
  // below the lattice's top face at z = 0.01 m) within its 0.4 N/mm.
  void touch_through_the_bridge(int port)
  {
    const pid_t bridge = start_bridge(port, "_touch", {"--peer-timeout", scenario_peer_timeout, "--profile", "touch", "--haptic-scale", "0.2", "--no-plot", "--token", given_token_hex});
    ENSURE(parse_hex(given_token_hex, bridge_token));
    double      x[3]   = {0.05, 0.025, 0.015};
    Greeted     g      = greet(port, 11, x);
    std::vector<std::array<double, 3>> sent;
    const std::uint32_t first = g.sequence + 1;
    for (int k = 0; k < 3000; ++k) // 0.5 ms each
      {
        const double depth = k < 1600 ? 0.004 * std::min(1.0, k / 1200.0) : k < 1700 ? 0.02 : -0.005;
        x[2]               = 0.01 - depth;
        send_to(g.socket, g.server, state_packet(++g.sequence, x));
        sent.push_back({x[0], x[1], x[2]});
        pause_and_drain(g.socket, g.replies, 500);
      }
    leave_and_stop(g, x, bridge);
    double largest = 0.0, stiffest = 0.0;
    std::size_t in_contact = 0, pressed = 0, pressed_in_contact = 0; // pressed: answers to states 1 mm deep or more
    for (const Reply &r : g.replies)
      {
        if (r.hips != 1 || r.sequence < first || r.sequence - first >= sent.size())
          continue;
        largest = std::max(largest, norm(r.force));
        const double travel = 0.01 - sent[r.sequence - first][2];
        if (r.in_contact && travel > 1e-4)
          {
            stiffest = std::max(stiffest, r.force[2] / travel);
            ++in_contact;
          }
        if (travel >= 1e-3)
          {
            ++pressed;
            pressed_in_contact += r.in_contact;
          }
      }
    // How many commands come back depends on how the machine schedules the client; every one that
    // answers a state 1 mm deep must be in contact.
    std::printf("  the Touch through the bridge: %zu commands in contact (%zu of %zu answering states 1 mm deep or "
                "more), largest force %.4f N (limit 3.3), stiffest %.4f N/mm rendered (limit 0.4)\n",
                in_contact, pressed_in_contact, pressed, largest, 1e-3 * stiffest);
    ENSURE(pressed > 100 && pressed_in_contact == pressed);
    ENSURE(largest <= 3.3 * (1.0 + 1e-12));
    ENSURE(stiffest <= 400.0 * (1.0 + 1e-9));
    ENSURE(read_text("serve_out_touch/stats.json").find("\"profile\": \"touch\"") != std::string::npos);
    close(g.socket);
  }
  // Two designs through the bridge (--design-b): the client holds a press and asks for design B, then
  // A again, with the state flag; the force rises on the stiffer design without a step, and each
  // design's press is in presses.csv.
  void designs_through_the_bridge(int port)
  {
    constexpr std::uint32_t design_b = 1u << 2;
    const pid_t bridge = start_bridge(port, "_designs",
                                      {"--peer-timeout", scenario_peer_timeout, "--design-b", "serve_lattice_stiffer.mrt", "--no-plot", "--token", given_token_hex});
    ENSURE(parse_hex(given_token_hex, bridge_token));
    double              x[3]  = {0.125, 0.025, 0.015};
    Greeted             g     = greet(port, 21, x);
    const std::uint32_t first = g.sequence + 1;
    std::vector<std::uint32_t> asked; // per state sent: its design flag
    for (int k = 0; k < 4800; ++k)    // 0.5 ms each: A, B, A for 0.8 s each
      {
        x[2]                      = 0.01 - 0.003 * std::min(1.0, k / 400.0);
        const std::uint32_t flags = k >= 1600 && k < 3200 ? design_b : 0;
        send_to(g.socket, g.server, state_packet(++g.sequence, x, flags));
        asked.push_back(flags);
        pause_and_drain(g.socket, g.replies, 500);
      }
    leave_and_stop(g, x, bridge);
    double largest_step = 0.0, previous = std::nan(""), settled[3] = {0.0, 0.0, 0.0};
    std::size_t in_contact = 0;
    for (const Reply &r : g.replies)
      {
        if (r.hips != 1 || r.sequence < first || r.sequence - first >= asked.size() || !r.in_contact)
          continue;
        ++in_contact;
        const std::uint32_t k = r.sequence - first;
        if (k > 600 && std::isfinite(previous))
          largest_step = std::max(largest_step, std::abs(r.force[2] - previous));
        previous = r.force[2];
        if (k % 1600 > 1400) // the last 0.1 s of each phase: settled
          settled[k / 1600] = r.force[2];
      }
    std::printf("  two designs through the bridge: %zu of %zu commands in contact; settled force A %.4f N, B %.4f N, "
                "A %.4f N; largest change between commands after the landing %.4f N\n",
                in_contact, g.replies.size(), settled[0], settled[1], settled[2], largest_step);
    ENSURE(settled[1] > settled[0] * 1.01 && std::abs(settled[2] - settled[0]) <= 1e-3 * settled[0]);
    ENSURE(largest_step <= 0.05 * (settled[1] - settled[0]) + 1e-3);
    const std::string stats = read_text("serve_out_designs/stats.json");
    ENSURE(test::json_number(stats, "switches", stats.find("\"designs\"")) == 2);
    const std::string presses = read_text("serve_out_designs/presses.csv");
    ENSURE(presses.find(",A\n") != std::string::npos && presses.find(",B\n") != std::string::npos);
    close(g.socket);
  }

  // Runs one bridge scenario; if any of its checks fails, prints that bridge's own log, so that a
  // failure on a loaded machine says what the bridge saw (its device counters, presses, timing).
  template <typename Scenario>
  void with_log_on_failure(const std::string &suffix, Scenario scenario)
  {
    const int failures_before = test::failures();
    scenario();
    if (test::failures() != failures_before)
      std::printf("-- serve_output%s.txt --\n%s", suffix.c_str(), read_text("serve_output" + suffix + ".txt").c_str());
  }
} // namespace

int main()
{
  modalrt::LatticeOptions o;
  o.patch_radius = 0.03;
  o.damping      = {0.7, 0.7};
  ENSURE(modalrt::write_basis_file("serve_lattice.mrt", modalrt::make_lattice_cantilever(o)));
  modalrt::LatticeOptions stiffer = o;
  stiffer.stiffness_modulus *= 1.3;
  ENSURE(modalrt::write_basis_file("serve_lattice_stiffer.mrt", modalrt::make_lattice_cantilever(stiffer)));
  const int   port   = 20000 + int(getpid() % 20000);
  const pid_t bridge = start_bridge(port, "", {"--frame-rate", "2", "--token-file", "serve_token.txt"});
  bridge_token       = read_token_file("serve_token.txt");

  Clients c;
  c.server.sin_family      = AF_INET;
  c.server.sin_port        = htons(std::uint16_t(port));
  c.server.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  const Teleport teleport = press_with_faults(c);
  restart_counter(c);
  restart_on_new_port(c);
  std::size_t         intruder_refusals = intruder_while_pressing(c);
  const std::uint32_t last              = c.sequence;
  refusals(c);

  // 4. The client falls silent (a device unplugged mid-press): the loop keeps its rate; after the
  // peer timeout (1 s) no command is sent any more.
  const auto silence_start = std::chrono::steady_clock::now();
  for (int k = 0; k < 2600; ++k) // 1.3 s; a sender without the token says HELLO 100 ms into it
    {
      pause_and_drain(c.client, c.replies, 500);
      if (k == 200)
        intruder_refusals += intruder_hellos(c.server, c.x, 900, 40);
    }
  const double silence_seconds =
    std::chrono::duration<double>(std::chrono::steady_clock::now() - silence_start).count();
  const std::size_t commands_at_silence_end = c.replies.size();
  intruder_refusals += intruder_hellos(c.server, c.x, 1000, 40); // the slot free: still refused
  for (int k = 0; k < 200; ++k)
    pause_and_drain(c.client, c.replies, 500);
  ENSURE(c.replies.size() == commands_at_silence_end); // the slot is free: nobody to command
  second_device_then_return(c);

  kill(bridge, SIGINT);
  int status = 0;
  waitpid(bridge, &status, 0);
  const std::string log = read_text("serve_output.txt");
  std::printf("%s", log.c_str());
  ENSURE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  struct stat token_status{};
  ENSURE(stat("serve_token.txt", &token_status) != 0); // removed at exit
  ENSURE(log.find("token in serve_token.txt") != std::string::npos);
  ENSURE(log.find("packets without the bridge's token (the first from 127.0.0.1:") != std::string::npos);
  check_silence(c.replies, commands_at_silence_end, last, silence_seconds);
  check_teleport(c.replies, teleport);
  check_stats(intruder_refusals);
  close(c.client);
  close(c.restarted);
  close(c.stranger);
  with_log_on_failure("_proxy", [&] { slide_through_the_bridge(port + 1 >= 40000 ? port - 1 : port + 1, c.replies); });
  with_log_on_failure("_validity",
                      [&] { validity_through_the_bridge(port + 2 >= 40000 ? port - 2 : port + 2, c.replies); });
  with_log_on_failure("_touch", [&] { touch_through_the_bridge(port + 3 >= 40000 ? port - 3 : port + 3); });
  with_log_on_failure("_designs", [&] { designs_through_the_bridge(port + 4 >= 40000 ? port - 4 : port + 4); });
  return test::finish("test_serve");
}
